"""Settings in one typed place: YAML config (formats.md section 4) -> frozen dataclasses.

Every setting is declared once, with ``setting(default, doc, low=, high=,
choices=)``: its default, what it means and the values it accepts side by
side. The loader refuses unknown keys, wrong types, non-finite numbers and
values out of range with a message naming the file and the key; the
README's settings table is printed from the same declarations
(``python -m stereotrack.config``; a test keeps the README in step). The
stages take views of these settings (``ClusterSettings.of``,
``ExplainSettings.of``), so no default is written twice.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .errors import StereotrackError
from .files import dump_yaml, load_yaml, write_text_atomic


@dataclass(frozen=True)
class Target:
    """A ball colour to track: an OpenCV HSV range and the ball's radius."""

    name: str
    hsv_min: tuple[int, int, int]  # H 0..179, S and V 0..255
    hsv_max: tuple[int, int, int]  # hsv_min[0] > hsv_max[0]: the hue range wraps around red
    radius: float = 0.035  # ball radius in metres
    colour_model: str | None = None  # a colour model file learnt by `colour learn` (path resolved from the config's folder)

    @property
    def wraps(self) -> bool:
        return self.hsv_min[0] > self.hsv_max[0]

    @property
    def any_hue(self) -> bool:
        """A range that takes every hue: a white, grey or black ball, told from the room by brightness alone."""
        return self.hsv_min[0] == 0 and self.hsv_max[0] >= 179


def setting(default: Any, doc: str, *, low: float | None = None, high: float | None = None, choices: tuple[str, ...] = ()) -> Any:
    """A documented setting: its default, what it means, and the values it accepts, side by side.

    The config loader checks values against ``low``/``high`` (inclusive) and
    ``choices``; the README's settings table is printed from ``doc``
    (``python -m stereotrack.config``).
    """
    return field(default=default, metadata={"doc": doc, "low": low, "high": high, "choices": choices})


