"""Placing things in a random stress scene: the rig, the light, the room, balls on paths that stay in view and apart.

Shared by the categories of ``stress.py``. Every draw comes from the
``numpy.random.Generator`` the category passes in, in a fixed order, so a
seed always gives the same scene. ``typed_target`` is the HSV range a user
would type for a ball (never one fitted to the render).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..config import Config, Target, TrackerSettings
from .rooms import bgr_to_hsv, hsv_to_bgr, make_room
from .shapes import TAG_TARGET_COLOURED, Material
from .spec import BallSpec, CameraResponse, Lighting, RigSpec, SceneSpec
from .stage import Stage
from .trajectories import Ballistic, Line, Pendulum, Static

GAMMA = 2.2  # every stress camera has an sRGB-like tone curve


def typed_target(bgr, radius: float, rng: np.random.Generator, name: str = "ball") -> Target:
    """The HSV range a user would type after looking at the ball: its hue +-10, S and V from about 80 up.

    A white or grey ball gets a low-saturation, high-value range instead. The
    user's numbers are rounded guesses, so they wobble a little with the seed.
    """
    h, s, v = bgr_to_hsv(bgr)
    if s < 60:  # white or grey
        return Target(name, (0, 0, int(np.clip(v - rng.integers(60, 90), 90, 190))), (179, int(rng.integers(40, 70)), 255), float(radius))
    hue = h + int(rng.integers(-2, 3))
    width = int(rng.integers(9, 12))
    return Target(
        name, ((hue - width) % 180, int(rng.integers(70, 91)), int(rng.integers(70, 91))), ((hue + width) % 180, 255, 255), float(radius)
    )


def ball_colour(rng, hue: float | None = None) -> tuple[float, float, float]:
    return hsv_to_bgr(rng.uniform(0, 180) if hue is None else hue, rng.uniform(150, 240), rng.uniform(170, 250))


def base_rig(rng, **over) -> RigSpec:
    k1 = float(rng.uniform(-0.12, 0.02))
    rig = RigSpec(
        cameras=2,
        width=640,
        height=480,
        hfov=float(rng.uniform(55, 72)),
        baseline=float(rng.uniform(0.2, 0.45)),
        aim_distance=float(rng.uniform(1.4, 2.4)),
        dist=(k1, float(rng.uniform(0.0, 0.04)), 0.0, 0.0, 0.0),
    )
    return dataclasses.replace(rig, **over)


def room_lighting(rng) -> Lighting:
    ambient = float(rng.uniform(0.3, 0.5))
    return Lighting(
        direction=(float(rng.uniform(-0.6, 0.6)), float(rng.uniform(-0.8, -0.2)), float(rng.uniform(0.5, 1.0))),
        ambient=ambient,
        diffuse=float(rng.uniform(0.95, 1.1) - ambient),
        specular=float(rng.uniform(0.15, 0.45)),
        shininess=float(rng.uniform(20, 60)),
    )


class Placer:
    """Working state while a scene is drawn: rig, times, room, and checks that keep balls in view and apart."""

    def __init__(self, rng, rig: RigSpec, fps: float, n_frames: int, exposure: float = 0.3):
        self.rng = rng
        self.rig = rig
        self.cams = rig.build().cameras
        self.fps = fps
        self.n_frames = n_frames
        self.times = np.arange(n_frames) / fps
        self.paths: list[np.ndarray] = []  # chosen balls' positions at self.times (NaN when absent)
        self.radii: list[float] = []
        self.keep_out: list[tuple[np.ndarray, float]] = []  # (centre, radius) balls must not enter
        self.floor_z = -1.2

    def in_view(self, pts: np.ndarray, radius: float, margin_px: float = 6.0) -> bool:
        ok = np.isfinite(pts[:, 0])
        p = pts[ok]
        for cam in self.cams:
            uv, front = cam.project(p)
            depth = cam.depth(p)
            r = cam.focal_px * radius / np.maximum(depth, 1e-6) + margin_px
            inside = front & (uv[:, 0] >= r) & (uv[:, 1] >= r) & (uv[:, 0] <= cam.width - 1 - r) & (uv[:, 1] <= cam.height - 1 - r)
            if not inside.all():
                return False
        return True

    def in_view_each(self, pts: np.ndarray, radius: float, margin_px: float = 2.0) -> np.ndarray:
        """Per point: inside every camera's image (NaN points are not)."""
        ok = np.isfinite(pts[:, 0])
        for cam in self.cams:
            uv, front = cam.project(np.nan_to_num(pts))
            depth = cam.depth(np.nan_to_num(pts))
            r = cam.focal_px * radius / np.maximum(depth, 1e-6) + margin_px
            ok &= front & (uv[:, 0] >= r) & (uv[:, 1] >= r) & (uv[:, 0] <= cam.width - 1 - r) & (uv[:, 1] <= cam.height - 1 - r)
        return ok

    def depths_seen(self, pts: np.ndarray) -> np.ndarray:
        """The depths of the points each camera sees (centre inside its image), all cameras' together."""
        out = []
        for cam in self.cams:
            uv, front = cam.project(pts)
            out.append(cam.depth(pts[front & cam.in_image(uv)]))
        return np.concatenate(out)

    def clear(self, pts: np.ndarray, radius: float) -> bool:
        for other, r in zip(self.paths, self.radii):
            d = np.linalg.norm(pts - other, axis=1)
            if np.nanmin(np.where(np.isfinite(d), d, np.inf)) < 1.15 * (radius + r):
                return False
        for c, r in self.keep_out:
            d = np.linalg.norm(pts - c, axis=1)
            if np.nanmin(np.where(np.isfinite(d), d, np.inf)) < radius + r:
                return False
        return True

    def accept(self, traj, radius: float, check_view: bool = True) -> bool:
        pts = traj.positions(self.times)
        if (check_view and not self.in_view(pts, radius)) or not self.clear(pts, radius):
            return False
        self.paths.append(pts)
        self.radii.append(radius)
        return True

    def point(self, depth: tuple[float, float]) -> np.ndarray:
        """A random point inside every camera's view at a depth (along y) in the range."""
        for _ in range(200):
            y = self.rng.uniform(*depth)
            p = np.array([self.rng.uniform(-1, 1) * 0.55 * y, y, self.rng.uniform(-0.4, 0.4) * y])
            if self.in_view(p[None], 0.1, 10):
                return p
        return np.array([0.0, float(np.mean(depth)), 0.0])


