"""Rendered calibration boards for a known rig: the known answer calibration is tested against.

Each output pixel is traced back through the camera model (``Camera``: the
same distortion as everywhere else) to the board plane and the board texture
is sampled there, at 2 x 2 samples per pixel averaged (anti-aliasing), then
mildly blurred and given sensor noise. Poses are drawn from a seeded
``numpy.random.Generator`` and kept only if the whole board (with its white
quiet zone) is inside every camera's image (or every camera of a group).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from scipy.interpolate import RectBivariateSpline

from ..calibration.boards import Board, board_image
from ..camera import Camera, Rig

SUPERSAMPLE = 2
_TEXTURE_PX_PER_SQUARE = 120
_BLACK, _WHITE, _BACKGROUND = 30.0, 225.0, 120.0


@dataclass(frozen=True, eq=False)
class BoardPose:
    """Board -> world: a board-frame point p is at ``R @ p + t`` in the world."""

    R: np.ndarray
    t: np.ndarray

    def to_world(self, points: np.ndarray) -> np.ndarray:
        return np.asarray(points, float) @ self.R.T + self.t


def _rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    return cv2.Rodrigues(np.asarray(axis, float) / np.linalg.norm(axis) * angle)[0]


def board_outline(board: Board) -> np.ndarray:
    """Board-frame corners of the printed area with a one-square quiet zone (4 x 3)."""
    m = board.square
    w, h = board.size_m
    return np.array([[-m, -m, 0], [w + m, -m, 0], [w + m, h + m, 0], [-m, h + m, 0]], float)


def random_board_poses(
    rig: Rig,
    board: Board,
    n: int,
    rng: np.random.Generator,
    fill: tuple[float, float] = (0.35, 0.75),
    max_tilt_deg: float = 40.0,
    max_spin_deg: float = 25.0,
    min_tilt_deg: float = 0.0,
    margin_px: float = 8.0,
    cameras: Sequence[int] | None = None,
) -> list[BoardPose]:
    """``n`` board poses fully visible in the given cameras (default: all).

    ``fill`` is the range of the board's width as a share of the image width;
    the board faces the cameras, tilted by ``min_tilt_deg`` to ``max_tilt_deg``
    (tilted views pin down the focal length) and turned in its plane up to
    ``max_spin_deg``.
    """
    cams = [rig.cameras[i] for i in (range(len(rig)) if cameras is None else cameras)]
    centre = np.mean([c.centre for c in cams], axis=0)
    forward = np.mean([c.R[2] for c in cams], axis=0)
    forward /= np.linalg.norm(forward)
    down = np.mean([c.R[1] for c in cams], axis=0)
    right = np.cross(down, forward)
    right /= np.linalg.norm(right)
    down = np.cross(forward, right)
    ref = cams[0]
    hfov = 2 * math.atan(ref.width / 2 / ref.K[0, 0])
    vfov = 2 * math.atan(ref.height / 2 / ref.K[1, 1])
    outline = board_outline(board)
    mid = np.array([board.size_m[0] / 2, board.size_m[1] / 2, 0.0])
    poses: list[BoardPose] = []
    for _ in range(200 * n):
        if len(poses) == n:
            break
        share = rng.uniform(*fill)
        dist = board.size_m[0] / (share * 2 * math.tan(hfov / 2))
        lateral = rng.uniform(-0.5, 0.5, 2) * (1 - share) * 2 * dist * np.array([math.tan(hfov / 2), math.tan(vfov / 2)])
        target = centre + forward * dist + right * lateral[0] + down * lateral[1]
        # Board axes: x right, y down, z away from the cameras; then tilt and spin.
        base = np.column_stack([right, down, forward])
        tilt_axis = np.array([math.cos(a := rng.uniform(0, 2 * math.pi)), math.sin(a), 0.0])
        spin = _rotation([0, 0, 1], math.radians(rng.uniform(-max_spin_deg, max_spin_deg)))
        tilt = _rotation(tilt_axis, math.radians(rng.uniform(min_tilt_deg, max_tilt_deg)))
        R = base @ tilt @ spin
        pose = BoardPose(R, target - R @ mid)
        pts = pose.to_world(outline)
        ok = True
        for cam in cams:
            uv, front = cam.project(pts)
            if not front.all() or uv[:, 0].min() < margin_px or uv[:, 1].min() < margin_px:
                ok = False
            elif uv[:, 0].max() > cam.width - 1 - margin_px or uv[:, 1].max() > cam.height - 1 - margin_px:
                ok = False
            if not ok:
                break
        if ok:
            poses.append(pose)
    if len(poses) < n:
        raise ValueError(f"found only {len(poses)} of {n} board poses visible in every camera: use a smaller board or a closer rig")
    return poses


def calibration_rig(n_cams: int, rng: np.random.Generator, size: tuple[int, int] = (640, 480)) -> Rig:
    """Webcams in a row 25 cm apart (20 cm for two), turned slightly towards each other, each with its own
    focal length (58-68 degrees across), principal point off centre and barrel distortion: a rig to calibrate."""
    from ..camera import intrinsics_from_fov, look_at

    spacing = 0.2 if n_cams == 2 else 0.25
    cams = []
    for k in range(n_cams):
        x = (k - (n_cams - 1) / 2) * spacing
        K = intrinsics_from_fov(size[0], size[1], rng.uniform(58, 68))
        K[1, 1] *= 1 + rng.uniform(-0.004, 0.004)
        K[0, 2] += rng.uniform(-12, 12)
        K[1, 2] += rng.uniform(-10, 10)
        dist = np.array(
            [rng.uniform(-0.25, -0.05), rng.uniform(0.0, 0.12), rng.uniform(-1e-3, 1e-3), rng.uniform(-1e-3, 1e-3), rng.uniform(-0.05, 0.0)]
        )
        eye = (x, rng.uniform(-0.01, 0.01), rng.uniform(-0.01, 0.01))
        target = (-0.3 * x + rng.uniform(-0.03, 0.03), rng.uniform(-0.03, 0.03), 1.0)
        R, t = look_at(eye, target)
        cams.append(Camera(f"cam{k}", size, K, dist, R, t))
    return Rig(tuple(cams))


def lens_rig(lens: str, rng: np.random.Generator) -> Rig:
    """Two webcams 20 cm apart with square pixels and off-centre principal points, to test lens models:
    'ordinary' (59-65 degrees across, radial k1 k2 only: every lens model can describe it) or 'wide'
    (87-93 degrees, rational distortion with k4 0.7-1.0, which only --rational describes)."""
    from ..camera import intrinsics_from_fov, look_at

    hfov = {"ordinary": 62.0, "wide": 90.0}[lens]
    cams = []
    for k, x in enumerate((-0.1, 0.1)):
        K = intrinsics_from_fov(640, 480, hfov + rng.uniform(-3, 3))
        K[0, 2] += rng.uniform(-12, 12)
        K[1, 2] += rng.uniform(-10, 10)
        R, t = look_at((x, 0.0, 0.0), (-0.3 * x, 0.0, 1.0))
        if lens == "ordinary":
            dist = [rng.uniform(-0.25, -0.05), rng.uniform(0.0, 0.12), 0.0, 0.0, 0.0]
        else:
            dist = [rng.uniform(0.3, 0.6), 0.05, 0.0, 0.0, 0.0, rng.uniform(0.7, 1.0), 0.15, 0.0]
        cams.append(Camera(f"cam{k}", (640, 480), K, np.array(dist), R, t))
    return Rig(tuple(cams))


def poses_seen_by_pairs(rig: Rig, board: Board, n: int, rng: np.random.Generator, **pose_options) -> list[BoardPose]:
    """``n`` board poses, each wholly in view of at least two cameras: with three or more cameras they cycle
    through the neighbouring pairs and all cameras together (others may see the board too, or part of it).
    ``pose_options`` go to ``random_board_poses``."""
    k = len(rig)
    groups = [(0, 1)] if k == 2 else [*((i, i + 1) for i in range(k - 1)), tuple(range(k))]
    poses: list[BoardPose] = []
    for attempt in range(20 * n):
        if len(poses) == n:
            break
        try:
            poses += random_board_poses(rig, board, 1, rng, cameras=groups[attempt % len(groups)], **pose_options)
        except ValueError:  # this group cannot see the whole board at once here: the next one
            continue
    if len(poses) < n:
        raise ValueError(f"found only {len(poses)} of {n} board poses seen whole by two cameras")
    return poses


_ray_cache: dict[tuple, np.ndarray] = {}
_COARSE = 4  # undistort every 4th sample exactly, interpolate the smooth field in between


def _camera_rays(cam: Camera) -> np.ndarray:
    """Unit-z ray directions in the camera frame for every sub-pixel sample (H*s x W*s x 3)."""
    key = (cam.image_size, cam.K.tobytes(), cam.dist.tobytes())
    if key not in _ray_cache:
        s, g = SUPERSAMPLE, _COARSE
        nu, nv = cam.width * s, cam.height * s
        # coarse sample indices from -g to past the last sample, so cubic interpolation never extrapolates
        iu = np.arange(-g, nu + 2 * g, g)
        iv = np.arange(-g, nv + 2 * g, g)
        uu, vv = np.meshgrid((iu + 0.5) / s - 0.5, (iv + 0.5) / s - 0.5)  # sample centres in pixel coordinates
        xn = cam.undistort_pixels(np.column_stack([uu.ravel(), vv.ravel()])).reshape(len(iv), len(iu), 2)
        fine = np.stack([RectBivariateSpline(iv, iu, xn[..., k])(np.arange(nv), np.arange(nu)) for k in range(2)], axis=2).astype(
            np.float32
        )
        if len(_ray_cache) >= 8:
            _ray_cache.pop(next(iter(_ray_cache)))
        _ray_cache[key] = np.concatenate([fine, np.ones((nv, nu, 1), np.float32)], axis=2)
    return _ray_cache[key]


_texture_cache: dict[Board, np.ndarray] = {}


def _texture(board: Board) -> np.ndarray:
    """Board texture with a one-square white quiet zone, float grey levels."""
    if board not in _texture_cache:
        pps = _TEXTURE_PX_PER_SQUARE
        img = board_image(board, pps).astype(np.float32) / 255.0
        img = cv2.copyMakeBorder(img, pps, pps, pps, pps, cv2.BORDER_CONSTANT, value=1.0)
        _texture_cache[board] = (_BLACK + (_WHITE - _BLACK) * img).astype(np.float32)
    return _texture_cache[board]


def render_board(
    cam: Camera,
    board: Board,
    pose: BoardPose,
    rng: np.random.Generator,
    blur_sigma: float = 0.5,
    noise_sigma: float = 1.5,
) -> np.ndarray:
    """Grey uint8 image of the board at ``pose`` seen by ``cam``."""
    d = _camera_rays(cam)
    A = cam.R @ pose.R  # board axes in the camera frame
    o = cam.R @ pose.t + cam.t  # board origin in the camera frame
    # The ray through sample d meets the board at s d with s = (o . n) / (d . n); its board
    # coordinates are then A_k . (s d - o): one 3 x 3 product per sample.
    proj = d @ A.astype(np.float32)  # columns: d . x_axis, d . y_axis, d . normal
    on = float(o @ A[:, 2])
    with np.errstate(divide="ignore", invalid="ignore"):
        s = on / proj[..., 2]
    pps = _TEXTURE_PX_PER_SQUARE / board.square  # texels per metre
    quiet = _TEXTURE_PX_PER_SQUARE
    map_x = (s * proj[..., 0] - float(o @ A[:, 0])) * pps + (quiet - 0.5)
    map_y = (s * proj[..., 1] - float(o @ A[:, 1])) * pps + (quiet - 0.5)
    behind = ~(s > 0)
    map_x[behind] = -1e6
    map_y[behind] = -1e6
    big = cv2.remap(
        _texture(board),
        map_x.astype(np.float32),
        map_y.astype(np.float32),
        cv2.INTER_LINEAR,
        borderMode=cv2.BORDER_CONSTANT,
        borderValue=_BACKGROUND,
    )
    img = cv2.resize(big, (cam.width, cam.height), interpolation=cv2.INTER_AREA)
    if blur_sigma > 0:
        img = cv2.GaussianBlur(img, (0, 0), blur_sigma)
    if noise_sigma > 0:
        img = img + rng.normal(0.0, noise_sigma, img.shape).astype(np.float32)
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)


def render_views(rig: Rig, board: Board, poses: Sequence[BoardPose], rng: np.random.Generator, **kwargs) -> list[tuple[np.ndarray, ...]]:
    """One grey image per camera for every pose."""
    return [tuple(render_board(cam, board, pose, rng, **kwargs) for cam in rig.cameras) for pose in poses]


def write_image_folders(
    folder: str | Path, rig: Rig, views: Sequence[Sequence[np.ndarray]], names: Sequence[str] | None = None
) -> list[Path]:
    """Write views as ``folder/<camera>/<view>.png`` (matched by file name); returns the camera folders."""
    folder = Path(folder)
    dirs = [folder / cam.name for cam in rig.cameras]
    for d in dirs:
        d.mkdir(parents=True, exist_ok=True)
    for i, images in enumerate(views):
        name = names[i] if names is not None else f"view{i:03d}"
        for d, img in zip(dirs, images):
            cv2.imwrite(str(d / f"{name}.png"), img)
    return dirs
