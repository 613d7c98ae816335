"""Named synthetic scenes (presets) and YAML scene files -> ``SceneSpec``.

``make_preset(name, **overrides)`` takes the preset's own parameters (e.g.
``depths`` for static_depths, ``all_at_once`` for appear5) and any scene or
rig setting (fps, n_frames, seed, noise, blur, jpeg_quality, distractors,
cameras, width, height, hfov, baseline, aim_distance, dist).
"""

from __future__ import annotations

import dataclasses
import inspect
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import StereotrackError
from ..files import load_yaml
from .spec import BallSpec, Lighting, Occluder, RigSpec, SceneSpec, colour_bgr
from .trajectories import TRAJECTORIES, Ballistic, Line, Pendulum, Samples, Static

_RIG_KEYS = {f.name for f in dataclasses.fields(RigSpec)}
_SCENE_KEYS = {"fps", "n_frames", "seed", "noise", "blur", "exposure", "jpeg_quality", "distractors"}


def _n(duration: float, fps: float) -> int:
    return max(1, int(round(duration * fps)))


def _pendulum(rest: tuple[float, float, float], length: float, amplitude: float, azimuth: float, phase: float) -> Pendulum:
    """A pendulum given where its ball hangs at rest (the pivot is ``length`` above)."""
    return Pendulum(pivot=(rest[0], rest[1], rest[2] + length), length=length, amplitude=amplitude, azimuth=azimuth, phase=phase)


# The demo scene: four pink pendulums at 1.0 to 2.2 m, periods 1.3 to 2.3 s, swinging across and in depth.
_PENDULUMS = (
    _pendulum((-0.25, 1.0, -0.10), 0.45, 25.0, 0.0, 0.0),
    _pendulum((0.15, 1.4, 0.05), 0.70, 20.0, 30.0, 90.0),
    _pendulum((-0.05, 1.8, -0.15), 1.00, 15.0, 60.0, 200.0),
    _pendulum((0.35, 2.2, 0.15), 1.30, 12.0, -20.0, 300.0),
)


def static2(rig: RigSpec, fps: float) -> SceneSpec:
    balls = (BallSpec(Static((-0.12, 1.3, 0.0))), BallSpec(Static((0.15, 1.7, 0.08))))
    return SceneSpec("static2", balls, rig, fps, _n(3.0, fps))


def static_depths(rig: RigSpec, fps: float, depths: tuple[float, ...] = (0.6, 1.2, 2.0)) -> SceneSpec:
    depths = tuple(float(d) for d in depths)
    n = len(depths)
    # Spread over bearings (not a fixed lateral offset) so no ball hides another in either view.
    bearings = np.radians(np.linspace(-12.0, 12.0, n)) if n > 1 else np.zeros(1)
    xs = [d * np.tan(b) for d, b in zip(depths, bearings)]
    zs = np.linspace(-0.08, 0.08, n) if n > 1 else [0.0]
    balls = tuple(BallSpec(Static((float(x), d, float(z)))) for x, d, z in zip(xs, depths, zs))
    return SceneSpec("static_depths", balls, rig, fps, _n(3.0, fps))


def pendulum4(rig: RigSpec, fps: float) -> SceneSpec:
    return SceneSpec("pendulum4", tuple(BallSpec(p) for p in _PENDULUMS), rig, fps, _n(10.0, fps))


def appear5(rig: RigSpec, fps: float, interval: float = 1.0, all_at_once: bool = False) -> SceneSpec:
    rests = [(-0.35, 1.2, 0.0), (0.3, 1.5, -0.1), (-0.05, 1.1, 0.12), (0.1, 2.0, 0.15), (-0.3, 1.8, -0.18)]
    balls = tuple(
        BallSpec(_pendulum(r, 0.5 + 0.15 * k, 15.0, 40.0 * k, 70.0 * k), appear=0.0 if all_at_once else k * float(interval))
        for k, r in enumerate(rests)
    )
    return SceneSpec("appear5", balls, rig, fps, _n(8.0, fps))


