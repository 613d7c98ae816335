"""Settings in one typed place: YAML config (formats.md section 4) -> frozen dataclasses.

Every setting has a documented default here; the README's settings table is
generated from these docstrings' field comments. Unknown keys and values out
of range are refused with a message naming the file and the key.
"""

from __future__ import annotations

import dataclasses
import difflib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from .errors import StereotrackError
from .files import load_yaml


@dataclass(frozen=True)
class Target:
    """A ball colour to track: an OpenCV HSV range and the ball's radius."""

    name: str
    hsv_min: tuple[int, int, int]  # H 0..179, S and V 0..255
    hsv_max: tuple[int, int, int]  # hsv_min[0] > hsv_max[0]: the hue range wraps around red
    radius: float = 0.035  # ball radius in metres

    @property
    def wraps(self) -> bool:
        return self.hsv_min[0] > self.hsv_max[0]


@dataclass(frozen=True)
class TrackerSettings:
    """The particle tracker (paper sections III-B to III-F)."""

    particles: int = 2000  # N, total particles per target
    alpha: float = 0.2  # share of abductive (importance-sampled) particles, 0..1
    window: int = 5  # colour window W in pixels (odd)
    motion_sigma: float = 0.02  # random-walk standard deviation per frame, metres
    d_min: float = 0.2  # nearest depth along a viewing ray for abductive particles, metres
    d_max: float = 5.0  # farthest depth along a viewing ray, metres
    blob_method: str = "components"  # "components" (connected components) or "histogram" (paper's axis maxima)
    min_blob_area: int = 6  # smallest colour blob, pixels
    depth_from_size: bool = True  # narrow the ray's depth range with the ball's apparent size
    crossing_share: float = 0.25  # share of the abductive particles placed where blob rays of two cameras cross (the rest along the rays)
    cluster_min_likelihood: float = 0.05  # particles below this likelihood are not clustered
    cluster_min_mass: float = 0.01  # clusters with less weight are dropped
    cluster_min_particles: int = 8  # clusters with fewer particles are dropped
    max_objects: int = 12  # at most this many objects per target
    em: str = "numpy"  # "numpy" (our weighted EM, compiled; default) or "sklearn" (GaussianMixture on resampled particles; slower)
    particle_velocity: bool = True  # particles near a track drift with its velocity (else the paper's pure random walk)
    exclusion: bool = True  # a particle following one track dies inside another tracked ball (seed 000's blocking)
    occlusion: bool = (
        True  # a camera whose view of a particle (or of a ball's blob) is blocked by a tracked ball of another colour does not judge it
    )
    refine: bool = True  # objects take the triangulated centroids of the blobs they alone explain (with one clean view: its ray, depth from particles + motion)
    disc_fit: bool = (
        True  # with one clean view and a blob shared with other balls in another: depth along the ray where the balls' discs best fit it
    )
    seed: int = 0  # random seed; runs are reproducible


@dataclass(frozen=True)
class TrackSettings:
    """Persistent identities (stereotrack/tracks): a Kalman filter per track, gated global assignment, a lifecycle in seconds."""

    gate: float = 11.34  # Mahalanobis gate on the squared distance (chi-square, 3 dof: 7.81 = 95%, 11.34 = 99%)
    confirm_time: float = 0.1  # seconds of hits before a new track is confirmed (only confirmed tracks go to tracks.csv)
    tentative_time: float = 0.05  # a tentative track unseen for longer than this, seconds, is dropped (clutter)
    report_coasting: float = 0.07  # seconds a confirmed track missed by the detector is still written, at its prediction
    delete_time: float = 0.5  # a track unseen for longer than this, seconds, is deleted; a ball seen again sooner keeps its id
    accel_noise: float = 30.0  # motion model: white-acceleration spectral density, m^2/s^3 (how fast a ball may change velocity)
    measurement_sigma: float = 0.01  # metres, added to each object's own covariance as measurement noise
    init_speed_sigma: float = 3.0  # velocity uncertainty of a new track, m/s
    min_separation: float = 0.05  # metres; an unmatched object this close to a live track is that ball seen twice, not a new one
    up: tuple[float, float, float] | None = None  # the world's up axis, e.g. [0, 0, 1], for gravity; none = no gravity (unknown rig)
    g: float = 9.81  # gravity, m/s^2, used only when 'up' is set
    flight_window: float = (
        0.25  # seconds of recent positions that decide if a ball flies freely (gravity on) or is held, swung or rolled (off)
    )


