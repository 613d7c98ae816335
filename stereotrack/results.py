"""What the pipeline hands to its sinks each frame: plain frozen data, no behaviour.

Data flows one way: source -> masks -> particles -> objects -> tracks -> sinks.
Sinks (tracks CSV, rerun viewer, recording writer, console) receive a
``FrameResult`` per frame and never reach back into the tracker.
"""

from __future__ import annotations

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
    masks: dict[tuple[str, str], np.ndarray] = field(default_factory=dict)  # (target, camera) -> uint8 0/1 mask
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