def crossing(rig: RigSpec, fps: float) -> SceneSpec:
    near = Line((-0.35, 1.2, 0.0), (0.35, 1.2, 0.0), period=6.0)
    far = Line((0.35, 1.8, 0.02), (-0.35, 1.8, 0.02), period=6.0)
    return SceneSpec("crossing", (BallSpec(near), BallSpec(far)), rig, fps, _n(6.0, fps))


def clutter(rig: RigSpec, fps: float) -> SceneSpec:
    lighting = Lighting(flicker=0.25, flicker_period=3.0)
    balls = tuple(BallSpec(p) for p in _PENDULUMS)
    return SceneSpec("clutter", balls, rig, fps, _n(10.0, fps), lighting=lighting, distractors=8, noise=6.0, jpeg_quality=75)


def occluded(rig: RigSpec, fps: float) -> SceneSpec:
    """A grey panel in front of the left camera hides a swinging ball in that view only part of the time."""
    balls = (BallSpec(_pendulum((-0.1, 1.6, -0.05), 0.6, 25.0, 0.0, 0.0)), BallSpec(_pendulum((0.2, 1.3, 0.05), 0.5, 20.0, 0.0, 90.0)))
    panel = Occluder(centre=(-0.2, 0.8, -0.05), size=(0.12, 0.01, 0.4))
    return SceneSpec("occluded", balls, rig, fps, _n(4.0, fps), occluders=(panel,))


def place_capture(times: np.ndarray, points: np.ndarray, rig: RigSpec, radius: float, aim_given: bool) -> tuple[np.ndarray, RigSpec]:
    """Turn capture positions (F x B x 3, z up) into scene positions that every camera sees.

    The wider horizontal spread goes across the image (world x), the volume's
    centre goes on the cameras' aim line, and unless the aim distance was
    given, the nearest depth that keeps every ball inside every image (with a
    margin) is chosen.
    """
    pts = points.copy()
    flat = pts[np.isfinite(pts[..., 0])]
    if np.ptp(flat[:, 1]) > np.ptp(flat[:, 0]):  # rotate 90 degrees about z: capture y -> world x
        pts = np.stack([pts[..., 1], -pts[..., 0], pts[..., 2]], axis=-1)
        flat = pts[np.isfinite(pts[..., 0])]
    centre = (flat.min(axis=0) + flat.max(axis=0)) / 2
    pts = pts - centre
    flat = flat - centre
    candidates = [rig.aim_distance] if aim_given else np.arange(1.2, 8.0, 0.05)
    for depth in candidates:
        trial = dataclasses.replace(rig, aim_distance=float(depth))
        world = flat + [0.0, depth, 0.0]
        ok = True
        for cam in trial.build().cameras:
            uv, front = cam.project(world)
            margin = cam.K[0, 0] * radius / np.maximum(cam.depth(world), 1e-6) + 4
            ok &= bool(
                front.all() and np.all(uv >= margin[:, None]) and np.all(uv <= np.array([cam.width - 1, cam.height - 1]) - margin[:, None])
            )
        if ok:
            return pts + [0.0, depth, 0.0], trial
    raise StereotrackError("the captured motion does not fit in the cameras' view at any depth up to 8 m (widen hfov)")


def juggle5(rig: RigSpec, fps: float, aim_given: bool = False, colour: str = "pink", loop: bool = False) -> SceneSpec:
    from .mocap import load_juggling

    cap = load_juggling(n_balls=5)
    radius = 0.035
    pts, rig = place_capture(cap.times, cap.positions, rig, radius, aim_given)
    balls = tuple(BallSpec(Samples(cap.times, pts[:, k], loop=loop), colour=colour, radius=radius) for k in range(cap.n_balls))
    return SceneSpec("juggle5", balls, rig, fps, _n(float(cap.times[-1]), fps) - 1)


