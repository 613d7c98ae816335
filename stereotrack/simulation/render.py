"""Rendering a synthetic scene (``spec.py``): any frame on its own, with exact ground truth.

A scene is a rig of toed-in cameras, balls on trajectories, a textured
background, optional distractors and occluders, lighting, noise, blur and
compression. ``SceneRenderer`` renders true spheres by per-pixel ray-sphere
intersection through the camera model, so perspective and lens distortion
are exact; ``write.render_scene`` writes a whole recording folder.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from ..camera import Camera
from .spec import BallSpec, Occluder, SceneSpec

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