@dataclass(frozen=True)
class BaselineSettings:
    """The classic OpenCV pipeline (baseline.py, `stereotrack track --method baseline`)."""

    max_epipolar_px: float = 4.0  # blobs further than this from each other's epipolar line are not paired, pixels
    pixel_sigma: float = 1.0  # blob centroid noise, pixels; sets each triangulated point's covariance


@dataclass(frozen=True)
class Config:
    targets: tuple[Target, ...] = ()
    tracker: TrackerSettings = field(default_factory=TrackerSettings)
    tracks: TrackSettings = field(default_factory=TrackSettings)
    baseline: BaselineSettings = field(default_factory=BaselineSettings)


_RANGES: dict[str, tuple[float, float]] = {
    "particles": (1, 10_000_000),
    "alpha": (0.0, 1.0),
    "crossing_share": (0.0, 1.0),
    "window": (1, 101),
    "motion_sigma": (0.0, 10.0),
    "d_min": (0.0, 1000.0),
    "d_max": (0.0, 1000.0),
    "min_blob_area": (1, 1_000_000),
    "cluster_min_likelihood": (0.0, 1.0),
    "cluster_min_mass": (0.0, 1.0),
    "cluster_min_particles": (1, 1_000_000),
    "max_objects": (1, 1000),
}
# tracks: and baseline: sections
_RANGES.update(
    {
        "gate": (0.1, 1000.0),
        "confirm_time": (0.0, 60.0),
        "tentative_time": (0.0, 60.0),
        "delete_time": (0.0, 3600.0),
        "report_coasting": (0.0, 3600.0),
        "accel_noise": (0.0, 1e6),
        "measurement_sigma": (0.0, 10.0),
        "init_speed_sigma": (0.0, 1000.0),
        "min_separation": (0.0, 10.0),
        "g": (0.0, 1000.0),
        "max_epipolar_px": (0.0, 10000.0),
        "pixel_sigma": (0.0, 1000.0),
    }
)
_CHOICES: dict[str, tuple[str, ...]] = {"blob_method": ("components", "histogram"), "em": ("numpy", "sklearn")}


def _err(path, key: str, what: str) -> StereotrackError:
    return StereotrackError(f"{path}: '{key}': {what}")


def _section(path, name: str, cls, data: Any):
    """Build a settings dataclass from a mapping, checking names, types and ranges."""
    if data is None:
        return cls()
    if not isinstance(data, dict):
        raise _err(path, name, "expected a mapping of settings")
    fields = {f.name: f for f in dataclasses.fields(cls)}
    kwargs = {}
    for key, value in data.items():
        if key not in fields:
            hint = difflib.get_close_matches(str(key), fields, n=1)
            raise _err(path, f"{name}.{key}", "unknown setting" + (f" (did you mean '{hint[0]}'?)" if hint else ""))
        default = getattr(cls(), key)
        try:
            if isinstance(default, bool):
                if not isinstance(value, bool):
                    raise TypeError
            elif isinstance(default, int):
                if isinstance(value, bool) or float(value) != int(value):
                    raise TypeError
                value = int(value)
            elif isinstance(default, float):
                if isinstance(value, bool):
                    raise TypeError
                value = float(value)
            elif isinstance(default, str):
                value = str(value)
        except (TypeError, ValueError):
            raise _err(path, f"{name}.{key}", f"expected a {type(default).__name__}, got {value!r}") from None
        if key in _RANGES:
            lo, hi = _RANGES[key]
            if not lo <= value <= hi:
                raise _err(path, f"{name}.{key}", f"must be between {lo:g} and {hi:g}, got {value!r}")
        if key in _CHOICES and value not in _CHOICES[key]:
            raise _err(path, f"{name}.{key}", f"must be one of {', '.join(_CHOICES[key])}, got {value!r}")
        kwargs[key] = value
    return cls(**kwargs)


def _hsv(path, key: str, value: Any) -> tuple[int, int, int]:
    if not (isinstance(value, (list, tuple)) and len(value) == 3):
        raise _err(path, key, f"expected [H, S, V], got {value!r}")
    try:
        h, s, v = (int(x) for x in value)
    except (TypeError, ValueError):
        raise _err(path, key, f"expected three whole numbers, got {value!r}") from None
    if not (0 <= h <= 179 and 0 <= s <= 255 and 0 <= v <= 255):
        raise _err(path, key, f"OpenCV HSV needs H in 0..179 and S, V in 0..255, got {value!r}")
    return (h, s, v)


