"""Synthetic stereo scenes with exact ground truth: the project's measuring instrument.

A scene (``SceneSpec``) is a rig of toed-in cameras, balls on trajectories,
a textured background, optional distractors and occluders, lighting, noise,
blur and compression. ``SceneRenderer`` renders any frame on its own (true
spheres by per-pixel ray-sphere intersection through the camera model, so
perspective and lens distortion are exact); ``render_scene`` writes a
recording folder with calib.yaml, truth.csv and config.yaml.

World frame ("world: custom"): origin midway between the camera centres,
x to the right, y forward (away from the cameras), z up; gravity is -z.
Presets live in ``scenes.py``.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from .camera import Camera, Rig, intrinsics_from_fov, look_at
from .config import Config, Target, config_to_dict
from .errors import StereotrackError

# Named ball colours (BGR albedo). Pink is the paper's ball colour.
COLOURS: dict[str, tuple[int, int, int]] = {
    "pink": (150, 60, 230),
    "orange": (20, 110, 235),
    "green": (60, 190, 50),
    "blue": (210, 110, 25),
    "yellow": (30, 205, 225),
}
WORLD_UP = (0.0, 0.0, 1.0)


# --------------------------------------------------------------------------- scene description


@dataclass(frozen=True)
class RigSpec:
    """Toed-in cameras along x at z = 0, all aimed at (0, aim_distance, 0)."""

    cameras: int = 2  # >= 2; spread along x, ``baseline`` apart
    width: int = 640
    height: int = 480
    hfov: float = 60.0  # horizontal field of view, degrees
    baseline: float = 0.3  # distance between neighbouring cameras, metres
    aim_distance: float = 1.5  # metres ahead (along +y) where the optical axes meet
    dist: tuple[float, ...] = ()  # OpenCV distortion coefficients, same for every camera

    def build(self) -> Rig:
        if self.cameras < 2:
            raise StereotrackError(f"a scene needs at least 2 cameras, got {self.cameras}")
        K = intrinsics_from_fov(self.width, self.height, self.hfov)
        cams = []
        for i in range(self.cameras):
            eye = ((i - (self.cameras - 1) / 2) * self.baseline, 0.0, 0.0)
            R, t = look_at(eye, (0.0, self.aim_distance, 0.0), up=WORLD_UP)
            cams.append(Camera(f"cam{i}", (self.width, self.height), K, np.asarray(self.dist, float), R, t))
        return Rig(tuple(cams), world="custom")


@dataclass(frozen=True)
class BallSpec:
    trajectory: Any  # a trajectory from trajectories.py
    colour: str | tuple[int, int, int] = "pink"  # a name in COLOURS, or a BGR albedo (0..255 each)
    radius: float = 0.035  # metres
    appear: float = 0.0  # seconds: in the scene from this time ...
    disappear: float = float("inf")  # ... until this time

    @property
    def bgr(self) -> np.ndarray:
        return np.asarray(colour_bgr(self.colour), np.float32)

    @property
    def target_name(self) -> str:
        """The target this ball belongs to: its colour's name, or ``bgr_B_G_R``."""
        return self.colour if isinstance(self.colour, str) else "bgr_" + "_".join(str(int(c)) for c in self.colour)


def colour_bgr(colour: str | Sequence[int]) -> tuple[int, int, int]:
    if isinstance(colour, str):
        if colour not in COLOURS:
            raise StereotrackError(f"unknown ball colour {colour!r}: use one of {', '.join(COLOURS)} or a [B, G, R] triple")
        return COLOURS[colour]
    bgr = tuple(int(c) for c in colour)
    if len(bgr) != 3 or not all(0 <= c <= 255 for c in bgr):
        raise StereotrackError(f"ball colour {list(colour)!r}: expected a colour name or [B, G, R] with values 0..255")
    return bgr


@dataclass(frozen=True)
class Occluder:
    """An axis-aligned box (a thin one is a panel) that hides what is behind it."""

    centre: tuple[float, float, float]
    size: tuple[float, float, float]  # extent along x, y, z, metres
    colour: tuple[int, int, int] = (90, 95, 100)  # BGR


