"""What the pipeline hands to its sinks each frame: plain frozen data, no behaviour.

Data flows one way: source -> evidence -> particles -> objects -> tracks -> sinks.
Sinks (tracks CSV, rerun viewer, recording writer, console) receive a
``FrameResult`` per frame and never reach back into the tracker.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from .frames import FramePair


@dataclass(frozen=True, eq=False)
class ParticleSet:
    """One target's weighted particle population after this frame's update."""

    target: str
    positions: np.ndarray  # N x 3, world metres
    weights: np.ndarray  # N, summing to 1
    abductive: np.ndarray  # N bool: placed by abduction this frame (else sequential)
    labels: np.ndarray  # N int: object index in FrameResult.objects of this target, -1 = none


@dataclass(frozen=True, eq=False)
class Object3D:
    """One cluster of particles this frame (paper section III-F): a ball candidate."""

    target: str
    position: np.ndarray  # 3, weighted mean, world metres
    covariance: np.ndarray  # 3 x 3, weighted particle covariance
    mass: float  # share of the target's particle weight in this cluster
    n_particles: int
    swept: bool = False  # placed at a fast ball's streaks triangulated in two or more cameras (objects/explain.py)


@dataclass(frozen=True, eq=False)
class Parabola:
    """A ball in free flight: the parabola fitted to its recent positions under gravity.

    ``p(t) = position + velocity (t - time) + acceleration (t - time)^2 / 2``, world metres and seconds.
    """

    time: float  # seconds, the time of the latest position fitted
    position: np.ndarray  # 3, world metres, at ``time``
    velocity: np.ndarray  # 3, metres per second, at ``time``
    acceleration: np.ndarray  # 3, m/s^2: gravity


@dataclass(frozen=True, eq=False)
class TrackEstimate:
    """A ball with an identity over time."""

    track_id: int  # positive, unique across targets within a run
    target: str
    position: np.ndarray  # 3, world metres
    velocity: np.ndarray  # 3, metres per second
    covariance: np.ndarray  # 3 x 3 position covariance
    state: str  # "tentative", "confirmed" or "coasting"
    n_particles: int = 0
    reported: bool = False  # written to tracks.csv: confirmed, or coasting for at most tracks.report_coasting s
    flight: Parabola | None = None  # the fitted parabola while the ball flies freely (needs tracks.up), else None
    settled: bool = False  # it has moved since it was first past tentative, or lived a while: its ball is no ghost (tracks/manager.py)
    travelled: bool = False  # it has moved across a camera's line of sight since it was first past tentative: no scenery
    # The frame it is confirmed: its hits while tentative and the frames it missed between them (placed on the line
    # between the hits), each (time, position, 3 x 3 covariance, n_particles), for the tracks.csv to write in hindsight
    # (a ball is in the file from the frame it was first seen, not confirm_time later).
    before: tuple = ()
    # Its states at the frames smooth_time old by now smoothed with every frame since (a Kalman smoother): each (time,
    # position, 3 x 3 covariance, fill), oldest first, given once (mostly one a frame; several after a slower frame), for
    # the tracks.csv and the viewer to write in place of that frame's (tracks.smooth_time); with ``fill``, also where
    # it wrote none (it coasted unreported, and its ball was met again since: tracks/smoothing.hindsight_fills).
    smoothed: tuple = ()


@dataclass(frozen=True, eq=False)
class TrackedBalls:
    """Where the tracks put balls this frame, every target's: the one form the stages read it in.

    The population keeps particles out of other balls and lets other colours
    occlude; the likelihood skips a camera whose view a ball of another colour
    blocks; explain-away favours objects where a track predicts a ball and cuts
    blobs that a nearer ball covers. Each takes the selection it needs
    (``confirmed_only``, ``of``, ``others``).
    """

    centres: np.ndarray  # B x 3, world metres
    radii: np.ndarray  # B, metres
    track_ids: np.ndarray  # B, int
    targets: tuple[str, ...]  # B target names
    confirmed: np.ndarray  # B bool: seen at the latest update (else coasting)
    settled: np.ndarray | None = None  # B bool: the ball may keep the background from learning its disc (None: every ball)
    travelled: np.ndarray | None = None  # B bool: the ball has moved, it is no scenery (None: every ball)

    def __post_init__(self):
        for name in ("settled", "travelled"):
            if getattr(self, name) is None:
                object.__setattr__(self, name, np.ones(len(self.centres), dtype=bool))

    @classmethod
    def from_tracks(cls, tracks: Sequence[TrackEstimate], radius: Mapping[str, float], tentative: Sequence[str] = ()) -> TrackedBalls:
        """The tracks past their tentative start (confirmed or coasting), with their target's ball radius; the tentative
        ones of the targets named in ``tentative`` too (never settled, not confirmed)."""
        live = [t for t in tracks if t.state != "tentative" or t.target in tentative]
        return cls(
            np.array([t.position for t in live]).reshape(-1, 3),
            np.array([radius[t.target] for t in live]),
            np.array([t.track_id for t in live], dtype=int),
            tuple(t.target for t in live),
            np.array([t.state == "confirmed" for t in live], dtype=bool),
            np.array([t.settled for t in live], dtype=bool),
            np.array([t.travelled for t in live], dtype=bool),
        )

    def __len__(self) -> int:
        return len(self.centres)

    def where(self, keep: np.ndarray) -> TrackedBalls:
        """The balls ``keep`` marks; all of them (most selections, a dozen a frame: one colour, every track confirmed
        and settled) are these same balls, not a copy (no stage writes into them)."""
        keep = np.asarray(keep, dtype=bool)
        if keep.all():
            return self
        return TrackedBalls(
            self.centres[keep].reshape(-1, 3),
            self.radii[keep],
            self.track_ids[keep],
            tuple(np.array(self.targets, dtype=object)[keep]),
            self.confirmed[keep],
            self.settled[keep],
            self.travelled[keep],
        )

    def confirmed_only(self) -> TrackedBalls:
        return self.where(self.confirmed)

    def of(self, target: str) -> TrackedBalls:
        """The balls of one target."""
        if all(t == target for t in self.targets):  # (``where`` of every ball: these balls; one colour, most scenes)
            return self
        return self.where(np.array([t == target for t in self.targets], dtype=bool))

    def others(self, target: str) -> TrackedBalls:
        """The balls of every other target."""
        if all(t != target for t in self.targets):
            return self
        return self.where(np.array([t != target for t in self.targets], dtype=bool))

    def occluding(self, target: str) -> TrackedBalls:
        """The balls of every other target that may hide ``target``'s: not those that overlap one of its own. Two solid
        balls cannot overlap, so a ball of another target that does is no ball in front of it but the same thing seen as
        both (an orange ball's white highlight, tracked by a white target): taken as one, it hid the orange ball from a
        camera, and ghosts along its rays in the other camera went unchallenged (hue_wall tune seed 2 with a white
        target added: the orange ball's MOTA 1.000 alone, -0.100 so, 1.000 without occlusion)."""
        others, own = self.others(target), self.of(target)
        if not len(others) or not len(own):
            return others
        gaps = np.linalg.norm(others.centres[:, None] - own.centres[None], axis=2)
        return others.where(~(gaps < others.radii[:, None] + own.radii[None]).any(axis=1))


@dataclass(frozen=True, eq=False)
class Rays:
    """The abduction's viewing rays for one target this frame (for display)."""

    target: str
    camera: str
    origins: np.ndarray  # M x 3
    directions: np.ndarray  # M x 3 unit vectors
    pixels: np.ndarray  # M x 2 blob centres in that camera


@dataclass(frozen=True, eq=False)
class FrameResult:
    frame: FramePair
    particles: tuple[ParticleSet, ...] = ()
    objects: tuple[Object3D, ...] = ()
    tracks: tuple[TrackEstimate, ...] = ()  # every live track, whatever its state
    rays: tuple[Rays, ...] = ()
    masks: dict[tuple[str, str], np.ndarray] = field(default_factory=dict)  # (target, camera) -> uint8 0/1 mask of the HSV range
    evidence: dict[tuple[str, str], np.ndarray] = field(default_factory=dict)  # ... what the observation model kept: colour or motion
    timings_ms: dict[str, float] = field(default_factory=dict)  # per stage, this frame
    latency_s: float | None = None  # grab-to-estimate, live sources only

    @property
    def confirmed(self) -> tuple[TrackEstimate, ...]:
        """The tracks a user sees (tracks.csv, the viewer): confirmed ones, and those coasting very briefly."""
        return tuple(t for t in self.tracks if t.reported)


class Sink(Protocol):
    """Receives every frame's result; ``close`` is called once, also after Ctrl-C."""

    def write(self, result: FrameResult) -> None: ...

    def close(self) -> None: ...
