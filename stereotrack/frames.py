"""What sources deliver: one synchronised frame pair (an image per camera, with capture times)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


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