@dataclass(frozen=True)
class Lighting:
    direction: tuple[float, float, float] = (-0.4, -0.6, 0.7)  # towards the light (normalised on use)
    ambient: float = 0.35
    diffuse: float = 0.65
    specular: float = 0.45  # highlight strength (0 = matte)
    shininess: float = 40.0
    flicker: float = 0.0  # global brightness swings by +-flicker (0.2 = +-20%) ...
    flicker_period: float = 3.0  # ... with this period, seconds

    def brightness(self, t: float) -> float:
        return 1.0 + self.flicker * float(np.sin(2 * np.pi * t / self.flicker_period))


@dataclass(frozen=True)
class SceneSpec:
    name: str
    balls: tuple[BallSpec, ...]
    rig: RigSpec = field(default_factory=RigSpec)
    fps: float = 30.0
    n_frames: int = 90
    seed: int = 0
    occluders: tuple[Occluder, ...] = ()
    lighting: Lighting = field(default_factory=Lighting)
    distractors: int = 0  # similar-hue patches in the background, per camera
    noise: float = 2.0  # Gaussian sensor noise, standard deviation in grey levels
    blur: int = 1  # motion blur: sub-frames averaged over the exposure (1 = none)
    exposure: float = 0.5  # exposure time as a fraction of the frame interval
    jpeg_quality: int = 0  # lossy compression: JPEG round trip at this quality (0 = off)

    def targets(self) -> tuple[Target, ...]:
        """One target per ball colour with an HSV range that covers the rendered balls."""
        out = {}
        for b in self.balls:
            if b.target_name not in out:
                out[b.target_name] = target_for_colour(b.target_name, b.bgr, b.radius, self.lighting)
        return tuple(out.values())

    def config(self) -> Config:
        return Config(targets=self.targets())


def target_for_colour(name: str, bgr: Sequence[float], radius: float, lighting: Lighting) -> Target:
    """An OpenCV HSV range around a ball colour: its hue +-10, the shaded side included, highlights left out."""
    bgr = np.asarray(bgr, np.uint8).reshape(1, 1, 3)
    h, s, v = (int(x) for x in cv2.cvtColor(bgr, cv2.COLOR_BGR2HSV)[0, 0])
    darkest = v * lighting.ambient * (1.0 - lighting.flicker)
    return Target(
        name=name,
        hsv_min=((h - 10) % 180, int(s * 0.55), int(max(20, 0.6 * darkest))),
        hsv_max=((h + 10) % 180, 255, 255),
        radius=float(radius),
    )


# --------------------------------------------------------------------------- rendering


