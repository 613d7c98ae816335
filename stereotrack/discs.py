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

from .abduction import Blobs
from .camera import Camera


def union_mismatch(cam: Camera, blobs: Blobs, blob: int, candidates: np.ndarray, others: np.ndarray, radius: float) -> np.ndarray:
    """Pixels by which each candidate ball's disc, with the other balls' discs, differs from blob ``blob``.

    ``candidates`` (T x 3) are positions of the ball being placed, ``others``
    (K x 3) the positions of the other balls that share the blob. Pixels are
    counted on the blob finder's label grid (a cell is in a disc when its
    centre is) over a window holding the blob and every disc, clipped to the
    image. Candidates behind the camera get +inf. Needs the blob finder's
    label image and boxes.
    """
    points = np.vstack([candidates, others])
    uv, front = cam.project(points)
    r = 0.5 * (cam.K[0, 0] + cam.K[1, 1]) * radius / np.where(front, cam.depth(points), 1.0)
    n = len(candidates)
    out = np.full(n, np.inf)
    t = np.flatnonzero(front[:n])
    if not len(t):
        return out
    k = n + np.flatnonzero(front[n:])
    s = blobs.label_scale
    off = 0.5 * (s - 1)  # label cell x has its centre at pixel x * s + off
    h, w = blobs.labels.shape
    seen = np.r_[t, k]
    bx0, by0, bx1, by1 = blobs.boxes[blob]
    x0 = max(0, min(bx0, int(np.floor(((uv[seen, 0] - r[seen]).min() - off) / s)))) 
    y0 = max(0, min(by0, int(np.floor(((uv[seen, 1] - r[seen]).min() - off) / s))))
    x1 = min(w, max(bx1, int(np.ceil(((uv[seen, 0] + r[seen]).max() - off) / s)) + 1))
    y1 = min(h, max(by1, int(np.ceil(((uv[seen, 1] + r[seen]).max() - off) / s)) + 1))
    blob_mask = blobs.label_blob[blobs.labels[y0:y1, x0:x1]] == blob
    gx = np.arange(x0, x1) * s + off
    gy = np.arange(y0, y1) * s + off
    covered = np.zeros(blob_mask.shape, bool)  # by the other balls' discs
    for i in k:  # a handful of balls
        covered |= (gx[None, :] - uv[i, 0]) ** 2 + (gy[:, None] - uv[i, 1]) ** 2 <= r[i] ** 2
    # xor(disc | covered, blob) = xor(covered, blob) + sum over the disc of g, g = 0 where covered,
    # -1 on the blob, +1 off it. Sums of g over a disc come row by row from running sums.
    g = np.where(covered, 0, np.where(blob_mask, -1, 1))
    run = np.zeros((g.shape[0], g.shape[1] + 1), np.int64)
    np.cumsum(g, axis=1, out=run[:, 1:])
    dy = gy[None, :] - uv[t, 1, None]  # T x rows
    half = np.sqrt(np.maximum(r[t, None] ** 2 - dy**2, 0.0))
    inside = r[t, None] ** 2 - dy**2 >= 0
    lo = np.clip(np.ceil((uv[t, 0, None] - half - off) / s).astype(int) - x0, 0, g.shape[1])
    hi = np.clip(np.floor((uv[t, 0, None] + half - off) / s).astype(int) + 1 - x0, 0, g.shape[1])
    hi = np.maximum(hi, lo)
    rows = np.arange(g.shape[0])[None, :]
    disc_sum = np.where(inside, run[rows, hi] - run[rows, lo], 0).sum(axis=1)
    out[t] = (np.count_nonzero(covered != blob_mask) + disc_sum) * float(s * s)
    return out


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
    ok = np.isfinite(mismatch)
    if not ok.any() or scale <= 0:
        return None
    t, m = depths[ok], mismatch[ok]
    logw = -(m - m.min()) / scale - 0.5 * ((t - prior) / max(prior_sigma, 1e-6)) ** 2
    w = np.exp(logw - logw.max())
    mean = float((w * t).sum() / w.sum())
    return RayFit(mean, float(np.sqrt((w * (t - mean) ** 2).sum() / w.sum())))
