"""Where a streak's ball was, from how much of each pixel it covered: the centroid of the change from the background.

A fast ball blurred over the exposure leaves each pixel a mix of the ball and
the room behind it, in the share of the exposure the ball covered it. The
centroid of those shares is the ball's mean position over the exposure (the
frame's time), wherever a colour range or a threshold would cut the streak's
faint ends. The cut is what moves a streak's mask centroid along it: half a
pixel to two pixels on a far ball's 10-pixel streaks, which at 12 m and 20
pixels of disparity is 0.3-1.2 m of depth when the streak runs along the
epipolar lines (fast_ball tune seeds 3, 10, 13, 15, 19: the mask centroids' disparity is off by 0.28-0.65
pixels (median), these by 0.13-0.34).

How far a pixel is from the background along the ball's colour (its
difference from the background projected on the streak's summed one) is
linear in the share the ball covered of it, for one ball colour over one
background colour; on the background's grid (motion.py, half the evidence
grid) sensor noise has a mean of zero along it, and ``NOISE`` of it is cut.
"""

from __future__ import annotations

import cv2
import numpy as np

from .blobs import Blobs
from .motion import SCALE

# The change is measured along the streak's own colour: each cell's difference from the background (three channels)
# projected on the direction of the whole window's summed difference, the ball's colour against the room. Sensor
# noise then has a mean of zero (the sum of absolute differences it had before is always positive, and cutting it at
# 12 grey levels cut a far streak's faint ends unevenly where the wall behind its two ends differs); this much of it
# is cut. Error along the streak against the truth's projection, fast_ball tune seeds 0-79 (about 4600 long streaks
# the tracker triangulated; evidence pixels, median / 90th percentile), before -> now: under 4 pixels half wide 0.165 /
# 0.667 -> 0.131 / 0.499; wider ones (the mask's centroid before) 0.296 / 0.833 -> 0.189 / 0.764. A cut at 1.5 or
# 4.5 is within 0.01 of 3 at the median; the absolute differences cut at 12 for every width, 0.184 / 0.725.
NOISE = 3.0  # grey levels along the streak's colour (the background's grid)
MARGIN = 2  # evidence pixels beyond a streak's half width that its faint ends may reach past its mask
# A centre moved more than this along the streak from its mask's is pulled by something else changing beside it (fast_ball
# tune seeds 0-19, the absolute differences' centre: such a centre was the better one only half the time); the mask's is
# kept. Along the colour it costs little (tune seeds 0-79, all 7947 streaks, projected on their own cells' summed change: 90th
# percentile 0.604 -> 0.612 px).
MOST_SHIFT = 1.5  # evidence pixels


def coverage_centres(blobs: Blobs, ids: np.ndarray, image: np.ndarray, behind: np.ndarray) -> np.ndarray:
    """Per blob (``ids`` of ``blobs``, components with labels), the centroid of the change between ``image`` and the
    background ``behind`` (BGR uint8, both on the background's grid, 1 / SCALE of the evidence grid's width and height)
    along the streak's colour, over the blob's own cells and their neighbourhood (its half width and MARGIN more),
    moved along the blob's major axis only, in evidence pixels. NaN where it is not measured (no labels, no change, or
    a centre pulled more than MOST_SHIFT from the mask's, by something else changing beside the streak): the caller
    keeps the mask's centroid there."""
    out = np.full((len(ids), 2), np.nan)
    if blobs.labels is None or blobs.label_blob is None or blobs.boxes is None or blobs.axes is None or blobs.major is None:
        return out
    ls, h, w = blobs.label_scale, image.shape[0], image.shape[1]
    for n, k in enumerate(np.asarray(ids, dtype=int)):
        if not np.isfinite(blobs.axes[k]).all():  # (a blob's moments unmeasured: none to move)
            continue
        grow = int(np.ceil((blobs.axes[k, 1] + MARGIN) / SCALE))  # cells of the background's grid
        x0, y0, x1, y1 = (int(c) * ls for c in blobs.boxes[k])  # evidence pixels, end exclusive
        gx0, gy0 = max(x0 // SCALE - grow, 0), max(y0 // SCALE - grow, 0)
        gx1, gy1 = min(-(-x1 // SCALE) + grow, w), min(-(-y1 // SCALE) + grow, h)
        if gx1 <= gx0 or gy1 <= gy0:
            continue
        # The blob's own cells on the background's grid: each cell takes the label of the evidence pixel at its centre.
        ys, xs = np.mgrid[gy0:gy1, gx0:gx1]
        ly = np.minimum((ys * SCALE + SCALE // 2) // ls, blobs.labels.shape[0] - 1)
        lx = np.minimum((xs * SCALE + SCALE // 2) // ls, blobs.labels.shape[1] - 1)
        own = blobs.label_blob[blobs.labels[ly, lx]] == k
        if not own.any():
            continue
        near = cv2.dilate(own.astype(np.uint8), np.ones((2 * grow + 1, 2 * grow + 1), np.uint8)) > 0
        change = image[gy0:gy1, gx0:gx1].astype(np.float32) - behind[gy0:gy1, gx0:gx1]
        colour = np.where(near[..., None], change, 0.0).sum(axis=(0, 1))
        size = float(np.linalg.norm(colour))
        if size == 0.0:
            continue
        weight = np.where(near, np.maximum(change @ (colour / size) - NOISE, 0.0), 0.0)
        total = weight.sum()
        if total <= 0.0:
            continue
        # A cell's centre is the mean of the SCALE x SCALE evidence pixels it averages.
        centre = SCALE * np.array([(xs * weight).sum(), (ys * weight).sum()]) / total + (SCALE - 1) / 2.0
        # Only along the streak: across it the mask's edges are the ball's sides, cut alike, while the change there
        # also holds the ball's shading against the room (1 pixel towards its dark side on 10-pixel-wide streaks:
        # fast_ball tune seed 1).
        along = float((centre - blobs.centres[k]) @ blobs.major[k])
        if abs(along) <= MOST_SHIFT:
            out[n] = blobs.centres[k] + along * blobs.major[k]
    return out