def target_from_dict(path, i: int, d: Any) -> Target:
    where = f"targets[{i}]"
    if not isinstance(d, dict):
        raise _err(path, where, "expected a mapping with name, hsv_min, hsv_max, radius")
    for key in ("name", "hsv_min", "hsv_max"):
        if key not in d:
            raise _err(path, f"{where}.{key}", "missing")
    unknown = set(d) - {"name", "hsv_min", "hsv_max", "radius"}
    if unknown:
        raise _err(path, f"{where}.{sorted(unknown)[0]}", "unknown field (expected name, hsv_min, hsv_max, radius)")
    lo = _hsv(path, f"{where}.hsv_min", d["hsv_min"])
    hi = _hsv(path, f"{where}.hsv_max", d["hsv_max"])
    if lo[1] > hi[1] or lo[2] > hi[2]:
        raise _err(path, where, f"hsv_min {list(lo)} must not exceed hsv_max {list(hi)} in S and V (only H may wrap)")
    try:
        radius = float(d.get("radius", Target.radius))
    except (TypeError, ValueError):
        raise _err(path, f"{where}.radius", f"expected metres, got {d.get('radius')!r}") from None
    if not 0.001 <= radius <= 1.0:
        raise _err(path, f"{where}.radius", f"expected a ball radius in metres (0.001..1), got {radius}")
    return Target(name=str(d["name"]), hsv_min=lo, hsv_max=hi, radius=radius)


def config_from_dict(data: Any, path: str | Path = "<config>") -> Config:
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise _err(path, "<top level>", "expected a mapping with 'targets' and optional 'tracker'")
    known = {f.name for f in dataclasses.fields(Config)}
    for key in data:
        if key not in known:
            raise _err(path, str(key), f"unknown section (expected {', '.join(sorted(known))})")
    raw_targets = data.get("targets") or []
    if not isinstance(raw_targets, list):
        raise _err(path, "targets", "expected a list of targets")
    targets = tuple(target_from_dict(path, i, t) for i, t in enumerate(raw_targets))
    names = [t.name for t in targets]
    if len(set(names)) != len(names):
        raise _err(path, "targets", f"target names must be unique, got {names}")
    tracker = _section(path, "tracker", TrackerSettings, data.get("tracker"))
    if tracker.d_min >= tracker.d_max:
        raise _err(path, "tracker.d_min", f"must be less than d_max ({tracker.d_max}), got {tracker.d_min}")
    if tracker.window % 2 == 0:
        raise _err(path, "tracker.window", f"must be odd so the window is centred, got {tracker.window}")
    tracks = _section(path, "tracks", TrackSettings, data.get("tracks"))
    tracks = dataclasses.replace(tracks, up=up_axis(tracks.up, f"{path}: 'tracks.up'"))
    baseline = _section(path, "baseline", BaselineSettings, data.get("baseline"))
    return Config(targets=targets, tracker=tracker, tracks=tracks, baseline=baseline)


def up_axis(value: Any, where: str = "up") -> tuple[float, float, float] | None:
    """A world 'up' axis from YAML ([x, y, z], or none) -> unit 3-tuple or None; ``where`` names it in errors."""
    if value is None:
        return None
    try:
        v = [float(x) for x in value]
    except (TypeError, ValueError):
        v = []
    norm = sum(x * x for x in v) ** 0.5 if len(v) == 3 else 0.0
    if not 1e-9 < norm < float("inf"):
        raise StereotrackError(f"{where}: expected the world's up axis as [x, y, z] (e.g. [0, 0, 1]) or none, got {value!r}")
    return (v[0] / norm, v[1] / norm, v[2] / norm)


def load_config(path: str | Path) -> Config:
    return config_from_dict(load_yaml(path, "config file not found"), Path(path))


def target_to_dict(t: Target) -> dict[str, Any]:
    return {"name": t.name, "hsv_min": list(t.hsv_min), "hsv_max": list(t.hsv_max), "radius": float(t.radius)}


def config_to_dict(config: Config, include_defaults: bool = False) -> dict[str, Any]:
    """Config -> YAML-able mapping; by default only settings that differ from the defaults."""
    out: dict[str, Any] = {"targets": [target_to_dict(t) for t in config.targets]}
    for f in dataclasses.fields(Config):
        if f.name == "targets":
            continue
        section = getattr(config, f.name)
        defaults = type(section)()
        values = {
            k.name: getattr(section, k.name)
            for k in dataclasses.fields(section)
            if include_defaults or getattr(section, k.name) != getattr(defaults, k.name)
        }
        if values:
            out[f.name] = values
    return out


def save_config(config: Config, path: str | Path) -> None:
    Path(path).write_text(yaml.safe_dump(config_to_dict(config), sort_keys=False, default_flow_style=None))
