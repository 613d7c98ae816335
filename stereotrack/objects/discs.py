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

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..camera import Camera
from ..evidence.blobs import Blobs
from ..evidence.gather import CameraEvidence
from .kernels import ball_union_mismatch, partial_disc_counts, posterior_depth


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


HIDDEN_COST = 0.1  # a pixel of a partly seen ball's disc that shows open background, against one of its evidence outside it
RIM_WEIGHT = 2.0  # evidence in the rim just inside the disc's outline counts this much more for a depth
PARTIAL_RING = 1.5  # the ring outside the disc whose evidence counts against a depth, out to this many radii
PARTIAL_LEAST_SEEN = 0.25  # the best depth's disc must hold at least this share of its area in evidence ...
PARTIAL_MOST_AROUND = 0.25  # ... and its ring at most this share of the disc's area: else something else is there


def partial_mismatch(view: CameraEvidence, candidates: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per candidate position of a ball (T x 3) in a camera that sees only part of it (a thing in front of it,
    the image's edge): (mismatch in pixels, evidence outside its disc, evidence inside it).

    The evidence is the moving map (else the colour mask). Every pixel of it near the ball lies inside the
    ball's disc: evidence in the ring just outside counts against a depth and evidence inside for it, one each;
    a pixel inside the disc without it may be hidden, and counts ``HIDDEN_COST`` against, unless it has the
    ball's colour (a static prop of that colour in front of the ball: not moving, and not against the ball).
    Whatever hides part of the ball looks like open background, so several discs hold the visible parts; of
    them the ball's has their curved edge on its outline: evidence in its rim counts ``RIM_WEIGHT`` more.
    The disc that holds all of the ball's visible parts and little open background is at the ball's depth; the
    ball-shape likelihood instead favours a smaller disc on the largest visible part, whose centre is off the
    ball's by up to half its radius.
    """
    seen = view.moving if view.moving is not None else view.mask
    maybe = view.mask if view.moving is not None else np.zeros_like(view.mask)
    counts = partial_disc_counts(
        np.ascontiguousarray(candidates, dtype=float), radius, *view.camera._kernel_arrays, seen, maybe, PARTIAL_RING
    )
    return counts[:, 0] - counts[:, 2] - RIM_WEIGHT * counts[:, 3] + HIDDEN_COST * counts[:, 1], counts[:, 0], counts[:, 2]


# Two points along a viewing ray whose discs lie this share of the ball's apparent radius apart in every view are one ball
# seen at two depths (explain._agree; tune seeds, summed MOTA: fast_ball 0-79 +0.67, none worse; hue_wall, white_ball,
# static_props, hands within 0.1, lighting 0-39 unchanged). A near ball's particles 3.5 radii off at 1.9 m are 0.52 of its
# radius off (tests/objects/test_explain.py: lighting tune seed 6's case, where the particles were right).
SAME_DISC = 0.5


def same_disc(point: np.ndarray, particles: np.ndarray, cameras: Sequence, radius: float) -> bool:
    """Do the triangulated centroids (``point``) and the particles' mean fall within SAME_DISC of the ball's apparent
    radius (``radius`` metres, at ``point``) of each other in every one of ``cameras`` (the views they were triangulated
    from): one ball's disc, at two depths? None of ``cameras``: no."""
    if not cameras:
        return False
    for cam in cameras:
        uv, front, depth = cam.view(np.array([point, particles]))
        if not front.all() or np.linalg.norm(uv[0] - uv[1]) > SAME_DISC * cam.apparent_radius(radius, depth[0]):
            return False
    return True
