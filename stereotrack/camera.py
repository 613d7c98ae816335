"""Camera and rig model: projection, back-projection, triangulation, calibration YAML.

Convention (OpenCV, formats.md section 1): ``x_cam = R @ X_world + t`` and the
pixel is ``K @ distort(x_cam[:2] / x_cam[2])``.  Everything is vectorised over
points; a rig holds two or more cameras.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property, lru_cache
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from .errors import StereotrackError
from .files import dump_yaml, load_yaml, write_text_atomic

_DIST_LENGTHS = (0, 4, 5, 8, 12, 14)
# Iterative undistortion to machine precision (OpenCV's default stops after 5 steps).
_UNDISTORT_CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-14)


_kernels = None


def kernels():
    """The compiled kernels, imported on first use: numba's import and start-up (about a second) is paid
    only by commands that project or triangulate, not by ``--help``."""
    global _kernels
    if _kernels is None:
        from . import kernels as module

        _kernels = module
    return _kernels


def _tilt_matrix(tau_x: float, tau_y: float) -> np.ndarray:
    """OpenCV's tilted-sensor projection (``computeTiltProjectionMatrix``) for the 13th and 14th coefficients."""
    cx, sx, cy, sy = math.cos(tau_x), math.sin(tau_x), math.cos(tau_y), math.sin(tau_y)
    rot_x = np.array([[1.0, 0.0, 0.0], [0.0, cx, sx], [0.0, -sx, cx]])
    rot_y = np.array([[cy, 0.0, -sy], [0.0, 1.0, 0.0], [sy, 0.0, cy]])
    rot = rot_y @ rot_x
    proj_z = np.array([[rot[2, 2], 0.0, -rot[0, 2]], [0.0, rot[2, 2], -rot[1, 2]], [0.0, 0.0, 1.0]])
    return proj_z @ rot