@dataclass(frozen=True)
class TrackerSettings:
    """The particle tracker (paper sections III-B to III-F)."""

    particles: int = setting(2000, "N, total particles per target", low=1, high=1_000_000)  # 10^7 took 34 s a frame: no run ends
    alpha: float = setting(0.2, "share of abductive (importance-sampled) particles, 0..1", low=0.0, high=1.0)
    window: int = setting(5, "colour window W in pixels (odd)", low=1, high=101)
    likelihood: str = setting(
        "ball_shape",
        "observation model, a file of stereotrack/particles/likelihoods/: ball_shape (a ball-sized disc of evidence with an empty "
        "ring around it, at the particle's depth) or colour_window (the paper's eq. 14)",
    )
    motion: bool = setting(True, "learn each camera's background: the moving part of the colour mask counts as evidence too")
    shading: bool = setting(
        True,
        "a white or grey target (one of every hue) also counts round shaded patches alone on something flat as moving, so a "
        "ball at rest in a white room is seen, and such patches among other edges where another camera shows the same ball, "
        "clear of what it is seen on (tracker.surfaces) (with motion only; 3-6 ms a camera at 640x480)",
    )
    background_rate: float = setting(0.05, "how fast the background learns a change, share per frame", low=0.001, high=1.0)
    background_start: int = setting(
        15,
        "tracking a recording with a white or grey target: each camera's background starts as the per-pixel median of "
        "this many of its frames, spread over its first 10 s (balls move, the room does not), not as its first frame, "
        "whose balls leave ghosts where they were; 0 = from the first frame, as live cameras and coloured targets do",
        low=0,
        high=1000,
    )
    foreground_threshold: float = setting(
        30.0, "grey levels (summed over the three channels) a pixel must differ from the background to be moving", low=1.0, high=254.0
    )
    colour_model: bool = setting(
        True,
        "learn each target's colours against the background's (hue-saturation histograms, refined online from confirmed "
        "tracks): a colour common in the room counts less than the ball's",
    )
    surfaces: bool = setting(
        True,
        "an object still in every view whose surroundings match between two views at its own depth is a patch of the surface "
        "it is seen on (a book's end, a poster's corner of the ball's colour), not a ball before it, unless it shows as a whole "
        "ball in every view, 6 pixels or more in radius (a ball at rest against a wall), and one of a coloured target "
        "whose blob is a ball's disc of the size at its depth in no view, or that lies at the end of a bar of its colour as "
        "wide as it in some view (unless, before things of its colour, its outline shows all round), or that is one flat "
        "colour in every view (a sticker), or whose outline is round in no view that shows it 5 pixels or more in radius (a "
        "cube), is no ball: both dropped (with motion only); so is a white or grey target's object in whose disc nothing "
        "changed in the last 5 frames (its shading keeps it moving), away from every travelled ball, whose outline is "
        "round in no view (a table's corner)",
    )
    outlines: bool = setting(
        True,
        "a white or grey target's still blob that no other view shows as the same ball is looked for along its viewing ray "
        "by its outline: where another camera shows a round outline of the ball's size at one depth (a ball at rest before "
        "a white wall there), the blob's own outline is round too, and it is neither one flat colour (a knob) nor a patch "
        "of the surface it is seen on, both discs count as moving and the buried one's ring as out of the range; a ball so "
        "found stays so while it is still (with motion and two cameras or more only)",
    )
    ball_blobs_only: bool = setting(
        True, "abductive particles start only from blobs that could be a ball at some depth in [d_min, d_max] (size, roundness)"
    )
    evidence_scale: int = setting(
        0,
        "build each camera's evidence on a grid this many times coarser than its images (1 = every pixel); 0 = automatic: "
        "2 for images 1280 pixels wide or more where the smallest ball at d_max still spans 5 pixels of radius, with the "
        "ball_shape likelihood; else 1",
        low=0,
        high=8,
    )
    threads: int = setting(
        1,
        "threads that build the cameras' evidence side by side: 1 = none, 0 = one per camera up to the machine's cores "
        "(no gain measured on a busy 2-core machine: BENCHMARKS.md)",
        low=0,
        high=64,
    )
    motion_sigma: float = setting(0.02, "random-walk standard deviation per frame, metres", low=0.0, high=10.0)
    d_min: float = setting(0.2, "nearest depth along a viewing ray for abductive particles, metres", low=0.0, high=1000.0)
    d_max: float = setting(5.0, "farthest depth along a viewing ray, metres", low=0.0, high=1000.0)
    blob_method: str = setting(
        "components", '"components" (connected components) or "histogram" (paper\'s axis maxima)', choices=("components", "histogram")
    )
    min_blob_area: int = setting(6, "smallest colour blob, pixels", low=1, high=1_000_000)
    depth_from_size: bool = setting(True, "narrow the ray's depth range with the ball's apparent size")
    crossing_share: float = setting(
        0.25, "share of the abductive particles placed where blob rays of two cameras cross (the rest along the rays)", low=0.0, high=1.0
    )
    track_floor: float = setting(
        0.5,
        "share of the resampled particles kept for a coloured target's confirmed tracks' balls, split evenly: a ball whose likelihood falls"
        " (held in a hand, half hidden) keeps particles while another takes the weight (0: by weight alone, the paper's)",
        low=0.0,
        high=1.0,
    )
    cluster_min_likelihood: float = setting(0.05, "particles below this likelihood are not clustered", low=0.0, high=1.0)
    cluster_min_mass: float = setting(0.01, "clusters with less weight are dropped", low=0.0, high=1.0)
    cluster_min_particles: int = setting(
        8,
        "clusters with fewer particles are dropped; while EM runs on its 250-particle subsample, those with fewer of its points"
        " (under 0.032 of the weight at 8)",
        low=1,
        high=1_000_000,
    )
    max_objects: int = setting(12, "at most this many objects per target", low=1, high=1000)
    em: str = setting(
        "numpy",
        '"numpy" (our weighted EM, compiled; default) or "sklearn" (GaussianMixture on resampled particles; slower)',
        choices=("numpy", "sklearn"),
    )
    particle_velocity: bool = setting(True, "particles near a track drift with its velocity (else the paper's pure random walk)")
    exclusion: bool = setting(True, "a particle following one track dies inside another tracked ball (seed 000's blocking)")
    occlusion: bool = setting(
        True,
        "a camera whose view of a particle (or of a ball's blob) is blocked by a tracked ball of another colour does not judge it "
        "(not by one overlapping a tracked ball of its own: two balls cannot overlap, so that is one thing two targets see, "
        "such as an orange ball's white highlight)",
    )
    refine: bool = setting(
        True,
        "objects take the triangulated centroids of the blobs they alone explain (with one clean view: its ray, depth from the "
        "particles, or from the ball's track when the other view's blob is shared with another ball)",
    )
    disc_fit: bool = setting(
        True, "with one clean view and a blob shared with other balls in another: depth along the ray where the balls' discs best fit it"
    )
    seed: int = setting(0, "random seed; runs are reproducible", low=0, high=2**63 - 1)

    def check(self, where: Any) -> None:
        """What no single field can say; raises StereotrackError naming ``where`` (the file)."""
        if self.d_min >= self.d_max:
            raise _err(where, "tracker.d_min", f"must be less than d_max ({self.d_max}), got {self.d_min}")
        if self.window % 2 == 0:
            raise _err(where, "tracker.window", f"must be odd so the window is centred, got {self.window}")


