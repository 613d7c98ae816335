"""Target colours: HSV masks, integral images, and learning a range from a region.

Masks are computed once per frame per camera per target; the likelihood then
counts mask pixels in any window in O(1) from the integral image.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import cv2
import numpy as np

from ..config import Target
from ..errors import StereotrackError
from .kernels import range_mask


def to_hsv(image_bgr: np.ndarray) -> np.ndarray:
    """BGR uint8 image -> OpenCV HSV (H 0..179)."""
    return cv2.cvtColor(image_bgr, cv2.COLOR_BGR2HSV)


def target_mask(hsv: np.ndarray, target: Target) -> np.ndarray:
    """Binary mask (uint8 0/1) of the pixels inside the target's HSV range; hue may wrap."""
    lo = np.array(target.hsv_min, dtype=np.uint8)
    hi = np.array(target.hsv_max, dtype=np.uint8)
    if not target.wraps:
        mask = cv2.inRange(hsv, lo, hi)
    else:  # reds: [h_min, 179] or [0, h_max]
        a = cv2.inRange(hsv, lo, np.array([179, hi[1], hi[2]], dtype=np.uint8))
        b = cv2.inRange(hsv, np.array([0, lo[1], lo[2]], dtype=np.uint8), hi)
        mask = cv2.bitwise_or(a, b)
    # inRange gives 0/255; 0/1 makes the integral image a pixel count.
    return cv2.threshold(mask, 0, 1, cv2.THRESH_BINARY)[1]


def integral_image(mask: np.ndarray) -> np.ndarray:
    """Summed-area table, (H+1) x (W+1) int32, of a 0/1 mask."""
    return cv2.integral(mask, sdepth=cv2.CV_32S)


def box_counts(table: np.ndarray, x0, y0, x1, y1):
    """The map's sum over each box [x0, x1) x [y0, y1) (pixels; scalars or arrays, cut to the map's size, taken
    towards zero), from its summed-area table ``table``: O(1) a box."""
    h, w = table.shape[0] - 1, table.shape[1] - 1
    x0, x1 = (np.clip(np.asarray(c), 0, w).astype(int) for c in (x0, x1))
    y0, y1 = (np.clip(np.asarray(c), 0, h).astype(int) for c in (y0, y1))
    return table[y1, x1] - table[y0, x1] - table[y1, x0] + table[y0, x0]


@dataclass(frozen=True, eq=False)
class CameraMasks:
    """One camera's masks for every target this frame."""

    camera: str
    masks: dict[str, np.ndarray]  # target name -> uint8 0/1 mask
    integrals: dict[str, np.ndarray]  # target name -> (H+1) x (W+1) int32 (empty when not asked for)
    hsv: np.ndarray | None = None  # the frame in HSV, for colour models and the moving maps' own ranges (motion_range, streak_range)


def camera_masks(camera: str, image_bgr: np.ndarray, targets: tuple[Target, ...], integrals: bool = True) -> CameraMasks:
    """HSV conversion once, then one mask and (unless ``integrals`` is False) one integral image per target. The
    moving maps' ranges (``motion_range``, ``streak_range``) are read from the HSV only where something moves
    (evidence/gather.py): a whole-image mask of each cost as much as the range's own. The masks are target_mask's, made
    in one compiled pass each (kernels.range_mask: OpenCV's inRange and threshold took 9 times as long)."""
    hsv = to_hsv(image_bgr)
    masks = {t.name: range_mask(hsv, range_bounds(t)) for t in targets}
    return CameraMasks(camera, masks, {name: integral_image(m) for name, m in masks.items()} if integrals else {}, hsv)


@lru_cache(maxsize=64)
def range_bounds(target: Target) -> np.ndarray:
    """The target's range as the compiled passes read it (evidence/kernels.py): h0, s0, v0, h1, s1, v1, and 1
    where the hue wraps around red (one array per range, made once: not to be written)."""
    return np.array([*target.hsv_min, *target.hsv_max, int(target.wraps)], np.int64)


def motion_range(target: Target) -> Target:
    """Where a moving ball's pixels may lie: its range, but any darker for a ball of every hue. A white or grey
    ball's shaded side is grey, below the value a user types for it (its lit side); its hue says nothing, so
    only saturation tells it from a coloured thing (skin, a shirt) moving too."""
    if not target.any_hue:
        return target
    return Target(target.name, (0, target.hsv_min[1], 0), (179, target.hsv_max[1], target.hsv_max[2]), target.radius)


STREAK_SATURATION = 0.4  # a streak's saturation may fall to this share of the typed minimum ...
STREAK_HUE = 10  # ... and its hue this far out of the typed range