@dataclass(frozen=True, eq=False)
class Camera:
    """One calibrated camera: intrinsics K, distortion, and world -> camera pose."""

    name: str
    image_size: tuple[int, int]  # (width, height) in pixels
    K: np.ndarray  # 3 x 3
    dist: np.ndarray  # 0, 4, 5, 8, 12 or 14 OpenCV coefficients
    R: np.ndarray  # 3 x 3 world -> camera rotation
    t: np.ndarray  # 3 world -> camera translation, metres

    @property
    def width(self) -> int:
        return int(self.image_size[0])

    @property
    def height(self) -> int:
        return int(self.image_size[1])

    @property
    def focal_px(self) -> float:
        """Mean focal length in pixels: a ball of radius R at depth Z looks ``focal_px * R / Z`` pixels wide."""
        return 0.5 * float(self.K[0, 0] + self.K[1, 1])

    def apparent_radius(self, radius: float | np.ndarray, depth: float | np.ndarray, min_depth: float = 1e-6) -> np.ndarray:
        """Pixels a ball of ``radius`` metres spans at ``depth`` (z in this camera's frame): ``focal_px * radius / depth``."""
        return self.focal_px * radius / np.maximum(depth, min_depth)

    @property
    def centre(self) -> np.ndarray:
        """Optical centre in world coordinates."""
        return -self.R.T @ self.t

    @property
    def P(self) -> np.ndarray:
        """3 x 4 projection matrix K [R | t] (ignores distortion)."""
        return self.K @ np.hstack([self.R, self.t[:, None]])

    def to_camera(self, points: np.ndarray) -> np.ndarray:
        """World points (N x 3) in this camera's frame (N x 3)."""
        return np.asarray(points, dtype=float) @ self.R.T + self.t

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Project world points (N x 3) to pixels.

        Returns (pixels N x 2, in_front N bool). Points behind the camera get
        NaN pixels and in_front False.
        """
        uv, in_front, _ = self.view(points)
        return uv, in_front

    def view(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``project`` plus every point's depth (z in this camera's frame): (pixels, in_front, depth)."""
        points = np.ascontiguousarray(points, dtype=float).reshape(-1, 3)
        return kernels().project_points(points, *self._kernel_arrays)

    @cached_property
    def _kernel_arrays(self) -> tuple[np.ndarray, ...]:
        """R, t, K, the distortion as 12 coefficients and the tilted-sensor matrix, as the projection kernel takes them."""
        d = np.asarray(self.dist, dtype=float).ravel()
        k = np.zeros(12)
        k[: min(d.size, 12)] = d[:12]
        tilt = _tilt_matrix(d[12], d[13]) if d.size == 14 else np.eye(3)
        f64 = lambda a: np.ascontiguousarray(a, dtype=np.float64)  # noqa: E731
        return f64(self.R), f64(self.t).ravel(), f64(self.K), k, tilt

    def in_image(self, uv: np.ndarray) -> np.ndarray:
        """Per pixel (N x 2): inside this camera's image (NaN pixels of points behind it are not)."""
        return (uv[:, 0] >= 0) & (uv[:, 0] < self.width) & (uv[:, 1] >= 0) & (uv[:, 1] < self.height)

    def distort_normalised(self, xn: np.ndarray) -> np.ndarray:
        """Normalised undistorted coordinates (N x 2) -> distorted pixels (N x 2)."""
        xn = np.asarray(xn, dtype=float).reshape(-1, 2)
        _, _, K, k, tilt = self._kernel_arrays
        points = np.column_stack([xn, np.ones(len(xn))])  # on the plane z = 1 of the camera frame
        return kernels().project_points(points, np.eye(3), np.zeros(3), K, k, tilt)[0]

    def undistort_pixels(self, pixels: np.ndarray) -> np.ndarray:
        """Distorted pixels (N x 2) -> normalised undistorted coordinates (N x 2)."""
        px = np.ascontiguousarray(pixels, dtype=np.float64).reshape(-1, 2)
        if len(px) == 0:
            return np.zeros((0, 2))
        if not self._distorted:
            return kernels().unproject_pinhole(px, self._kernel_arrays[2])
        out = cv2.undistortPoints(px.reshape(-1, 1, 2), self.K, self.dist, criteria=_UNDISTORT_CRITERIA)
        return out.reshape(-1, 2)

    @cached_property
    def _distorted(self) -> bool:
        return bool(np.any(self.dist))

    def rays(self, pixels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Back-project pixels (N x 2) to world rays: (origins N x 3, unit directions N x 3)."""
        R, t = self._kernel_arrays[:2]
        return kernels().rays_from_normalised(self.undistort_pixels(pixels), R, t)

    def depth(self, points: np.ndarray) -> np.ndarray:
        """Depth (z in the camera frame) of world points (N x 3)."""
        return self.to_camera(points)[:, 2]

    def axis_cosines(self, directions: np.ndarray) -> np.ndarray:
        """Per world unit direction (N x 3, as ``rays`` gives them): the cosine of its angle to this camera's optical
        axis. A point at depth z lies z / cos along its ray, and a ball there looks stretched away from the image's
        centre by 1 / cos."""
        return np.asarray(directions, dtype=float).reshape(-1, 3) @ self.R[2]


@dataclass(frozen=True, eq=False)
class Rig:
    """Two or more cameras sharing one world frame."""

    cameras: tuple[Camera, ...]
    world: str = "cam0"
    quality: dict[str, Any] | None = field(default=None)

    def __post_init__(self) -> None:
        if len(self.cameras) < 2:
            raise StereotrackError(f"a rig needs at least 2 cameras, got {len(self.cameras)}")

    @property
    def names(self) -> list[str]:
        return [c.name for c in self.cameras]

    def __len__(self) -> int:
        return len(self.cameras)

    def __getitem__(self, key: int | str) -> Camera:
        if isinstance(key, str):
            for cam in self.cameras:
                if cam.name == key:
                    return cam
            raise StereotrackError(f"no camera named {key!r} in the rig (cameras: {', '.join(self.names)})")
        return self.cameras[key]

    def project(self, points: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
        """Project world points into every camera: a list of (pixels, in_front)."""
        return [cam.project(points) for cam in self.cameras]

    def views(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Every point in every camera at once: pixels (C x N x 2), in front (C x N), depth (C x N)."""
        return tuple(np.stack(a) for a in zip(*(cam.view(points) for cam in self.cameras)))

    def triangulate(self, pixels: Sequence[np.ndarray | None]) -> np.ndarray:
        """Triangulate one point from one pixel (u, v) per camera; None skips a camera."""
        obs = [(cam, np.asarray(p, dtype=float).reshape(1, 2)) for cam, p in zip(self.cameras, pixels) if p is not None]
        if len(obs) < 2:
            raise ValueError("triangulation needs observations from at least 2 cameras")
        return triangulate_points([c for c, _ in obs], [p for _, p in obs])[0]

    def check_images(self, images: Sequence[np.ndarray]) -> None:
        """Refuse frames whose count or size does not match the calibration (a user's camera settings)."""
        if len(images) != len(self.cameras):
            raise StereotrackError(f"got {len(images)} images per frame but the calibration has {len(self.cameras)} cameras")
        for cam, img in zip(self.cameras, images):
            if img.shape[1] != cam.width or img.shape[0] != cam.height:
                raise StereotrackError(
                    f"frame from {cam.name} is {img.shape[1]}x{img.shape[0]} but the calibration says {cam.width}x{cam.height} "
                    f"(set the camera to the calibrated resolution or recalibrate)"
                )

    def baseline(self, i: int = 0, j: int = 1) -> float:
        return float(np.linalg.norm(self.cameras[i].centre - self.cameras[j].centre))


@lru_cache(maxsize=16)
def stacked_kernel_arrays(cameras: tuple[Camera, ...]) -> tuple[np.ndarray, ...]:
    """Every camera's projection arrays (see ``Camera.view``) stacked along a first axis, for kernels
    that project into all cameras at once."""
    return tuple(np.ascontiguousarray(np.stack(a)) for a in zip(*(cam._kernel_arrays for cam in cameras)))


def triangulate_points(cameras: Sequence[Camera], pixels: Sequence[np.ndarray]) -> np.ndarray:
    """Triangulate M points seen by every given camera (pixels: one M x 2 array per camera).

    Linear least squares (DLT) on undistorted normalised coordinates, solved
    for all points at once; exact observations give the exact point.
    """
    if len(pixels[0]) == 0:
        return np.zeros((0, 3))
    xn = np.stack([cam.undistort_pixels(px) for cam, px in zip(cameras, pixels)])  # C x M x 2
    P = np.stack([np.hstack([cam.R, cam.t[:, None]]) for cam in cameras])  # normalised projections
    return kernels().triangulate_dlt(xn, np.ascontiguousarray(P, dtype=float))


def triangulate_with_covariance(
    cameras: Sequence[Camera], pixels: Sequence[np.ndarray], pixel_sigma: float, pixel_covs: Sequence[np.ndarray] | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """``triangulate_points`` plus each point's covariance for isotropic pixel noise ``pixel_sigma``:
    sigma^2 J J', J (3 x 4) the derivative of the first two cameras' triangulation with respect to
    their four pixel coordinates, by central differences. It grows along the viewing direction with
    depth / baseline, as it should. ``pixel_covs`` (the first two cameras' M x 2 x 2, pixels^2) replace sigma^2 I
    where the noise is not the same in every direction (a streak's centroid along it). Returns (points M x 3,
    covariances M x 3 x 3)."""
    m = len(pixels[0])
    if m == 0:
        return np.zeros((0, 3)), np.zeros((0, 3, 3))
    h = 0.5  # pixels
    steps = np.vstack([np.eye(4) * h, -np.eye(4) * h])  # +h then -h on each of the four pixel coordinates
    # Row s * m + i: step s on point i.
    moved = [(pixels[0][None] + steps[:, None, :2]).reshape(-1, 2), (pixels[1][None] + steps[:, None, 2:]).reshape(-1, 2)]
    if len(cameras) == 2:  # one triangulation call for the points and their 8 perturbed copies
        both = triangulate_points(cameras, [np.vstack([p, q]) for p, q in zip(pixels, moved)])
        points, moved_points = both[:m], both[m:]
    else:
        points, moved_points = triangulate_points(cameras, pixels), triangulate_points(cameras[:2], moved)
    moved_points = moved_points.reshape(8, m, 3)
    J = ((moved_points[:4] - moved_points[4:]) / (2 * h)).transpose(1, 2, 0)  # m x 3 x 4
    if pixel_covs is None:
        return points, pixel_sigma**2 * J @ J.transpose(0, 2, 1)
    S = np.zeros((m, 4, 4))
    S[:, :2, :2], S[:, 2:, 2:] = pixel_covs[0], pixel_covs[1]
    return points, J @ S @ J.transpose(0, 2, 1)


def look_at(eye: Sequence[float], target: Sequence[float], up: Sequence[float] = (0.0, -1.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    """World -> camera (R, t) for a camera at ``eye`` looking at ``target``.

    The camera's y axis points along ``up``'s opposite in the image (image y
    grows downwards), OpenCV style: z forward, x right, y down.
    """
    eye = np.asarray(eye, float)
    z = np.asarray(target, float) - eye
    z /= np.linalg.norm(z)
    down = -np.asarray(up, float)
    x = np.cross(down, z)
    if np.linalg.norm(x) < 1e-9:
        raise ValueError("look_at: 'up' is parallel to the viewing direction")
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    R = np.stack([x, y, z])
    return R, -R @ eye


def intrinsics_from_fov(width: int, height: int, hfov_deg: float) -> np.ndarray:
    """Pinhole K with square pixels, principal point at the image centre."""
    f = (width / 2) / math.tan(math.radians(hfov_deg) / 2)
    return np.array([[f, 0, (width - 1) / 2], [0, f, (height - 1) / 2], [0, 0, 1.0]])


# --------------------------------------------------------------------------- YAML


def _fail(path: Path | str, field_name: str, what: str) -> StereotrackError:
    return StereotrackError(f"{path}: field '{field_name}': {what}")


def _matrix(path, field_name, value, shape) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise _fail(path, field_name, f"expected numbers in a {shape[0]}x{shape[1] if len(shape) > 1 else ''} list".rstrip("x")) from None
    if arr.shape != shape:
        raise _fail(path, field_name, f"expected shape {list(shape)}, got {list(arr.shape)}")
    if not np.all(np.isfinite(arr)) or np.abs(arr).max() > 1e9:
        raise _fail(path, field_name, "contains a non-finite or absurdly large number")
    return arr


def _camera_from_dict(path, i: int, d: Any) -> Camera:
    where = f"cameras[{i}]"
    if not isinstance(d, dict):
        raise _fail(path, where, "expected a mapping with name, image_size, K, dist, R, t")
    for key in ("name", "image_size", "K", "R", "t"):
        if key not in d:
            raise _fail(path, f"{where}.{key}", "missing")
    name = d["name"]
    if isinstance(name, bool) or not isinstance(name, (str, int)) or not str(name).strip() or any(c in str(name) for c in ",\n\r"):
        raise _fail(path, f"{where}.name", f"expected a camera name (text without commas), got {name!r:.60}")
    name = str(name)
    size = d["image_size"]
    if not (
        isinstance(size, (list, tuple))
        and len(size) == 2
        and all(isinstance(v, int) and not isinstance(v, bool) and 0 < v <= 100_000 for v in size)
    ):
        raise _fail(path, f"{where}.image_size", f"expected [width, height] in whole pixels, got {size!r}")
    K = _matrix(path, f"{where}.K", d["K"], (3, 3))
    if K[0, 0] <= 0 or K[1, 1] <= 0 or abs(K[2, 2] - 1) > 1e-9 or np.any(K[1:, 0] != 0) or np.any(K[2, :2] != 0):
        raise _fail(path, f"{where}.K", "expected [[fx, s, cx], [0, fy, cy], [0, 0, 1]] with fx, fy > 0")
    dist_raw = d.get("dist", [])
    dist_raw = [] if dist_raw is None else dist_raw
    try:
        dist = np.asarray(dist_raw, dtype=float).ravel()
    except (TypeError, ValueError):
        raise _fail(path, f"{where}.dist", "expected a list of numbers") from None
    if dist.size not in _DIST_LENGTHS:
        raise _fail(path, f"{where}.dist", f"expected 0, 4, 5, 8, 12 or 14 coefficients, got {dist.size}")
    if not np.all(np.isfinite(dist)) or np.abs(dist).max(initial=0.0) > 1e6:
        raise _fail(path, f"{where}.dist", f"expected finite distortion coefficients, got {dist.tolist()}")
    R = _matrix(path, f"{where}.R", d["R"], (3, 3))
    if np.abs(R @ R.T - np.eye(3)).max() > 1e-5 or np.linalg.det(R) < 0:
        raise _fail(path, f"{where}.R", "is not a rotation matrix (R R^T must be I and det(R) = +1)")
    t = _matrix(path, f"{where}.t", d["t"], (3,))
    return Camera(name=name, image_size=(int(size[0]), int(size[1])), K=K, dist=dist, R=R, t=t)


def rig_from_dict(data: Any, path: Path | str = "<calibration>") -> Rig:
    """Build and validate a rig from parsed calibration YAML (formats.md section 1)."""
    if not isinstance(data, dict):
        raise _fail(path, "<top level>", "expected a mapping with 'cameras'")
    cams = data.get("cameras")
    if not isinstance(cams, list) or len(cams) < 2:
        raise _fail(path, "cameras", "expected a list of at least 2 cameras")
    cameras = tuple(_camera_from_dict(path, i, c) for i, c in enumerate(cams))
    names = [c.name for c in cameras]
    if len(set(names)) != len(names):
        raise _fail(path, "cameras", f"camera names must be unique, got {names}")
    world = data.get("world", cameras[0].name)
    if not isinstance(world, str):
        raise _fail(path, "world", f"expected a camera name ({', '.join(names)}) or 'custom', got {world!r:.60}")
    if world != "custom" and world not in names:
        raise _fail(path, "world", f"expected a camera name ({', '.join(names)}) or 'custom', got {world!r}")
    quality = data.get("quality")
    if quality is not None and not isinstance(quality, dict):
        raise _fail(path, "quality", "expected a mapping")
    return Rig(cameras=cameras, world=world, quality=quality)


def rig_to_dict(rig: Rig) -> dict[str, Any]:
    def lst(a: np.ndarray) -> list:
        return np.asarray(a, dtype=float).tolist()

    out: dict[str, Any] = {"version": 1, "units": "metres", "world": rig.world, "cameras": []}
    for c in rig.cameras:
        out["cameras"].append(
            {"name": c.name, "image_size": [c.width, c.height], "K": lst(c.K), "dist": lst(c.dist), "R": lst(c.R), "t": lst(c.t)}
        )
    if rig.quality is not None:
        out["quality"] = rig.quality
    return out


def load_rig(path: str | Path) -> Rig:
    """Read and validate a calibration YAML file."""
    data = load_yaml(path, "calibration file not found (run 'stereotrack calibrate' or pass --calib FILE)")
    return rig_from_dict(data, Path(path))


def save_rig(rig: Rig, path: str | Path) -> None:
    write_text_atomic(path, dump_yaml(rig_to_dict(rig)))


def with_image_size(cam: Camera, size: tuple[int, int]) -> Camera:
    return replace(cam, image_size=(int(size[0]), int(size[1])))
