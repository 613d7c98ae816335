"""What sources deliver: synchronised frame pairs (an image per camera, with capture times), and what a source is.

A source (``Source``) is any iterable of ``FramePair`` that also says which
rig filmed it, its frame rate and how many pairs it holds, counts what it
delivered and dropped, and closes: live cameras (``capture.CameraPairSource``),
a recording (``capture.RecordingSource``). The tracker never knows which.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from .camera import Rig


@dataclass(frozen=True, eq=False)
class FramePair:
    """One synchronised set of frames, one image per camera (two or more)."""

    index: int
    images: tuple[np.ndarray, ...]  # BGR uint8, one per camera, in rig order
    timestamps: tuple[float, ...]  # capture time per camera, seconds, one monotonic clock

    @property
    def time(self) -> float:
        """The pair's time: the mean of its cameras' capture times."""
        return float(np.mean(self.timestamps))


@dataclass(frozen=True)
class CameraStats:
    name: str
    device: str
    frames: int  # frames grabbed
    fps: float  # measured over the last two seconds
    dropped: int  # pairs with a frame of this camera the consumer skipped (it was busy)
    unpaired: int  # frames with no partner within the pairing tolerance


@dataclass(frozen=True)
class SourceStats:
    cameras: tuple[CameraStats, ...]
    pairs: int  # pairs handed to the consumer
    pairs_dropped: int  # pairs the consumer skipped because it was busy (or, replaying, was late for)
    formed: int = 0  # live cameras: pairs formed (each went to the recorder, if any)
    not_recorded: int = 0  # live cameras: pairs lost because the recorder's queue was full (disk too slow)

    def line(self) -> str:
        """One status line: frames/s per camera, pair counts, unpaired frames."""
        fps = " ".join(f"{c.name} {c.fps:4.1f} fps" for c in self.cameras)
        unpaired = "/".join(str(c.unpaired) for c in self.cameras)
        lost = f" | not recorded {self.not_recorded}" if self.not_recorded else ""
        pairs = max(self.formed, self.pairs + self.pairs_dropped)
        return f"{fps} | pairs {pairs} | skipped {self.pairs_dropped}{lost} | unpaired {unpaired}"


# --------------------------------------------------------------------------- pairing (pure logic)


class Source(Protocol):
    """Frame pairs from somewhere: iterate it, then ``close`` it (also after Ctrl-C)."""

    rig: Rig | None  # the calibration in force, when the source knows it
    fps: float  # nominal frame rate
    camera_names: tuple[str, ...]
    n_frames: int | None  # pairs it will deliver; None for live cameras

    def __iter__(self) -> Iterator[FramePair]: ...

    @property
    def stats(self) -> SourceStats: ...

    def close(self) -> None: ...