@dataclass(frozen=True)
class TrackSettings:
    """Persistent identities (stereotrack/tracks): a Kalman filter per track, gated global assignment, a lifecycle in seconds."""

    gate: float = setting(
        11.34, "Mahalanobis gate on the squared distance (chi-square, 3 dof: 7.81 = 95%, 11.34 = 99%)", low=0.1, high=1000.0
    )
    confirm_time: float = setting(
        0.1, "seconds of hits before a new track is confirmed (only confirmed tracks go to tracks.csv)", low=0.0, high=60.0
    )
    tentative_time: float = setting(
        0.05, "a tentative track unseen for longer than this, seconds, is dropped (clutter)", low=0.0, high=60.0
    )
    report_coasting: float = setting(
        0.07, "seconds a confirmed track missed by the detector is still written, at its prediction", low=0.0, high=3600.0
    )
    delete_time: float = setting(
        0.5, "a track unseen for longer than this, seconds, is deleted; a ball seen again sooner keeps its id", low=0.0, high=3600.0
    )
    accel_noise: float = setting(
        30.0, "motion model: white-acceleration spectral density, m^2/s^3 (how fast a ball may change velocity)", low=0.0, high=1e6
    )
    fast_accel_noise: float = setting(
        9.0, "motion model of a confirmed ball at 8 m/s or more (thrown, pitched: no hand carries one so fast) when 'up' is "
        "set: it flies under gravity and air drag; white-acceleration spectral density, m^2/s^3", low=0.0, high=1e6,
    )  # fmt: skip
    drag: float = setting(
        0.012, "air drag of a ball at 8 m/s or more (with 'up'), 1/m: it slows by drag x speed^2 (rho Cd area / 2 mass: a baseball 0.006, "
        "a football 0.013, a tennis ball 0.02, a table-tennis ball 0.14); 0 = none", low=0.0, high=10.0,
    )  # fmt: skip
    measurement_sigma: float = setting(0.01, "metres, added to each object's own covariance as measurement noise", low=0.0, high=10.0)
    init_speed_sigma: float = setting(3.0, "velocity uncertainty of a new track, m/s", low=0.0, high=1000.0)
    max_speed: float = setting(
        40.0, "m/s, the fastest a ball flies: a new track missed by its second object's gate takes the nearest unmatched "
        "one this fast away, and its velocity from the two (a thrown ball moves metres between frames); no track takes "
        "an object that would make it faster; 0 = off", low=0.0, high=1000.0,
    )  # fmt: skip
    confirm_speed: float = setting(
        5.0, "m/s; a track this fast is confirmed after three hits in a row, before confirm_time: clutter does not fly, "
        "and a thrown ball crosses the view in a few frames (0 = off)", low=0.0, high=1000.0,
    )  # fmt: skip
    min_separation: float = setting(
        0.05, "metres; an unmatched object this close to a live track is that ball seen twice, not a new one", low=0.0, high=10.0
    )
    up: tuple[float, float, float] | None = setting(
        None, "the world's up axis, e.g. [0, 0, 1], for gravity; none = no gravity (unknown rig)"
    )
    g: float = setting(9.81, "gravity, m/s^2, used only when 'up' is set", low=0.0, high=1000.0)
    flight_window: float = setting(
        0.25,
        "seconds of recent positions that decide if a ball flies freely (gravity on) or is held, swung or rolled (off)",
        low=0.01,
        high=60.0,
    )
    smooth_time: float = setting(
        0.15,
        "seconds of later frames each tracks.csv row is smoothed with (a Kalman smoother, in hindsight); 0 = the filter's "
        "estimate at its frame, as the live outputs (--udp, --osc) send it",
        low=0.0,
        high=5.0,
    )