def _smooth_noise(rng: np.random.Generator, w: int, h: int, cell: int) -> np.ndarray:
    small = rng.uniform(-1, 1, (max(2, h // cell + 2), max(2, w // cell + 2))).astype(np.float32)
    return cv2.resize(small, (w, h), interpolation=cv2.INTER_CUBIC)


def make_background(rng: np.random.Generator, w: int, h: int, distractors: int = 0, distractor_hue: int | None = None) -> np.ndarray:
    """A textured, mostly low-saturation background (float32 BGR): smooth noise, a gradient, shapes."""
    lum = 125 + 35 * _smooth_noise(rng, w, h, 160) + 18 * _smooth_noise(rng, w, h, 40) + 7 * _smooth_noise(rng, w, h, 8)
    ang = rng.uniform(0, 2 * np.pi)
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    lum += 30 * ((xx - w / 2) * np.cos(ang) + (yy - h / 2) * np.sin(ang)) / max(w, h)
    img = np.repeat(lum[:, :, None], 3, axis=2)
    for c in range(3):  # a gentle colour cast that wanders over the image
        img[:, :, c] += 10 * _smooth_noise(rng, w, h, 200)
    for _ in range(int(rng.integers(10, 20))):  # furniture: grey-ish boxes and discs
        grey = rng.uniform(40, 220)
        colour = tuple(float(grey + rng.uniform(-12, 12)) for _ in range(3))
        x0, y0 = int(rng.uniform(-0.1, 1.0) * w), int(rng.uniform(-0.1, 1.0) * h)
        sx, sy = int(rng.uniform(0.03, 0.3) * w), int(rng.uniform(0.03, 0.3) * h)
        if rng.uniform() < 0.6:
            cv2.rectangle(img, (x0, y0), (x0 + sx, y0 + sy), colour, -1)
        else:
            cv2.ellipse(img, (x0, y0), (sx // 2, sy // 2), float(rng.uniform(0, 180)), 0, 360, colour, -1)
    img = cv2.GaussianBlur(img, (3, 3), 0)
    for _ in range(distractors):  # similar-hue patches: what a colour tracker must not follow
        hue = (distractor_hue + int(rng.integers(-14, 15))) % 180
        hsv = np.uint8([[[hue, int(rng.integers(70, 230)), int(rng.integers(90, 240))]]])
        colour = tuple(float(c) for c in cv2.cvtColor(hsv, cv2.COLOR_HSV2BGR)[0, 0])
        centre = (int(rng.uniform(0.05, 0.95) * w), int(rng.uniform(0.05, 0.95) * h))
        axes = (int(rng.uniform(0.01, 0.05) * w), int(rng.uniform(0.01, 0.05) * w))
        cv2.ellipse(img, centre, axes, float(rng.uniform(0, 180)), 0, 360, colour, -1)
    return np.clip(img, 0, 255).astype(np.float32)


@dataclass
class _CameraCache:
    camera: Camera
    rays: np.ndarray  # H x W x 3 float32 unit directions, world frame
    centre: np.ndarray  # 3
    background: np.ndarray  # H x W x 3 float32
    focal: float


class SceneRenderer:
    """Renders frames of a scene in memory: ``render(i) -> (images, truth rows)``.

    Truth rows are (object_id, x, y, z, visible) for every ball present whose
    centre is in front of and inside every camera's image; ``visible`` counts
    the cameras in which some of the ball is not hidden. Any frame can be
    rendered on its own and always comes out the same.
    """

    def __init__(self, spec: SceneSpec):
        self.spec = spec
        self.rig = spec.rig.build()
        rng = np.random.default_rng(spec.seed)
        light = np.asarray(spec.lighting.direction, float)
        self._light = (light / np.linalg.norm(light)).astype(np.float32)
        hue = int(cv2.cvtColor(spec.balls[0].bgr.astype(np.uint8)[None, None], cv2.COLOR_BGR2HSV)[0, 0, 0]) if spec.balls else 0
        w, h = spec.rig.width, spec.rig.height
        uu, vv = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
        pixels = np.column_stack([uu.ravel(), vv.ravel()])
        self._cams = []
        for cam in self.rig.cameras:
            _, dirs = cam.rays(pixels)  # undistorted, so lens distortion is exact
            bg = make_background(rng, w, h, spec.distractors, hue)
            self._cams.append(
                _CameraCache(cam, dirs.reshape(h, w, 3).astype(np.float32), cam.centre.astype(np.float32), bg, float(cam.K[0, 0]))
            )
        # One bank of Gaussian noise; each frame reads it at seeded offsets (cheap, still Gaussian per pixel).
        self._noise = (rng.standard_normal(2 * w * h * 3, dtype=np.float32) * spec.noise) if spec.noise > 0 else None

    @property
    def n_frames(self) -> int:
        return self.spec.n_frames

    def time(self, frame: int) -> float:
        return frame / self.spec.fps

    def ball_positions(self, t: float) -> np.ndarray:
        """B x 3 ball centres at time t; NaN rows for balls not in the scene."""
        out = np.full((len(self.spec.balls), 3), np.nan)
        for k, b in enumerate(self.spec.balls):
            if b.appear <= t < b.disappear:
                out[k] = b.trajectory.positions(np.array([t]))[0]
        return out

    def render(self, frame: int) -> tuple[tuple[np.ndarray, ...], list[tuple[int, float, float, float, int]]]:
        spec = self.spec
        t = self.time(frame)
        rng = np.random.default_rng([spec.seed, frame])
        gain = spec.lighting.brightness(t)
        n_sub = max(1, int(spec.blur))
        offsets = ((np.arange(n_sub) + 0.5) / n_sub - 0.5) * spec.exposure / spec.fps if n_sub > 1 else np.zeros(1)
        sub_positions = [self.ball_positions(t + dt) for dt in offsets]
        images, visible = [], np.zeros(len(spec.balls), int)
        for cc in self._cams:
            acc = None
            for k, pos in enumerate(sub_positions):
                img, ids = self._draw(cc, pos)
                acc = img if acc is None else acc + img
                if k == len(sub_positions) // 2:
                    seen = np.bincount(ids[ids >= 0].ravel(), minlength=len(spec.balls))[: len(spec.balls)]
                    visible += seen > 0
            # gain * mean of sub-frames + noise, saturated to uint8, in one OpenCV pass.
            if self._noise is not None:
                start = int(rng.integers(0, len(self._noise) - acc.size))
                noise = self._noise[start : start + acc.size].reshape(acc.shape)
                out = cv2.addWeighted(acc, gain / n_sub, noise, 1.0, 0.0, dtype=cv2.CV_8U)
            else:
                out = cv2.addWeighted(acc, gain / n_sub, acc, 0.0, 0.0, dtype=cv2.CV_8U)
            if spec.jpeg_quality > 0:
                ok, buf = cv2.imencode(".jpg", out, [cv2.IMWRITE_JPEG_QUALITY, int(spec.jpeg_quality)])
                out = cv2.imdecode(buf, cv2.IMREAD_COLOR)
            images.append(out)
        centres = self.ball_positions(t)
        truth = []
        for k, c in enumerate(centres):
            if np.isnan(c[0]):
                continue
            inside = True
            for cam in self.rig.cameras:
                uv, front = cam.project(c[None])
                inside &= bool(front[0]) and 0 <= uv[0, 0] <= cam.width - 1 and 0 <= uv[0, 1] <= cam.height - 1
            if inside:
                truth.append((k, float(c[0]), float(c[1]), float(c[2]), int(visible[k])))
        return tuple(images), truth

    def labels(self, frame: int) -> tuple[np.ndarray, ...]:
        """Per camera, H x W int16: the ball index seen at each pixel at the frame's time.

        -1 is background, -2 - k is occluder k. Edge pixels count for a ball
        when it covers at least half of them. For measuring colour masks.
        """
        pos = self.ball_positions(self.time(frame))
        return tuple(self._draw(cc, pos)[1] for cc in self._cams)

    # ---- one camera, one instant: z-buffered balls and occluders over the background
    def _draw(self, cc: _CameraCache, ball_pos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        h, w = cc.rays.shape[:2]
        img = cc.background.copy()
        zbuf = np.full((h, w), np.inf, np.float32)
        ids = np.full((h, w), -1, np.int16)
        items = []
        for k, (b, c) in enumerate(zip(self.spec.balls, ball_pos)):
            if not np.isnan(c[0]):
                items.append((float(np.linalg.norm(c - cc.centre)), "ball", k, b, c))
        for k, occ in enumerate(self.spec.occluders):
            items.append((float(np.linalg.norm(np.asarray(occ.centre) - cc.centre)), "box", -2 - k, occ, None))
        for _, kind, k, obj, c in sorted(items, key=lambda it: -it[0]):  # far to near, so edges blend over what lies behind
            if kind == "ball":
                self._draw_ball(cc, img, zbuf, ids, k, obj, c.astype(np.float32))
            else:
                self._draw_box(cc, img, zbuf, ids, k, obj)
        return img, ids

    def _ball_box(self, cc: _CameraCache, c: np.ndarray, r: float) -> tuple[int, int, int, int] | None:
        """Pixel bounding box of a sphere: project its silhouette circle (the tangent cone), plus a margin."""
        oc = c - cc.centre
        dist = float(np.linalg.norm(oc))
        if dist <= r * 1.01:
            return None
        axis = oc / dist
        a = np.cross(axis, [0.0, 0.0, 1.0] if abs(axis[2]) < 0.9 else [1.0, 0.0, 0.0])
        a /= np.linalg.norm(a)
        b = np.cross(axis, a)
        ang = np.linspace(0, 2 * np.pi, 24, endpoint=False)
        rim_r = 1.08 * r * np.sqrt(dist**2 - r**2) / dist
        rim = cc.centre + axis * (dist - r * r / dist) + rim_r * (np.cos(ang)[:, None] * a + np.sin(ang)[:, None] * b)
        uv, front = cc.camera.project(rim)
        if not front.all():
            return None
        x0, y0 = np.floor(uv.min(axis=0)).astype(int) - 2
        x1, y1 = np.ceil(uv.max(axis=0)).astype(int) + 3
        h, w = cc.rays.shape[:2]
        x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, w), min(y1, h)
        return None if x0 >= x1 or y0 >= y1 else (x0, y0, x1, y1)

    def _draw_ball(self, cc, img, zbuf, ids, k: int, ball: BallSpec, c: np.ndarray) -> None:
        box = self._ball_box(cc, c.astype(float), ball.radius)
        if box is None:
            return
        x0, y0, x1, y1 = box
        d = cc.rays[y0:y1, x0:x1]
        oc = c - cc.centre
        bproj = d @ oc  # distance along each ray to the closest approach
        miss2 = np.maximum(float(oc @ oc) - bproj * bproj, 0.0)  # squared ray-centre distance
        r = np.float32(ball.radius)
        miss = np.sqrt(miss2)
        # Analytic anti-aliasing: pixel coverage from the ray's distance to the silhouette, in pixels.
        cover = np.clip(0.5 + (r - miss) * cc.focal / np.maximum(bproj, 1e-6), 0.0, 1.0)
        tz = bproj - np.sqrt(np.maximum(r * r - miss2, 0.0))
        mask = (cover > 0) & (bproj > 0) & (tz < zbuf[y0:y1, x0:x1])
        if not mask.any():
            return
        dm, tm, cm = d[mask], tz[mask], cover[mask][:, None]
        n = (cc.centre + tm[:, None] * dm - c) / r
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        L = self._light
        lam = np.clip(n @ L, 0.0, None)
        half = L - dm
        half /= np.linalg.norm(half, axis=1, keepdims=True)
        spec = np.clip(np.sum(n * half, axis=1), 0.0, None) ** self.spec.lighting.shininess
        lit = self.spec.lighting
        colour = ball.bgr * (lit.ambient + lit.diffuse * lam)[:, None] + (255.0 * lit.specular * spec)[:, None]
        region = img[y0:y1, x0:x1]
        region[mask] = cm * colour + (1 - cm) * region[mask]
        solid = mask.copy()
        solid[mask] = cm[:, 0] >= 0.5
        zbuf[y0:y1, x0:x1][solid] = tz[solid]
        ids[y0:y1, x0:x1][solid] = k

    def _draw_box(self, cc, img, zbuf, ids, k: int, occ: Occluder) -> None:
        lo = np.asarray(occ.centre, float) - np.asarray(occ.size, float) / 2
        hi = lo + np.asarray(occ.size, float)
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        uv, front = cc.camera.project(corners)
        h, w = cc.rays.shape[:2]
        if front.all():
            x0, y0 = np.maximum(np.floor(uv.min(axis=0)).astype(int) - 2, 0)
            x1, y1 = np.minimum(np.ceil(uv.max(axis=0)).astype(int) + 3, [w, h])
        else:
            x0, y0, x1, y1 = 0, 0, w, h
        if x0 >= x1 or y0 >= y1:
            return
        d = cc.rays[y0:y1, x0:x1]
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / d
            ta = (lo.astype(np.float32) - cc.centre) * inv
            tb = (hi.astype(np.float32) - cc.centre) * inv
        tmin, tmax = np.minimum(ta, tb), np.maximum(ta, tb)
        tmin = np.nan_to_num(tmin, nan=-np.inf)
        tmax = np.nan_to_num(tmax, nan=np.inf)
        t_near, face = tmin.max(axis=2), tmin.argmax(axis=2)
        t_far = tmax.min(axis=2)
        mask = (t_near <= t_far) & (t_near > 0) & (t_near < zbuf[y0:y1, x0:x1])
        if not mask.any():
            return
        normal_sign = -np.sign(d[mask][np.arange(mask.sum()), face[mask]])  # the face looks back at the camera
        normals = np.zeros((mask.sum(), 3), np.float32)
        normals[np.arange(mask.sum()), face[mask]] = normal_sign
        lit = self.spec.lighting
        shade = lit.ambient + lit.diffuse * np.clip(normals @ self._light, 0.0, None)
        img[y0:y1, x0:x1][mask] = np.asarray(occ.colour, np.float32) * shade[:, None]
        zbuf[y0:y1, x0:x1][mask] = t_near[mask]
        ids[y0:y1, x0:x1][mask] = k


# --------------------------------------------------------------------------- writing a recording


def render_scene(spec: SceneSpec, out_folder: str | Path, progress: bool = True, codec: str = "ffv1", overwrite: bool = False) -> Path:
    """Render a scene into a recording folder (videos, frames.csv, calib.yaml, truth.csv, config.yaml)."""
    from .console import Progress
    from .recording import RecordingWriter

    renderer = SceneRenderer(spec)
    rig = renderer.rig
    out = Path(out_folder)
    writer = RecordingWriter(
        out,
        rig.names,
        (spec.rig.width, spec.rig.height),
        spec.fps,
        rig=rig,
        codec=codec,
        source=f"synthetic: {spec.name} (seed {spec.seed})",
        targets=config_to_dict(spec.config()),
        extra_meta={"up": list(WORLD_UP)},
        overwrite=overwrite,
        truth_fields=("visible",),
    )
    bar = Progress(spec.n_frames, label=f"rendering {spec.name}", enabled=progress)
    try:
        for i in range(spec.n_frames):
            images, truth = renderer.render(i)
            t = renderer.time(i)
            writer.write(images, [t] * len(images))
            writer.write_truth(i, truth)
            bar.update(1)
    finally:
        writer.close()
        bar.close()
    return out


def ensure_demo_recording(root: str | Path, codec: str = "mjpg") -> Path:
    """``root/recordings/demo``: rendered from ``pendulum4`` (10 s at 30 fps) unless already complete.

    Renders into a temporary folder and renames it into place, so an
    interrupted render never leaves a half demo behind. MJPG by default, like
    a webcam: 9 MB instead of 250 MB of lossless FFV1 (sensor noise does not
    compress), and the target colours still cover 99% of the ball pixels.
    """
    from .scenes import make_preset

    root = Path(root)
    demo = root / "recordings" / "demo"
    spec = make_preset("pendulum4", fps=30.0, n_frames=300)
    if _is_complete(demo, spec.n_frames):
        return demo
    tmp = root / "recordings" / f".demo-partial-{os.getpid()}"
    if tmp.exists():
        shutil.rmtree(tmp)
    render_scene(spec, tmp, progress=True, codec=codec)
    if demo.exists():
        shutil.rmtree(demo)
    os.replace(tmp, demo)
    return demo


def _is_complete(folder: Path, n_frames: int) -> bool:
    from .recording import open_recording

    if not (folder / "meta.yaml").is_file() or not (folder / "truth.csv").is_file():
        return False
    try:
        return open_recording(folder).n_frames == n_frames
    except StereotrackError:
        return False


def make_preset(name: str, **overrides: Any) -> SceneSpec:
    """A named scene (see ``scenes.PRESETS``) with overrides; defined in scenes.py."""
    from .scenes import make_preset as _make

    return _make(name, **overrides)


def load_scene_yaml(path: str | Path) -> SceneSpec:
    """A scene from a YAML file (a preset with overrides, or balls and trajectories); defined in scenes.py."""
    from .scenes import load_scene_yaml as _load

    return _load(path)
