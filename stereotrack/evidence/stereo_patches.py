"""A white or grey ball at rest that is not alone in a view, kept where another camera shows it too.

motion.shading finds such a ball by its shading, and asks its patch to stand
alone on something flat: a shelf's books, a poster's shapes and a plant's
leaves are among other edges. A ball at rest in front of a plant or a table's
leg is among other edges too, in one view or both, and was never found
(white_ball tune seeds 0-279: of 14 balls never found, 8 failed only that
test in a view). Its patch passes every other test there (round, a ball's
width, shaded, a rim turning all the way round). Such a patch is kept where
another camera shows a patch that is the same ball: the two lie on each
other's epipolar lines, at a depth in range, and each is as wide as the ball
is there. A crowded patch with no partner stays out, as before. Two views
agree on any real thing, so a pair must also stand clear of what it is seen
on (objects/surface.py): a pale piece of a poster between books did not
(white_ball tune seed 51: a false ball for the whole scene).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import cv2
import numpy as np

from ..camera import Camera, triangulate_points

# How far apart a pair may lie across the epipolar line (pixels of the evidence grid): one cell of the background's
# grid, plus this share of the patch's radius (a patch cut by what it stands in front of is off centre). The point the
# pair triangulates to splits that between the views: each may be half as far from it.
PAIR_CELLS = 1.0
PAIR_RADII = 0.3
# A patch's radius may be this many times off the ball's at the pair's depth, either way: on the background's grid a
# ball spans a few cells, its patch's radius is known to a cell.
SIZE_RATIO = 1.6


def patch_discs(patches: np.ndarray, scale: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The patches of a map (uint8 0/1 on a grid ``scale`` times coarser than the evidence's): their labels, and per
    patch (label - 1) its centroid and the radius of a disc of its area, both in pixels of the evidence grid."""
    n, labels, stats, centroids = cv2.connectedComponentsWithStats(patches, connectivity=8)
    centres = scale * centroids[1:] + 0.5 * (scale - 1)  # a cell is the mean of scale x scale pixels
    return labels, centres.reshape(-1, 2), scale * np.sqrt(stats[1:, cv2.CC_STAT_AREA] / np.pi)


def paired(
    crowded: Sequence[np.ndarray],
    alone: Sequence[np.ndarray],
    cameras: Sequence[Camera],
    radius: float,
    d_min: float,
    d_max: float,
    scale: int,
    scenery: Callable[[np.ndarray], bool] | None = None,
) -> list[np.ndarray]:
    """Per camera, its ``crowded`` patches (uint8 0/1 on the background's grid, ``scale`` evidence pixels a cell) that
    another camera shows as the same ball, crowded there too or ``alone`` (kept already): epipolar, in depth range
    (``d_min`` .. ``d_max`` metres) and as wide as a ball of ``radius`` metres at that depth in both views, and not
    ``scenery`` (a point, 3: is a thing there a patch of the surface it is seen on?). ``cameras`` read the evidence
    grid."""
    found = [patch_discs(c, scale) for c in crowded]
    others = [patch_discs(a, scale) for a in alone]
    kept = [np.zeros(len(f[1]), bool) for f in found]
    for i in range(len(cameras)):
        for j in range(i + 1, len(cameras)):
            if not (len(found[i][1]) or len(found[j][1])):
                continue
            # Every pair of a patch of camera i and one of camera j, crowded or alone, one of them crowded at least
            ci, ri, ki = _both(found[i], others[i])
            cj, rj, kj = _both(found[j], others[j])
            a, b = np.meshgrid(np.arange(len(ci)), np.arange(len(cj)), indexing="ij")
            a, b = a.ravel(), b.ravel()
            some = (ki[a] >= 0) | (kj[b] >= 0)
            a, b = a[some], b[some]
            if not len(a):
                continue
            ok, points = same_ball(cameras[i], cameras[j], ci[a], ri[a], cj[b], rj[b], radius, d_min, d_max, PAIR_CELLS * scale)
            if scenery is not None:
                for k in np.flatnonzero(ok):
                    ok[k] = not scenery(points[k])
            kept[i][ki[a[ok & (ki[a] >= 0)]]] = True
            kept[j][kj[b[ok & (kj[b] >= 0)]]] = True
    return [np.isin(f[0], np.flatnonzero(k) + 1).astype(np.uint8) for f, k in zip(found, kept)]


def same_ball(cam_i, cam_j, ci, ri, cj, rj, radius: float, d_min: float, d_max: float, slack: float) -> tuple[np.ndarray, np.ndarray]:
    """Per pair of discs (centres ``ci`` in ``cam_i``, ``cj`` in ``cam_j``, K x 2 pixels; radii ``ri``, ``rj``), whether
    they are one ball of ``radius`` metres: the point they triangulate to is in front of both cameras, ``d_min`` ..
    ``d_max`` metres deep and within half of ``slack`` plus PAIR_RADII of each disc's radius of its centre, and each disc
    is as wide as the ball there (SIZE_RATIO); and those points (K x 3)."""
    points = triangulate_points([cam_i, cam_j], [ci, cj])
    ok = np.ones(len(points), bool)
    for cam, centres, radii in ((cam_i, ci, ri), (cam_j, cj, rj)):
        uv, front, depth = cam.view(points)
        off = np.linalg.norm(uv - centres, axis=1)
        expected = cam.apparent_radius(radius, depth)
        ok &= front & (depth >= d_min) & (depth <= d_max) & (off <= 0.5 * (slack + PAIR_RADII * radii))
        ok &= (radii <= SIZE_RATIO * expected) & (expected <= SIZE_RATIO * radii)
    return ok, points


def _both(crowded: tuple, alone: tuple) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A camera's crowded and alone patches together: centres, radii, and per patch its crowded index (-1: alone)."""
    n = len(crowded[1])
    index = np.r_[np.arange(n), np.full(len(alone[1]), -1)]
    return np.vstack([crowded[1], alone[1]]), np.r_[crowded[2], alone[2]], index
