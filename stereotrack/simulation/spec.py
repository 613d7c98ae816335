"""What a synthetic scene is: rig, balls on trajectories, occluders, lighting, noise (frozen dataclasses).

Optional, for rooms rather than flat backdrops (all off by default): a 3D
``stage`` (stage.py: walls, furniture, props), ``movers`` (hands.py: hands
and arms that carry balls), a ``CameraResponse`` per camera (white balance,
exposure, auto-exposure hunting, vignetting, tone curve, greyscale) and the
``user_config`` a user would type instead of the ranges fitted to the balls.

World frame ("world: custom"): origin midway between the camera centres,
x to the right, y forward (away from the cameras), z up; gravity is -z.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import cv2
import numpy as np

from ..camera import Camera, Rig, intrinsics_from_fov, look_at
from ..config import Config, Target
from ..errors import StereotrackError
from .stage import Stage

# Named ball colours (BGR albedo). Pink is the paper's ball colour.
COLOURS: dict[str, tuple[int, int, int]] = {
    "pink": (150, 60, 230),
    "orange": (20, 110, 235),
    "green": (60, 190, 50),
    "blue": (210, 110, 25),
    "yellow": (30, 205, 225),
}


WORLD_UP = (0.0, 0.0, 1.0)


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
    waves: tuple[tuple[float, float, float], ...] = ()  # more drift: (amplitude, period s, phase rad) each, added to the flicker

    def brightness(self, t: float) -> float:
        return 1.0 + self.flicker * float(np.sin(2 * np.pi * t / self.flicker_period)) + _waves(self.waves, t)


def _waves(waves: Sequence[tuple[float, float, float]], t: float) -> float:
    return sum(a * float(np.sin(2 * np.pi * t / period + phase)) for a, period, phase in waves)


@dataclass(frozen=True)
class CameraResponse:
    """How one camera turns light into pixel values, beyond the scene's lighting (neutral by default)."""

    gains: tuple[float, float, float] = (1.0, 1.0, 1.0)  # white balance times exposure: B, G, R multipliers
    waves: tuple[tuple[float, float, float], ...] = ()  # auto exposure hunting: (amplitude, period s, phase rad) each
    vignette: float = 0.0  # share of the brightness lost in the image corners
    gamma: float = 1.0  # tone curve: a surface lit at s shows s ** (1 / gamma) of its colour (2.2 like sRGB; 1 = linear)
    greyscale: bool = False  # a monochrome camera: three equal channels

    def brightness(self, t: float) -> float:
        return 1.0 + _waves(self.waves, t)


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
    stage: Stage | None = None  # 3D scenery (walls, furniture, props) instead of the flat per-camera background
    movers: tuple[Any, ...] = ()  # moving things that are not balls (hands.Hand): anything with ellipsoids(t)
    responses: tuple[CameraResponse, ...] = ()  # one per camera (missing ones are neutral)
    user_config: Config | None = None  # the config a user would type (targets, tracker settings); none = ranges fitted to the balls

    def targets(self) -> tuple[Target, ...]:
        """One target per ball colour with an HSV range that covers the rendered balls."""
        out = {}
        for b in self.balls:
            if b.target_name not in out:
                out[b.target_name] = target_for_colour(b.target_name, b.bgr, b.radius, self.lighting)
        return tuple(out.values())

    def config(self) -> Config:
        return self.user_config if self.user_config is not None else Config(targets=self.targets())

    def response(self, camera: int) -> CameraResponse:
        return self.responses[camera] if camera < len(self.responses) else CameraResponse()


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