def throw1(rig: RigSpec, fps: float, mocap: bool = False, aim_given: bool = False) -> SceneSpec:
    if mocap:  # the real capture of one ball thrown six times (lost now and then: the ball leaves the scene)
        from .mocap import THROWS_6, find_real_data, link_balls, read_qualisys_tsv

        cap = link_balls(read_qualisys_tsv(find_real_data(THROWS_6)), n_balls=1)
        pts, rig = place_capture(cap.times, cap.positions, rig, 0.035, aim_given)
        return SceneSpec("throw1", (BallSpec(Samples(cap.times, pts[:, 0])),), rig, fps, _n(float(cap.times[-1]), fps) - 1)
    throw = Ballistic((-0.25, 1.6, -0.3), (0.25, 1.6, -0.3), flight=0.75, dwell=0.15)
    return SceneSpec("throw1", (BallSpec(throw),), rig, fps, _n(6.0, fps))


PRESETS: dict[str, tuple[Callable[..., SceneSpec], str]] = {
    "static2": (static2, "2 static pink balls at 1.3 and 1.7 m (the paper's Table II set-up)"),
    "static_depths": (static_depths, "one static pink ball per depth in 'depths' (default 0.6, 1.2, 2.0 m)"),
    "pendulum4": (pendulum4, "4 pink pendulums at 1.0-2.2 m, periods 1.3-2.3 s, swinging across and in depth (the demo)"),
    "appear5": (appear5, "5 pink pendulums appearing one per 'interval' s ('all_at_once' for all from the start)"),
    "crossing": (crossing, "2 pink balls crossing in opposite directions at 1.2 and 1.8 m: the near one hides the far one"),
    "clutter": (clutter, "pendulum4 plus similar-hue distractors, +-25% brightness swings, noise 6 and JPEG 75"),
    "occluded": (occluded, "2 swinging balls, a panel hides one of them from cam0 part of the time"),
    "juggle5": (juggle5, "replay of the real 5-ball juggling motion capture (16.6 s)"),
    "throw1": (throw1, "one ball thrown hand to hand, 0.75 s flights up to 3.5 m/s ('mocap' replays the real 6 throws)"),
}


def make_preset(name: str, **overrides: Any) -> SceneSpec:
    """A preset scene with overrides: preset parameters, scene settings (fps, n_frames, seed, ...) or rig settings."""
    if name not in PRESETS:
        raise StereotrackError(f"unknown scene preset {name!r}: choose one of {', '.join(PRESETS)} (or give a scene .yaml file)")
    builder = PRESETS[name][0]
    params = set(inspect.signature(builder).parameters) - {"rig", "fps"}
    unknown = set(overrides) - params - _RIG_KEYS - _SCENE_KEYS
    if unknown:
        raise StereotrackError(
            f"preset {name!r}: unknown setting {sorted(unknown)[0]!r} (preset parameters: {', '.join(sorted(params - {'aim_given'})) or 'none'}; "
            f"scene: {', '.join(sorted(_SCENE_KEYS))}; rig: {', '.join(sorted(_RIG_KEYS))})"
        )
    rig_over = {k: v for k, v in overrides.items() if k in _RIG_KEYS}
    if "dist" in rig_over:
        rig_over["dist"] = tuple(float(x) for x in rig_over["dist"] or ())
    rig = RigSpec(**rig_over)
    kwargs = {k: v for k, v in overrides.items() if k in params}
    if "aim_given" in params:
        kwargs["aim_given"] = "aim_distance" in rig_over
    fps = float(overrides.get("fps", 30.0))
    spec = builder(rig, fps, **kwargs)
    scene_over = {k: v for k, v in overrides.items() if k in _SCENE_KEYS and k != "fps"}
    return dataclasses.replace(spec, **scene_over)


# --------------------------------------------------------------------------- YAML scene files


