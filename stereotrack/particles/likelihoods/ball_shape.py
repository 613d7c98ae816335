"""Does it look like a ball of this size here? A centre-surround likelihood: ``tracker.likelihood: ball_shape``.

At a particle's depth z the ball of radius R spans r = f R / z pixels in
each camera. A ball there fills the core of that disc with target evidence
and leaves the ring around it empty; a wall or a poster of the ball's colour
fills both, a speck fills neither, a ball at a wrong depth fits one of them
only. Per camera the factor is

    fill(core of the disc) x (1 - fill(ring around the disc)),

in O(1) from the summed-area table of the colour mask, and of the moving
part of it (evidence/motion.py): a ball moving in front of a wall of its
own colour is a ball in the moving map (and on a streak of the mask, a
ball swept along it; on a still streak about the ball's width, a rod's
end, the colour does not count). The best of the two counts,
floored (no probability wells) and multiplied over cameras; a camera whose
view a ball of another colour blocks says nothing. Boxes stand in for
discs: the core is the square inside the disc, the ring lies between
squares of ``mid`` and ``outer`` radii.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ...config import Target, TrackerSettings
from ...evidence.blobs import streaks
from ...evidence.gather import CameraEvidence
from ...results import TrackedBalls
from ..kernels import ball_shape_likelihood

CORE = 0.7  # half-side of the core square, in ball radii (the square inside the disc)
MID = 1.2  # the ring starts beyond this half-side, in ball radii (clear of the disc's edge and its blur)
OUTER = 1.8  # ... and ends here


class Model:
    def __init__(self, radius: float, floor: float, occlusion: bool = True):
        self.radius = radius  # the ball's radius, metres
        self.floor = floor  # the least factor a camera gives
        self.occlusion = occlusion

    @classmethod
    def from_settings(cls, settings: TrackerSettings, target: Target) -> Model:
        return cls(target.radius, 1.0 / settings.window**2, settings.occlusion)

    def __call__(self, positions: np.ndarray, views: Sequence[CameraEvidence], occluders: TrackedBalls | None) -> np.ndarray:
        positions = np.ascontiguousarray(positions, dtype=float).reshape(-1, 3)
        if self.occlusion and occluders is not None and len(occluders):
            centres, radii = np.ascontiguousarray(occluders.centres, dtype=float), np.ascontiguousarray(occluders.radii, dtype=float)
        else:
            centres, radii = np.zeros((0, 3)), np.zeros(0)
        out = np.ones(len(positions))
        for v in views:
            moving = v.moving_integral is not None
            colour, scale = (v.soft_integral, 255.0) if v.soft_integral is not None else (v.integral, 1.0)
            ball_shape_likelihood(
                out, positions, *v.camera._kernel_arrays, colour, scale, v.moving_integral if moving else v.integral, moving,
                self.radius, CORE, MID, OUTER, self.floor, v.camera.centre, centres, radii, *_streaks(v),
            )  # fmt: skip
        return out


BallShape = Model

_NO_LABELS, _NO_BLOBS = np.zeros((1, 1), np.int32), np.zeros(1, np.int64)


def _streaks(view: CameraEvidence) -> tuple:
    """The kernel's view of a camera's streaks: label image, label -> blob, its scale, and per blob whether it is a
    streak, the half width of a still one (gather.still_streaks; 0: it moves), its direction and its area (empty when
    the blob finder gives no labels or there is no streak)."""
    blobs = view.blobs
    none = _NO_LABELS, _NO_BLOBS, 1, np.zeros(0, np.bool_), np.zeros(0), np.zeros((0, 2)), np.zeros(0)
    if blobs.labels is None or blobs.major is None or not len(blobs):
        return none
    is_streak = blobs.swept if blobs.swept is not None else streaks(blobs.areas, blobs.axes)  # as the blob finder judged it
    if not is_streak.any():
        return none
    still_width = np.where(view.still, blobs.axes[:, 1], 0.0) if view.still is not None else np.zeros(len(blobs))
    return blobs.labels, blobs.label_blob, blobs.label_scale, is_streak, still_width, blobs.major, blobs.areas.astype(float)
