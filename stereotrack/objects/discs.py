"""A blob that two balls share: which depth along a clean ray reproduces it.

Two balls of one colour that overlap in a camera make one blob there, the
union of two discs. A ball seen alone in another camera lies on that camera's
viewing ray; sliding it along the ray slides and scales its disc in the shared
view. The depth whose disc, together with the other balls' discs, covers the
shared blob best is a measurement of the ball's depth: the particles' mean is
pulled towards the other ball, and a track's prediction would feed its own
velocity error back into itself.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..camera import Camera
from ..evidence.blobs import Blobs
from .kernels import ball_union_mismatch, posterior_depth


def union_mismatch(cam: Camera, blobs: Blobs, blob: int, candidates: np.ndarray, others: np.ndarray, radius: float) -> np.ndarray:
    """Pixels by which each candidate ball's disc, with the other balls' discs, differs from blob ``blob``.

    ``candidates`` (T x 3) are positions of the ball being placed, ``others``
    (K x 3) the positions of the other balls that share the blob. Pixels are
    counted on the blob finder's label grid (a cell is in a disc when its
    centre is) over a window holding the blob and every disc, clipped to the
    image. Candidates behind the camera get +inf. Needs the blob finder's
    label image and boxes.
    """
    return ball_union_mismatch(
        np.ascontiguousarray(candidates, dtype=float),
        np.ascontiguousarray(others, dtype=float).reshape(-1, 3),
        radius,
        *cam._kernel_arrays,
        blobs.labels,
        blobs.label_blob,
        blob,
        blobs.boxes[blob],
        blobs.label_scale,
    )


@dataclass(frozen=True)
class RayFit:
    depth: float  # metres along the ray
    sigma: float  # metres: its standard deviation


def depth_on_ray(mismatch: np.ndarray, depths: np.ndarray, prior: float, prior_sigma: float, scale: float) -> RayFit | None:
    """The depth that reproduces the shared blob(s), from the mismatch (pixels) at each of ``depths``.

    The mismatch is read as a likelihood, exp(-mismatch / scale), times a wide
    Gaussian prior (the particles' or the track's depth): where the blob pins
    the ball down (a sharp minimum) the prior hardly matters; where it does
    not (a ball hidden behind a nearer one fits anywhere behind it) the prior
    picks the point and the spread says how little the blob knew.
    """
    if scale <= 0:
        return None
    mean, sigma = posterior_depth(
        np.asarray(mismatch, dtype=float), np.asarray(depths, dtype=float), float(prior), float(prior_sigma), float(scale)
    )
    return None if np.isnan(mean) else RayFit(mean, sigma)