def random_motion(
    sc: Placer, radius: float, depth=(0.9, 2.6), kinds=("pendulum", "throw", "line", "rest"), p=(0.4, 0.3, 0.2, 0.1), speed=1.0
):
    """A trajectory that keeps the ball inside every view and clear of the others (None after 300 tries)."""
    rng = sc.rng
    for _ in range(300):
        kind = rng.choice(kinds, p=np.asarray(p) / np.sum(p))
        rest = sc.point(depth)
        if kind == "pendulum":
            length = rng.uniform(0.3, 1.2)
            traj = Pendulum(
                (rest[0], rest[1], rest[2] + length),
                length,
                float(rng.uniform(10, 35) * min(speed, 1.6)),
                float(rng.uniform(-90, 90)),
                float(rng.uniform(0, 360)),
            )
        elif kind == "throw":
            end = sc.point(depth)
            end[2] = rest[2] + rng.uniform(-0.1, 0.1)
            flight = rng.uniform(0.45, 0.9) / speed
            traj = Ballistic(
                tuple(rest), tuple(end), flight=float(flight), dwell=float(rng.uniform(0.05, 0.3)), phase=float(rng.uniform(0, 2))
            )
        elif kind == "line":
            end = sc.point(depth)
            dist = np.linalg.norm(end - rest)
            traj = Line(tuple(rest), tuple(end), period=float(2 * dist / (rng.uniform(0.3, 1.5) * speed)), phase=float(rng.uniform(0, 1)))
        else:
            traj = Static(tuple(rest))
        if sc.accept(traj, radius):
            return traj
    return None