@dataclass(frozen=True)
class BaselineSettings:
    """The classic OpenCV pipeline (pipeline/baseline.py, `stereotrack track --method baseline`)."""

    max_epipolar_px: float = setting(
        4.0, "blobs further than this from each other's epipolar line are not paired, pixels", low=0.0, high=1e4
    )
    pixel_sigma: float = setting(1.0, "blob centroid noise, pixels; sets each triangulated point's covariance", low=0.0, high=1000.0)


@dataclass(frozen=True)
class Config:
    targets: tuple[Target, ...] = ()
    tracker: TrackerSettings = field(default_factory=TrackerSettings)
    tracks: TrackSettings = field(default_factory=TrackSettings)
    baseline: BaselineSettings = field(default_factory=BaselineSettings)


SECTIONS = {"tracker": TrackerSettings, "tracks": TrackSettings, "baseline": BaselineSettings}  # config file section -> its settings


def settings_table() -> str:
    """The README's table of every setting, printed from the fields' own defaults and documentation."""
    header = (
        "Every key is optional in a config file's `tracker:`, `tracks:` and `baseline:` sections; "
        "unknown keys and out-of-range values are refused with the file and key named."
    )
    rows = [header, "", "| section.key | default | meaning |", "|---|---|---|"]
    for section, cls in SECTIONS.items():
        for f in dataclasses.fields(cls):
            rows.append(f"| `{section}.{f.name}` | `{f.default}` | {f.metadata['doc']} |")
    return "\n".join(rows)


def _err(path, key: str, what: str) -> StereotrackError:
    return StereotrackError(f"{path}: '{key}': {what}")


def _section(path, name: str, cls, data: Any):
    """Build a settings dataclass from a mapping, checking names, types, finiteness and the ranges its fields declare."""
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
        default = fields[key].default
        try:
            if isinstance(default, bool):
                if not isinstance(value, bool):
                    raise TypeError
            elif isinstance(default, int):
                if isinstance(value, bool):
                    raise TypeError
                # an int is whole as it is (through a float, the top seed 2**63 - 1 rounded to 2**63 and was refused)
                if not isinstance(value, int) and (not math.isfinite(float(value)) or float(value) != int(value)):
                    raise TypeError
                value = int(value)
            elif isinstance(default, float):
                if isinstance(value, bool):
                    raise TypeError
                value = float(value)
            elif isinstance(default, str):
                value = str(value)
        except (TypeError, ValueError, OverflowError):
            raise _err(path, f"{name}.{key}", f"expected a {type(default).__name__}, got {value!r}") from None
        meta = fields[key].metadata
        if isinstance(value, float) and not math.isfinite(value):
            raise _err(path, f"{name}.{key}", f"must be a finite number, got {value!r}")
        lo, hi = meta.get("low"), meta.get("high")
        if (lo is not None and value < lo) or (hi is not None and value > hi):
            raise _err(path, f"{name}.{key}", f"must be between {lo:g} and {hi:g}, got {value!r}")
        if meta.get("choices") and value not in meta["choices"]:
            raise _err(path, f"{name}.{key}", f"must be one of {', '.join(meta['choices'])}, got {value!r}")
        kwargs[key] = value
    return cls(**kwargs)


