"""What a ball's blobs' shapes say of their centroids: whole, in part, smeared or a streak (explain's refine step)

explain.py asks whether a ball's blob shows it whole or in part, smeared by its motion or as a streak, and where
a streak's centre lies and how well it is known.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..evidence.blobs import minor_skew
from ..evidence.gather import CameraEvidence

CENTROID_SIGMA_PX = 0.5  # blob centroid noise of a shaded, sensor-noisy ball, pixels (sets refined objects' covariance)
STREAK_LONGER = math.log(1.2)  # a blob longer than its ball by this (log of half its larger side / the ball's radius) is a smear
ROUND_MIN_PX = 6.0  # ... judged on blobs this wide or wider (fast_ball tune seed 2: balls of 2-5 pixels fill 0.4-0.8)
ROUND_FILL = 0.7  # a blob fills at least this share of the disc its larger side spans, or it is a ball seen in part


def _whole(blob_ids: np.ndarray, blobs, log_ratio: np.ndarray) -> np.ndarray:
    """Per object and camera: its blob there fills the disc its larger side spans (ROUND_FILL), or is longer than the
    ball (a smear: a fast ball's streak, blurred). A ball cut by something in front of it, or by the image's edge,
    keeps its extent across the cut and so looks ball-sized, but its centroid lies up to half a radius off the
    ball's centre (static_props tune seed 0: a pole splits a ball in one view, 0.2 m of depth error); it is never
    longer than the ball (``log_ratio``: the blob's larger side against the ball's size at the object's depth)."""
    fill = np.ones(blob_ids.shape)
    for j, b in enumerate(blobs):
        on = blob_ids[:, j] >= 0
        ids = blob_ids[on, j]
        fill[on, j] = b.areas[ids] / (np.pi * np.maximum(b.radii[ids], 0.5) ** 2)
        fill[on, j] = np.where(b.radii[ids] >= ROUND_MIN_PX, fill[on, j], 1.0)  # a few pixels' share says nothing
    return (fill >= ROUND_FILL) | (log_ratio > STREAK_LONGER)  # (NaN: no blob, no smear)


LOPSIDED = 0.12  # a blob's skewness across its major axis from which it is a ball cut straight, not one blurred


def _blurred(whole: np.ndarray, smeared: np.ndarray, blob_ids: np.ndarray, views: Sequence[CameraEvidence], swept) -> np.ndarray:
    """Per object and camera: its blob there, not ``whole``, is a ball blurred along its path: a streak or a short blur
    (``swept``) as wide on either side of its axis (blobs.minor_skew), or any blob of a ball ``smeared`` in another
    view (a fast ball). A half disc (a ball cut by a prop or the image's edge) is as elongated and as full as a short
    blur, and at its depth no narrower than one (a fast ball's blur is thinned by the background it swept over: 0.5-0.7
    of its width in fast_ball tune seed 1, where a half disc's is 0.53), but it has a flat side and a curved one: its
    skewness across its axis is 0.15-0.4 (static_props tune seeds 0, 4, 7, 11), a short blur's 0.0-0.13 (fast_ball,
    motion_blur). A blur's centroid is its ball's (main's short-blur rule); a half disc's is not, and the partial-view
    fit reads it (fast_ball tune seed 1 fell 0.833 -> 0.625 with the fit on its short blurs)."""
    out = np.zeros(whole.shape, bool)
    fast = smeared.any(axis=1)
    for j, v in enumerate(views):
        ask = (blob_ids[:, j] >= 0) & ~whole[:, j]
        out[ask & fast, j] = True
        ask &= ~fast
        ask[ask] = swept[j][blob_ids[ask, j]]
        if ask.any():
            idx = np.flatnonzero(ask)
            out[idx, j] = minor_skew(v.blobs, v.counted if v.counted is not None else v.mask, blob_ids[idx, j]) < LOPSIDED
    return out


STREAK_EDGE_PX = 1.0  # a long streak's mask holds the pixels its edges cross in part: a band up to 2 r + this many pixels wide
STREAK_THINNING = math.log(2.0)  # a streak may be down to half its ball's width in range: ...


def _streaks_may_be_thin(log_ratio: np.ndarray, blob_ids: np.ndarray, blobs, swept: list[np.ndarray]) -> np.ndarray:
    """Size ratios of streaks (``swept``) against their width, where a streak thinner than its ball counts as the
    ball's size: a fast ball's colour is diluted by the
    background it swept over, most at the streak's edges, so the part in range is thinner than the ball.
    Its centroid is still the ball's mean position, which triangulates to a few centimetres at 7 m (fast_ball tune seed 4)
    where the particles, judging the disc's size, drift 0.15 m.

    Nor is a long streak (Blobs.swept) too wide until it is wider than the band its ball marks: 2 r pixels plus the
    pixels its two edges cross in part (STREAK_EDGE_PX), uniform across, whose moments' semi-minor axis is
    2 sqrt(r (r + 1) / 3) where a disc's is r. A far ball's streak (r = 1.45 pixels) is a band of 4 pixels, semi-minor
    2.24: 0.43 in log against its radius, beyond REFINE_TOLERANCE, so its object was placed by its particles, 0.3-1 m
    off along the ray, though its blobs lay within half a pixel of the ball in both views (fast_ball tune seed 33, 27 of
    29 frames; seeds 3, 27, 33, 35, 44 up 0.30-0.74 with the band). A short blur's cross-section is a disc's: its
    radius, r, is the most (hands tune seed 38: a short blur 1.36 times the ball's width, merged with something beside
    it, is no clean view)."""
    out = log_ratio.copy()
    for j, b in enumerate(blobs):
        if b.widths is None or not len(b):
            continue
        on = blob_ids[:, j] >= 0
        ids = blob_ids[on, j]
        streak = swept[j][ids]
        on[on] = streak
        ids = ids[streak]
        width = np.maximum(b.axes[ids, 1] if b.axes is not None else b.widths[ids], 0.5)  # (short streaks' too, blobs.short_streaks)
        ball = np.maximum(b.radii[ids], 0.5) * np.exp(-out[on, j])  # the ball's radius at the object's depth
        band = 2.0 * np.sqrt(ball * (ball + STREAK_EDGE_PX) / 3.0)  # the semi-minor axis of the widest band it marks
        band = np.where(b.swept[ids], band, ball) if b.swept is not None else ball  # (a short blur: a disc's, its radius)
        ratio = np.where(width > band, np.log(width / band), np.minimum(np.log(width / ball) + STREAK_THINNING, 0.0))
        out[on, j] = ratio
    return out


def _slack(views: list[int], ids: np.ndarray, blobs, swept: list[np.ndarray]) -> float | None:
    """A ball's streaks in its clean ``views`` (blob ``ids``): how far short of its length a streak's width falls at
    most (1 - width / length), or None when one of them is no streak."""
    if not all(swept[j][ids[j]] for j in views):
        return None
    axes = [blobs[j].axes[ids[j]] for j in views]
    return max(1.0 - max(float(b), 0.5) / max(float(a), 0.5) for a, b in axes) if all(a is not None for a in axes) else 0.0


LONG_STREAK = 0.75  # a blob whose one ball's radius (its width's) is under this share of its half length is a long streak


def _long(b, k: int) -> bool:
    """Is blob ``k`` of ``b`` a long streak (Blobs.ball_radii: its width under LONG_STREAK of its length)?"""
    return bool(b.ball_radii()[k] < LONG_STREAK * b.radii[k])


# A ball's streaks in two cameras that look at it from nearly one direction (their rays to it within PARALLEL_DEG) are
# one path seen twice, about as long in each. A streak under CUT_SHORT of such a view's lost the rest out of range (a
# faint end, a wall of its colour behind it): its centroid lies off along it by up to half what it lacks, and along the
# epipolar lines that is depth. Triangulated, it put its ball 0.37 m near claiming 0.04 m (fast_ball tune seed 428, a
# streak half as long as the other view's; the track took it and flew off). Streak triangulations of fast_ball tune
# seeds 400-459 against the truth, by how much shorter the shorter view's streak was: off by more than 0.1 m in 4 %
# where they are within 10 % of each other, 10-12 % where it is 10-40 % shorter, 19 % where 40-50 %, 36 % where more
# than half. Such a view is no clean view: the other one's ray and the particles' depth place the ball
# (explain._one_view). A near ball's views differ: seen from 2 m by cameras 1.2 m apart, its streak was 0.45-0.7 as
# long in one as in the other and triangulated to 3 cm (motion_blur tune seed 19).
CUT_SHORT = 0.6
PARALLEL_DEG = 15.0


def _cut_short(blob_ids: np.ndarray, blobs, swept: list[np.ndarray], cameras, objects) -> np.ndarray:
    """Per object (``objects``, Object3D) and camera: its blob there is a streak (``swept``) under CUT_SHORT as long
    (Blobs.axes' semi-major) as its streak in another camera whose ray to it lies within PARALLEL_DEG of this one's."""
    out = np.zeros(blob_ids.shape, bool)
    if blob_ids.shape[1] < 2 or any(b.axes is None for b in blobs) or not len(blob_ids):
        return out
    length = np.zeros(blob_ids.shape)
    for j, b in enumerate(blobs):
        on = blob_ids[:, j] >= 0
        on[on] = swept[j][blob_ids[on, j]]
        length[on, j] = b.axes[blob_ids[on, j], 0]
    if (length > 0).sum(axis=1).max() < 2:  # (most frames: no ball a streak in two views)
        return out
    positions = np.array([o.position for o in objects])
    rays = np.stack([positions - c.centre for c in cameras], axis=1)  # objects x cameras x 3
    rays /= np.maximum(np.linalg.norm(rays, axis=2, keepdims=True), 1e-12)
    parallel = np.einsum("ijk,ilk->ijl", rays, rays) >= np.cos(np.radians(PARALLEL_DEG))
    longer = parallel & (length[:, :, None] < CUT_SHORT * length[:, None, :])
    return (length > 0) & longer.any(axis=2)


STREAK_ALONG = 0.05  # a streak's centroid along it is this share of its length (beyond its width) uncertain


def _centroid_covs(b, ids: np.ndarray, streak: np.ndarray) -> np.ndarray:
    """Per blob (``ids``): its centroid's covariance (2 x 2, pixels^2). Half a pixel every way; for a streak
    (``streak``) more along it: its ends fade into the background it swept over, and how much of them stays in the
    range decides where its centroid falls along it (0.5-2.4 pixels on 10-pixel streaks at 12 m, where their
    disparity is 21 pixels: fast_ball tune seed 13), while across it the centroid keeps its half pixel."""
    covs = np.repeat((CENTROID_SIGMA_PX**2 * np.eye(2))[None], len(ids), axis=0)
    if b.axes is None or b.major is None or not streak.any():
        return covs
    k = ids[streak]
    along = STREAK_ALONG * np.maximum(b.axes[k, 0] - b.axes[k, 1], 0.0)
    u = b.major[k]
    covs[streak] += (along**2)[:, None, None] * u[:, :, None] * u[:, None, :]
    return covs


def _centres(view: CameraEvidence, ids: np.ndarray, streak: np.ndarray) -> np.ndarray:
    """The blobs' (``ids``) centroids, a long streak's (``streak`` and Blobs.swept: as wide all along, away from the
    image's edge) from its change from the background (``streak_centres``). A short blur's mask holds nearly all of
    its ball, and the change around it is more often something else's (fast_ball tune seed 1: a ball coming in)."""
    out = view.blobs.centres[ids].copy()
    if view.blobs.swept is not None:
        streak = streak & view.blobs.swept[ids]
    if streak.any():
        out[streak] = view.streak_centres(ids[streak])
    return out