def place_balls(sc: Placer, colour, radius, n: int, **motion) -> tuple[BallSpec, ...]:
    out = []
    for _ in range(n):
        traj = random_motion(sc, radius, **motion)
        if traj is not None:
            out.append(BallSpec(traj, colour=tuple(int(round(c)) for c in colour), radius=radius))
    return tuple(out)


def room_for(sc: Placer, avoid_hue, white=False, hall=False, back=(3.0, 6.0)):
    rng = sc.rng
    return make_room(
        rng,
        avoid_hue,
        width=float(rng.uniform(4, 8) if not hall else rng.uniform(15, 30)),
        depth=float(rng.uniform(*back)),
        camera_height=float(rng.uniform(0.9, 1.5)),
        ceiling=float(rng.uniform(2.4, 3.0) if not hall else rng.uniform(6, 10)),
        white=white,
        hall=hall,
    )


def assemble(category, seed, sc: Placer, balls, room, target, extra_props=(), extra_decals=None, **kw) -> SceneSpec:
    rng = sc.rng
    walls = room.walls
    if extra_decals:
        walls = tuple(dataclasses.replace(w, decals=w.decals + tuple(extra_decals.get(i, ()))) for i, w in enumerate(walls))
    tracker = kw.pop("tracker", TrackerSettings())
    responses = kw.pop("responses", None)
    if responses is None:
        responses = tuple(CameraResponse(vignette=float(rng.uniform(0.0, 0.15)), gamma=GAMMA) for _ in range(sc.rig.cameras))
    return SceneSpec(
        name=f"stress-{category}-{seed}",
        balls=balls,
        rig=sc.rig,
        fps=sc.fps,
        n_frames=sc.n_frames,
        seed=int(seed),
        lighting=kw.pop("lighting", room_lighting(rng)),
        noise=float(kw.pop("noise", rng.uniform(1.5, 4.0))),
        blur=int(kw.pop("blur", 3)),
        exposure=float(kw.pop("exposure", rng.uniform(0.2, 0.4))),
        jpeg_quality=int(kw.pop("jpeg_quality", 0)),
        stage=Stage(walls, room.props + tuple(extra_props)),
        responses=responses,
        user_config=Config(targets=(target,), tracker=tracker),
        **kw,
    )


def target_material(rng, hue, tag=TAG_TARGET_COLOURED) -> Material:
    return Material(
        hsv_to_bgr(hue + rng.uniform(-7, 7), rng.uniform(110, 235), rng.uniform(140, 250)),
        float(rng.uniform(0.0, 0.4)),
        float(rng.uniform(8, 40)),
        tag,
    )


def one_view_point(sc: Placer, radius: float, seen_by: int) -> np.ndarray | None:
    """A point whose ball-sized sphere is inside camera ``seen_by``'s image and outside every other camera's."""
    rng = sc.rng
    for _ in range(2000):
        p = np.array([rng.uniform(-2.5, 2.5), rng.uniform(0.6, 3.0), rng.uniform(-0.8, 0.8)])
        ok = True
        for i, cam in enumerate(sc.cams):
            uv, front = cam.project(p[None])
            r = cam.focal_px * radius / max(float(cam.depth(p[None])[0]), 1e-6)
            inside = bool(front[0]) and r + 3 <= uv[0, 0] <= cam.width - 4 - r and r + 3 <= uv[0, 1] <= cam.height - 4 - r
            outside = (
                (not front[0]) or uv[0, 0] < -r - 3 or uv[0, 0] > cam.width + r + 3 or uv[0, 1] < -r - 3 or uv[0, 1] > cam.height + r + 3
            )
            ok &= inside if i == seen_by else outside
        if ok:
            return p
    return None