def _whole(x: Any) -> bool:
    """A whole number as YAML gives it: an int, or a float like 150.0 (not a bool, not 150.5, not inf)."""
    return not isinstance(x, bool) and (isinstance(x, int) or (isinstance(x, float) and math.isfinite(x) and x == int(x)))


def _hsv(path, key: str, value: Any) -> tuple[int, int, int]:
    if not (isinstance(value, (list, tuple)) and len(value) == 3):
        raise _err(path, key, f"expected [H, S, V], got {value!r:.80}")
    if not all(_whole(x) for x in value):
        raise _err(path, key, f"expected three whole numbers, got {value!r:.80}")
    h, s, v = (int(x) for x in value)
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
    unknown = set(d) - {"name", "hsv_min", "hsv_max", "radius", "colour_model"}
    if unknown:
        raise _err(path, f"{where}.{sorted(unknown)[0]}", "unknown field (expected name, hsv_min, hsv_max, radius, colour_model)")
    lo = _hsv(path, f"{where}.hsv_min", d["hsv_min"])
    hi = _hsv(path, f"{where}.hsv_max", d["hsv_max"])
    if lo[1] > hi[1] or lo[2] > hi[2]:
        raise _err(path, where, f"hsv_min {list(lo)} must not exceed hsv_max {list(hi)} in S and V (only H may wrap)")
    radius = d.get("radius", Target.radius)
    if isinstance(radius, bool) or not isinstance(radius, (int, float)) or not 0.001 <= radius <= 1.0:
        raise _err(path, f"{where}.radius", f"expected a ball radius in metres (0.001..1), got {radius!r:.80}")
    name = d["name"]
    if isinstance(name, bool) or not isinstance(name, (str, int)) or not str(name).strip() or any(c in str(name) for c in ",\n\r"):
        raise _err(path, f"{where}.name", f"expected a name without commas (it becomes a column of tracks.csv), got {name!r:.80}")
    model = d.get("colour_model")
    if model is not None:
        if not isinstance(model, str) or not model:
            raise _err(path, f"{where}.colour_model", f"expected the path of a colour model file, got {model!r:.80}")
        model = str(Path(path).parent / model) if not Path(model).is_absolute() else model
    return Target(name=str(name), hsv_min=lo, hsv_max=hi, radius=float(radius), colour_model=model)


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
    tracker.check(path)
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


def target_to_dict(t: Target, folder: str | Path | None = None) -> dict[str, Any]:
    """A target as a config names it; ``folder``: the config's, so its colour model's path is written as the
    loader reads it (relative to that folder, an absolute path outside it kept)."""
    out = {"name": t.name, "hsv_min": list(t.hsv_min), "hsv_max": list(t.hsv_max), "radius": float(t.radius)}
    if t.colour_model is not None:
        model = t.colour_model
        if folder is not None:
            inside = os.path.commonpath([os.path.abspath(model), os.path.abspath(folder)]) == os.path.abspath(folder)
            model = os.path.relpath(model, folder) if inside or not Path(model).is_absolute() else model
        out["colour_model"] = model
    return out


def config_to_dict(config: Config, include_defaults: bool = False, path: str | Path | None = None) -> dict[str, Any]:
    """Config -> YAML-able mapping; by default only settings that differ from the defaults. ``path``: where it is
    saved (colour model paths are written relative to its folder)."""
    folder = Path(path).parent if path is not None else None
    out: dict[str, Any] = {"targets": [target_to_dict(t, folder) for t in config.targets]}
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
    write_text_atomic(path, dump_yaml(config_to_dict(config, path=path)))


if __name__ == "__main__":  # python -m stereotrack.config: the README's settings table
    print(settings_table())