def _build(cls, data: Any, where: str, path) -> Any:
    """A frozen dataclass from a mapping: unknown keys refused, lists become tuples."""
    if not isinstance(data, dict):
        raise StereotrackError(f"{path}: '{where}': expected a mapping")
    names = {f.name for f in dataclasses.fields(cls)}
    unknown = set(data) - names
    if unknown:
        raise StereotrackError(f"{path}: '{where}.{sorted(unknown)[0]}': unknown field (expected {', '.join(sorted(names))})")
    kwargs = {k: tuple(v) if isinstance(v, list) else v for k, v in data.items()}
    for f in dataclasses.fields(cls):  # numbers where numbers belong: a tuple field gets a list of numbers
        if f.name in kwargs and str(f.type).startswith("tuple[") and ("float" in str(f.type) or "int" in str(f.type)):
            value = kwargs[f.name]
            if not isinstance(value, tuple) or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
                raise StereotrackError(f"{path}: '{where}.{f.name}': expected a list of numbers, got {value!r:.60}")
        elif f.name in kwargs and str(f.type) in ("float", "int"):
            value = kwargs[f.name]
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise StereotrackError(f"{path}: '{where}.{f.name}': expected a number, got {value!r:.60}")
    try:
        return cls(**kwargs)
    except (TypeError, ValueError) as exc:
        raise StereotrackError(f"{path}: '{where}': {str(exc).splitlines()[0][:120]}") from None


def _ball(d: Any, i: int, path) -> BallSpec:
    where = f"balls[{i}]"
    if not isinstance(d, dict) or not isinstance(d.get("trajectory"), dict):
        raise StereotrackError(f"{path}: '{where}': expected a mapping with a 'trajectory' mapping")
    traj = dict(d["trajectory"])
    kind = traj.pop("type", None)
    if kind not in TRAJECTORIES:
        raise StereotrackError(f"{path}: '{where}.trajectory.type': expected one of {', '.join(TRAJECTORIES)}, got {kind!r}")
    ball = dict(d, trajectory=_build(TRAJECTORIES[kind], traj, f"{where}.trajectory", path))
    if ball.get("disappear") is None:
        ball.pop("disappear", None)
    spec = _build(BallSpec, ball, where, path)
    try:
        colour_bgr(spec.colour)
    except StereotrackError as exc:
        raise StereotrackError(f"{path}: '{where}.colour': {exc}") from None
    return spec


def scene_from_dict(data: Any, path: str | Path = "<scene>") -> SceneSpec:
    """A scene from parsed YAML: an optional ``preset`` with overrides, or a full scene with ``balls``."""
    if not isinstance(data, dict):
        raise StereotrackError(f"{path}: expected a mapping (see the README's scene file example)")
    data = dict(data)
    allowed = {"name", "preset", "params", "rig", "balls", "occluders", "lighting"} | _SCENE_KEYS
    unknown = set(data) - allowed
    if unknown:
        raise StereotrackError(f"{path}: '{sorted(unknown)[0]}': unknown field (expected {', '.join(sorted(allowed))})")
    rig_data = data.get("rig") or {}
    if not isinstance(rig_data, dict):
        raise StereotrackError(f"{path}: 'rig': expected a mapping")
    scene_over = {k: data[k] for k in _SCENE_KEYS if k in data}
    if "preset" in data:
        params = data.get("params") or {}
        if not isinstance(params, dict) or not all(isinstance(k, str) for k in params):
            raise StereotrackError(f"{path}: 'params': expected a mapping of preset parameters")
        try:
            spec = make_preset(str(data["preset"]), **params, **rig_data, **scene_over)
        except (TypeError, ValueError, ArithmeticError, IndexError, KeyError) as exc:  # a parameter of the wrong kind
            raise StereotrackError(f"{path}: 'params': the preset cannot use these values ({str(exc).splitlines()[0][:100]})") from None
    else:
        if not isinstance(data.get("balls"), list) or not data["balls"]:
            raise StereotrackError(f"{path}: 'balls': expected a list of balls (or give a 'preset')")
        rig = _build(RigSpec, rig_data, "rig", path)
        balls = tuple(_ball(b, i, path) for i, b in enumerate(data["balls"]))
        spec = SceneSpec(name=str(data.get("name", Path(str(path)).stem)), balls=balls, rig=rig, **{k: v for k, v in scene_over.items()})
        if "n_frames" not in scene_over:
            spec = dataclasses.replace(spec, n_frames=_n(3.0, spec.fps))
    if "occluders" in data:
        occ = tuple(_build(Occluder, o, f"occluders[{i}]", path) for i, o in enumerate(data["occluders"] or []))
        spec = dataclasses.replace(spec, occluders=occ)
    if "lighting" in data:
        spec = dataclasses.replace(spec, lighting=_build(Lighting, data["lighting"], "lighting", path))
    if "name" in data:
        spec = dataclasses.replace(spec, name=str(data["name"]))
    check_scene(spec, path)
    return spec