def streak_range(target: Target) -> Target:
    """Where a fast ball's streak's pixels may lie: a pixel it sweeps over sees the ball only part of the exposure,
    so its colour is the ball's mixed with the background's, paler and of a hue pulled towards the room's (fast_ball
    tune seeds: saturation 34-71 against a typed minimum of 74-83, hue up to 5 outside the range). Only moving
    pixels, in blobs shaped like a streak, may take it (CameraEvidence.from_mask): a pale thing of the hue is none."""
    (h0, s0, v0), (h1, s1, v1) = target.hsv_min, target.hsv_max
    span = (h1 - h0) % 180 + 2 * STREAK_HUE
    lo, hi = (0, 179) if span >= 179 else ((h0 - STREAK_HUE) % 180, (h1 + STREAK_HUE) % 180)
    return Target(target.name, (lo, int(STREAK_SATURATION * s0), int(0.5 * v0)), (hi, s1, v1), target.radius)


# --------------------------------------------------------------------------- learning


@dataclass(frozen=True)
class LearnedRange:
    target: Target
    roi_coverage: float  # share of the region's pixels inside the learned range
    background_coverage: float  # share of the pixels outside the region inside the range


def _hue_interval(h: np.ndarray, lo_pct: float, hi_pct: float) -> tuple[int, int]:
    """Percentile interval of hues on the 180-step circle, cut at the emptiest hue."""
    hist = np.bincount(h.ravel(), minlength=180)
    cut = int(np.argmin(np.convolve(np.r_[hist[-7:], hist, hist[:7]], np.ones(15), "valid")[:180]))
    shifted = (h.astype(int) - cut) % 180
    a, b = np.percentile(shifted, [lo_pct, hi_pct])
    return int((np.floor(a) + cut) % 180), int((np.ceil(b) + cut) % 180)


def saturated_threshold(saturation: np.ndarray) -> float:
    """The saturation that splits a region into ball and background: Otsu's threshold (a coloured ball on a grey
    background is the saturated mode), at least 40 (greys are never the ball's colour)."""
    thr, _ = cv2.threshold(np.ascontiguousarray(saturation, np.uint8).reshape(-1, 1), 0, 255, cv2.THRESH_BINARY + cv2.THRESH_OTSU)
    return max(float(thr), 40.0)


def range_of(
    pixels: np.ndarray,
    name: str,
    radius: float = Target.radius,
    margin: tuple[int, int, int] = (4, 25, 25),
    percentiles: tuple[float, float] = (2.0, 98.0),
) -> Target:
    """A target whose HSV range holds a ball's pixels (N x 3 HSV): robust percentiles per channel (hue on the
    circle, so a red ball gives a wrapping range), widened by ``margin``."""
    h_lo, h_hi = _hue_interval(pixels[:, 0], *percentiles)
    s_lo, s_hi = np.percentile(pixels[:, 1], percentiles)
    v_lo, v_hi = np.percentile(pixels[:, 2], percentiles)
    h_lo, h_hi = (h_lo - margin[0]) % 180, (h_hi + margin[0]) % 180
    lo = (int(h_lo), int(max(0, s_lo - margin[1])), int(max(0, v_lo - margin[2])))
    hi = (int(h_hi), int(min(255, s_hi + margin[1])), int(min(255, v_hi + margin[2])))
    return Target(name=name, hsv_min=lo, hsv_max=hi, radius=radius)


def learn_target(
    image_bgr: np.ndarray,
    roi: tuple[int, int, int, int],
    name: str,
    radius: float = Target.radius,
    margin: tuple[int, int, int] = (4, 25, 25),
    percentiles: tuple[float, float] = (2.0, 98.0),
) -> LearnedRange:
    """Learn an HSV range from the pixels of ``roi`` (x, y, w, h) that look like the ball. (``colour learn`` uses
    learn.py; this stays a public name of 0.1, ``stereotrack.colour.learn_target``, for users' scripts.)

    Keeps the saturated pixels of the region (the ball, not the background
    around it), takes robust percentiles per channel (hue on the circle, so a
    red ball gives a wrapping range) and widens them by ``margin``.
    """
    x, y, w, h = roi
    H, W = image_bgr.shape[:2]
    if w <= 0 or h <= 0 or x < 0 or y < 0 or x + w > W or y + h > H:
        raise StereotrackError(f"--roi {x},{y},{w},{h} is not inside the {W}x{H} image")
    hsv = to_hsv(image_bgr)
    patch = hsv[y : y + h, x : x + w].reshape(-1, 3)
    ball = patch[patch[:, 1] > saturated_threshold(patch[:, 1])]
    if len(ball) < 10:
        raise StereotrackError(f"--roi {x},{y},{w},{h}: too few coloured pixels in the region (draw the box tightly around the ball)")
    target = range_of(ball, name, radius, margin, percentiles)
    mask = target_mask(hsv, target)
    inside = np.zeros(mask.shape, bool)
    inside[y : y + h, x : x + w] = True
    roi_cov = float(mask[inside].mean())
    bg_cov = float(mask[~inside].mean()) if (~inside).any() else 0.0
    return LearnedRange(target, roi_cov, bg_cov)