# Ranges of a scene's settings (field: lowest, highest, whole number); every other number must be finite.
_SCENE_LIMITS = {
    "fps": (1e-3, 1000, False),
    "n_frames": (1, 100_000, True),
    "seed": (0, 2**32 - 1, True),
    "distractors": (0, 1000, True),
    "noise": (0, 100, False),
    "blur": (1, 32, True),
    "exposure": (0, 1, False),
    "jpeg_quality": (0, 100, True),
}
_RIG_LIMITS = {
    "cameras": (2, 8, True),
    "width": (32, 8192, True),
    "height": (32, 8192, True),
    "hfov": (1, 170, False),
    "baseline": (1e-3, 10, False),
    "aim_distance": (0.05, 100, False),
}


def check_scene(spec: SceneSpec, path: str | Path = "<scene>") -> None:
    """Refuse a scene the renderer cannot draw: numbers out of range, not finite, or of the wrong kind."""
    for section, obj, limits in (("", spec, _SCENE_LIMITS), ("rig.", spec.rig, _RIG_LIMITS)):
        for name, (lo, hi, whole) in limits.items():
            value = getattr(obj, name)
            kind = "a whole number" if whole else "a number"
            if (
                isinstance(value, bool)
                or not isinstance(value, (int, float))
                or not math.isfinite(value)
                or (whole and value != int(value))
            ):
                raise StereotrackError(f"{path}: '{section}{name}': expected {kind}, got {value!r:.60}")
            if not lo <= value <= hi:
                raise StereotrackError(f"{path}: '{section}{name}': expected {kind} from {lo:g} to {hi:g}, got {value!r}")
    if len(spec.rig.dist) not in (0, 4, 5, 8, 12, 14):
        raise StereotrackError(f"{path}: 'rig.dist': expected 0, 4, 5, 8, 12 or 14 coefficients, got {len(spec.rig.dist)}")
    for i, ball in enumerate(spec.balls):
        if isinstance(ball.radius, bool) or not isinstance(ball.radius, (int, float)) or not 0.001 <= ball.radius <= 1:
            raise StereotrackError(f"{path}: 'balls[{i}].radius': expected a ball radius in metres (0.001..1), got {ball.radius!r:.60}")
    _check_finite(spec, path, "")


def _check_finite(obj: Any, path, where: str) -> None:
    """Every number in the scene's dataclasses is a finite real number (a ball's 'disappear' may be infinite)."""
    if dataclasses.is_dataclass(obj):
        for f in dataclasses.fields(obj):
            _check_finite(getattr(obj, f.name), path, f"{where}{'.' if where else ''}{f.name}")
    elif isinstance(obj, (tuple, list)):
        for i, v in enumerate(obj):
            _check_finite(v, path, f"{where}[{i}]")
    elif isinstance(obj, np.ndarray):
        if obj.dtype.kind == "f" and not where.endswith("points") and not np.all(np.isfinite(obj)):
            raise StereotrackError(f"{path}: '{where}': expected finite numbers")
    elif isinstance(obj, float) and not math.isfinite(obj) and not where.endswith("disappear"):
        raise StereotrackError(f"{path}: '{where}': expected a finite number, got {obj!r}")
    elif obj is not None and not isinstance(obj, (str, bool, int, float, np.ndarray)):
        raise StereotrackError(f"{path}: '{where}': expected a number or a list of numbers, got {obj!r:.60}")


def load_scene_yaml(path: str | Path) -> SceneSpec:
    return scene_from_dict(load_yaml(path, "scene file not found"), Path(path))
