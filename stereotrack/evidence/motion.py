"""Motion: a background model per camera, so scenery of a ball's colour that never moves stops looking like a ball.

The background is a running average of the frames, kept at half resolution
(sensor noise averages out and it costs a quarter), and updated everywhere
except under the discs of the balls the tracks predict: a ball that comes to
rest (in a hand, on a table, at a pendulum's turning point) is never learnt
into the background and stays foreground. A pixel is foreground when it
differs from the background by more than ``threshold`` grey levels, summed
over its three channels. The first frame starts the background, so nothing is foreground in
it: motion adds evidence (a ball moving in front of a wall of its own
colour), it never takes colour evidence away.

The first frame holds the balls too: where one was, the background is the
ball until learnt away, and once it has moved on, a wall of its colour there
differs from it: a "ghost" ball in the moving map. A track that forms on the
ghost keeps it out of the update, and the ghost lasts for ever. So the
background starts as the mean of the frames seen so far (rate 1 / (n + 1) at
the n-th frame, down to ``rate``; OpenCV's MOG2 starts the same way): a
ball's first position fades within a few frames, before a track confirms.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import cv2
import numpy as np

from ..camera import Camera
from ..config import Target
from ..results import TrackedBalls
from .kernels import absorb_still_patches, background_step, frame_gain, straight_runs

SCALE = 2  # the background is kept at 1 / SCALE of the image's width and height
KEEP_OUT_MARGIN = 1.5  # the discs kept out of the background update, in ball radii (a ball moves between frames)
ABSORB_FRAMES = 5  # a moving patch none of whose cells changed for this many frames, under no travelled ball, is background at once
MIN_GHOST_CELLS = 2  # fewer calm moving cells than this (a speck of noise) are left to the running average
GAIN_STEP = 8  # the lighting's gain is measured on every GAIN_STEP-th background cell in each direction
# A fast ball's streak sees the ball a fraction of the exposure: far and thin, it differs from the wall behind by
# 15-25 grey levels (three channels, this grid) where the threshold asks 30 (fast_ball tune seeds 14, 17: no moving
# pixel for whole throws), and sensor noise by under 10 (99.9th percentile). The ``faint`` map of changes above this
# share of the threshold is read only for streak-shaped blobs of a streak's colour (evidence/gather.py).
FAINT_SHARE = 0.4

# A white or grey ball's kept-out disc (a target of every hue: its colour is the wall's) must show something in this
# frame: a ball's shading and rim give its disc a mean gradient of 4-20 grey levels per pixel (on the background's
# grid); the flat wall a ghost is made of, under 1. white_ball tune seeds 0-19: the predicted discs of tracks within
# 12 cm of a ball fell under 2 in 12 frames of 1368 (all on a track running off a fast ball), those 30 cm or more from
# every ball in 130 of 172.
STRUCTURE_MIN = 2.0


def structure(image: np.ndarray, u: float, v: float, r: float) -> float:
    """The mean gradient magnitude (grey levels per pixel, Sobel) of ``image`` (BGR, uint8 or float32) over the disc
    of radius 1.3 ``r`` around (u, v): how much a disc there shows. A ball has shading and a rim, a flat wall none."""
    h, w = image.shape[:2]
    grow = int(np.ceil(1.3 * r)) + 2
    x0, x1, y0, y1 = max(int(u) - grow, 0), min(int(u) + grow + 1, w), max(int(v) - grow, 0), min(int(v) + grow + 1, h)
    if x1 - x0 < 3 or y1 - y0 < 3:
        return 0.0
    ys, xs = np.mgrid[y0:y1, x0:x1]
    disc = np.hypot(xs - u, ys - v) <= 1.3 * r + 0.5
    if not disc.any():  # a disc just off the image's edge: nothing of it shows
        return 0.0
    gx, gy = _sobel(image[y0:y1, x0:x1].astype(np.float32).mean(axis=2))
    return float(np.hypot(gx[disc], gy[disc]).mean())


def _sobel(grey: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The horizontal and vertical gradients of ``grey`` (float32), in grey levels per pixel (3 x 3 Sobel)."""
    return cv2.Sobel(grey, cv2.CV_32F, 1, 0, ksize=3) / 8.0, cv2.Sobel(grey, cv2.CV_32F, 0, 1, ksize=3) / 8.0


# A white or grey ball at rest in a white room has neither a colour of its own nor motion: what shows it is its shading
# and its rim, gradient that a flat wall lacks. On the background's grid (halved, 3x3 Gaussian), a ball's disc holds
# gradients of 3-20 grey levels per pixel, a painted wall's texture under 2 and a floor's mostly under 2.5.
SHADING_MIN = 2.5
SHADING_VALUE = 0.75  # ... among pixels at least this share of the range's least value (a black plant's leaves are no white ball)
SHADING_ASPECT = 1.5  # a patch of the map counts when its box is at most this elongated ...
SHADING_FILL = 0.6  # ... and it fills this share of the ellipse in its box
SHADING_MIN_RADIUS = 2.5  # pixels of the background's grid: a smaller patch is a speck of texture, a switch or a knob far off
SHADING_EDGED = 0.7  # share of a patch that must show gradient itself (the rest: filled holes)
# ... and of a disc cut out of a patch joined to something (_inner_discs): a ball's shading fills its disc (white_ball
# tune seeds 31, 49, 74: 0.97-1.00), where a disc inside a small box or a thing's filled outline shows less (seed 70: 0.86, 0.88)
SHADING_EDGED_DRAWN = 0.95
SHADING_SQUARE = 0.9  # a patch filling more of its box is square
SHADING_BUSY = 0.25  # at most this share of the ring around a patch shows gradient
# ... and around a disc cut out of a patch joined to something: what it is joined to lies in its ring (a ball against a
# picture's frame, white_ball tune seed 49: 0.26-0.30), and its shading is asked more of (SHADING_EDGED_DRAWN)
SHADING_BUSY_DRAWN = 0.4
SHADING_CONTRAST = (
    40.0  # grey levels at least between a patch's brightest and darkest pixels (white_ball tune seeds: balls 66-115, decals 5-17)
)
# A grey ball's shading spans less than a white one's: its lit and its shaded side are both its albedo's share of the
# light. The contrast asked is SHADING_CONTRAST_SHARE of the range's least value (the ball's shaded side), within
# SHADING_CONTRAST_LEAST .. SHADING_CONTRAST (white_ball tune 0-119, patches passing every other test at frames 10, 45,
# 80: still balls 32-37 at least value 100 (seed 65, a grey ball never found), others at most 34, at least value 132
# (a door's knob, seed 47))
SHADING_CONTRAST_SHARE = 0.3
SHADING_CONTRAST_LEAST = 30.0
SHADING_HOLE = 0.6  # a hole in the map (a ball's flat, lit centre) is filled when smaller than a disc of this many ball radii
# A ball at rest against the room's long edges (wall and ceiling, wall and floor, a table's front) joins them in the
# map, and the joined patch spans the image. The edges are straight: their gradient keeps one direction along their
# length, where a ball's rim turns. Within one window of SHADING_TURN radians of gradient direction a rim's arc spans
# 2 sin(SHADING_TURN / 2) = 0.77 of its radius; a run of edge pixels as long as SHADING_STRAIGHT of the nearest ball's
# radii is a straight edge of the room, taken off the map (and off the ring a patch must be alone in) before the
# patches are labelled.
SHADING_TURN = np.pi / 4
SHADING_STRAIGHT = 2.0
SHADING_WAYS = 8  # a patch must hold gradient pointing in each of this many directions (white_ball tune 0-59: 504 of 507 balls' patches do, 39 of 279 others)
SHADING_DISC = 0.85  # a patch cut off a straight edge fills this share of its box's ellipse and lies this share or more inside it


def shading(image: np.ndarray, target, near_px: float, far_px: float, crowded: bool = False) -> np.ndarray | tuple:
    """Where a white or grey ball (``target`` of every hue) shows by its shading alone: the pixels of ``image``
    (BGR uint8 on the background's grid) whose brightness changes by SHADING_MIN grey levels per pixel or more and
    whose colour could be the ball's (saturation at most the range's top, value at least SHADING_VALUE of its bottom),
    with the holes smaller than a disc of SHADING_HOLE x ``near_px`` filled (a ball's lit centre is flat), kept in
    the patches round like a ball and as wide as one between ``far_px`` and ``near_px`` radii (the ball's apparent
    radius on this grid at the farthest and nearest depths). A wall's edges, a shelf's books and a floor's texture are
    lines, networks and specks; a flat wall is empty. The room's straight edges are taken off first (a ball at rest
    against one would join it), and a patch must hold gradient pointing every way, as a ball's rim does. A patch too
    wide or not round may be a ball joined to something (a leg, a bin, another ball): the largest discs inside it are
    tested again on their own. uint8 0/1; with ``crowded``, also the patches that pass every test but being alone
    (a ball in front of a plant, a table's leg: stereo_patches.paired keeps those another camera shows too)."""
    grey = cv2.GaussianBlur(cv2.cvtColor(image, cv2.COLOR_BGR2GRAY), (3, 3), 0).astype(np.float32)
    gx = cv2.Sobel(grey, cv2.CV_32F, 1, 0, ksize=3)
    gy = cv2.Sobel(grey, cv2.CV_32F, 0, 1, ksize=3)
    edges = cv2.threshold(cv2.magnitude(gx, gy), 8.0 * SHADING_MIN, 1, cv2.THRESH_BINARY)[1].astype(np.uint8)  # Sobel weighs a step 8 times
    low = int(np.ceil(SHADING_VALUE * target.hsv_min[2]))
    pale = cv2.inRange(cv2.cvtColor(image, cv2.COLOR_BGR2HSV), (0, 0, low), (255, target.hsv_max[1], 255))  # 0 / 255
    direction = cv2.phase(gx, gy)  # of the gradient, radians 0 .. 2 pi
    straight = _straight(edges, direction, SHADING_STRAIGHT * near_px)
    edges[straight] = 0
    out = cv2.bitwise_and(edges, edges, mask=pale)
    shaded = out.copy()  # before the holes are filled
    h, w = out.shape
    n, labels, stats, _ = cv2.connectedComponentsWithStats(1 - out, connectivity=4)  # the holes (label 0: the map itself)
    x, y, bw, bh, area = stats.T
    fill = (area <= np.pi * (SHADING_HOLE * near_px) ** 2) & (x > 0) & (y > 0) & (x + bw < w) & (y + bh < h)
    fill[0] = False
    if fill.any():
        out[fill[labels]] = 1
    contrast = min(max(SHADING_CONTRAST_SHARE * target.hsv_min[2], SHADING_CONTRAST_LEAST), SHADING_CONTRAST)
    balls, busy, joined = _ball_patches(out, shaded, edges, grey, direction, straight, near_px, far_px, contrast=contrast)
    # The gradient of the ball's rim spreads a pixel beyond it (the blur, Sobel's 3 x 3): a disc that much wider
    # would put the ball nearer than it is.
    balls, busy = cv2.erode(balls, _CROSS), cv2.erode(busy, _CROSS)
    # A ball at rest touching something of the map that is not straight (a table's leg, a bin, another ball) joins it
    # in a patch too wide or not round. The largest discs inside such patches (their distance transform's peaks), a
    # pixel inside them (that spread), are looked at again as patches of their own: a ball's is its own disc, an
    # edge's a few pixels wide.
    # A disc cut out of a joined patch is placed to a cell, its patch's whole outline is not: crowded, it is left out
    # (paired, its depth was a pixel of disparity off: white_ball tune seed 103, 0.18 m behind the ball).
    if joined is not None:
        balls |= _ball_patches(
            joined, shaded, edges, grey, direction, straight, near_px, far_px, _inner_discs(joined, far_px, near_px), contrast
        )[0]
    return (balls, busy) if crowded else balls  # (apart: a patch is kept or crowded, a joined one neither)


def _inner_discs(patches: np.ndarray, far_px: float, near_px: float) -> tuple[np.ndarray, np.ndarray]:
    """The largest discs inside ``patches`` (uint8 0/1) centred where its distance transform peaks with a radius a
    ball's between ``far_px`` and ``near_px`` could have (shading's bounds), each a pixel narrower than it fits (a
    ball's patch is its disc and its rim's spread), and parted from the others it meets: labels (int32, 0 none) and
    stats (per label: x, y, width, height, area; row 0 unused), as cv2.connectedComponentsWithStats gives them (which
    takes 8 times as long as the labelling alone)."""
    fits = cv2.distanceTransform(patches, cv2.DIST_L2, 3)  # per pixel, the radius of the largest disc there in the patch
    low = max(far_px / 1.3, SHADING_MIN_RADIUS)
    peak = ((fits >= cv2.dilate(fits, None)) & (fits >= low) & (fits <= 1.3 * near_px)).astype(np.uint8)
    n, labels = cv2.connectedComponents(peak, connectivity=8)
    if n <= 1:
        return np.zeros(patches.shape, np.int32), np.zeros((1, 5), np.int32)
    xs, ys = cv2.findNonZero(peak).reshape(-1, 2).T
    mine = labels[ys, xs]
    count = np.bincount(mine, minlength=n)[1:]
    centres = np.column_stack([np.bincount(mine, xs, n)[1:], np.bincount(mine, ys, n)[1:]]) / count[:, None]  # as OpenCV's
    radii = _per_label(np.maximum, fits[ys, xs], mine, n, 0.0)[1:]
    order = np.argsort(-radii, kind="stable")  # the largest first; a peak inside a disc chosen is a lump of it
    centres, radii = centres[order], radii[order]
    within = np.hypot(*(centres[:, None] - centres[None]).transpose(2, 0, 1)) <= radii[:, None]  # [i, j]: j in i's disc
    lump = np.zeros(len(order), bool)
    for i in range(len(order)):
        if not lump[i]:
            lump[i + 1 :] |= within[i, i + 1 :]
    chosen = [(u, v, r) for (u, v), r, gone in zip(centres, radii, lump) if not gone]
    drawn = np.zeros(patches.shape, np.float32)  # each disc's number (1, 2 ...), the larger drawn over the smaller
    for number, (u, v, r) in reversed(list(enumerate(chosen, 1))):
        cv2.circle(drawn, (int(round(u)), int(round(v))), max(int(round(r)) - 1, 1), float(number), -1)
    # Two balls' discs overlap where their patch's rims spread into each other: the pixels where two discs meet are
    # left out, so that each disc is a patch of its own.
    apart = np.where(drawn > 0, drawn, np.float32(len(chosen) + 1))
    meets = (cv2.dilate(drawn, None) != drawn) | (cv2.erode(apart, None) != apart)
    out = np.where(meets, 0, drawn).astype(np.int32)
    xy = cv2.findNonZero((out > 0).astype(np.uint8)).reshape(-1, 2) if out.any() else np.zeros((0, 2), np.int32)
    mine = out[xy[:, 1], xy[:, 0]]
    m = len(chosen) + 1
    first, last = _per_label(np.minimum, xy, mine, m, 0), _per_label(np.maximum, xy, mine, m, -1)
    area = np.bincount(mine, minlength=m)
    stats = np.column_stack([first, last - first + 1, area])
    stats[area == 0] = 0  # (and row 0: no pixel is labelled 0)
    return out, stats.astype(np.int32)


def _per_label(reduce, values: np.ndarray, labels: np.ndarray, n: int, empty) -> np.ndarray:
    """Per label 0 .. n - 1, ``reduce`` (np.minimum, np.maximum) of its ``values`` (K, or K x D: per column), ``empty``
    for a label without any: a sort and one reduceat, where ufunc.at takes several times as long."""
    out = np.full((n, *values.shape[1:]), empty, dtype=np.result_type(values, type(empty)))
    if not len(values):
        return out
    order = np.argsort(labels, kind="stable")
    sorted_labels = labels[order]
    starts = np.flatnonzero(np.r_[True, sorted_labels[1:] != sorted_labels[:-1]])
    out[sorted_labels[starts]] = reduce.reduceat(values[order], starts)
    return out


def _ball_patches(
    out, shaded, edges, grey, direction, straight, near_px, far_px, discs=None, contrast: float = SHADING_CONTRAST
) -> tuple[np.ndarray, np.ndarray | None]:
    """The patches of a shading map (``out``, uint8 0/1, holes filled) that could be a ball (motion.shading's tests):
    round, as wide as a ball between ``far_px`` and ``near_px``, showing gradient themselves (``shaded``, before the
    holes were filled), alone on something flat (``edges`` around them), with a lit side and a limb (``grey``), a rim
    pointing every way (``direction``), and a disc on their own where cut off a ``straight`` edge. ``discs``: instead
    of ``out``'s patches, discs drawn a pixel inside a patch (_inner_discs: their labels and stats): discs already, and
    their ring starts beyond that pixel and the rim's spread. The patches kept, those that pass every test but being
    alone, and those too wide or not round (perhaps a ball joined to something; None when there is none, and for
    ``discs``), uint8 0/1 each."""
    h, w = out.shape
    drawn = discs is not None
    labels, stats = discs if drawn else cv2.connectedComponentsWithStats(out, connectivity=8)[1:3]
    n = len(stats)
    x, y, bw, bh, area = stats.T
    wide, narrow = np.maximum(bw, bh) / 2.0, np.minimum(bw, bh) / 2.0
    round_ = (wide <= SHADING_ASPECT * narrow) & (area >= SHADING_FILL * np.pi * wide * narrow)
    keep = round_ & (narrow <= near_px * 1.3) & (wide >= max(far_px / 1.3, SHADING_MIN_RADIUS))
    keep[0] = False
    joined = ~round_ | (narrow > near_px * 1.3)
    joined[0] = False
    joined = joined.astype(np.uint8)[labels] if joined.any() and not drawn else None  # (discs are not searched again)
    keep &= area <= SHADING_SQUARE * bw * bh  # a disc fills pi / 4 of its box, a switch or a socket all of it
    if not keep.any():
        return np.zeros_like(out), np.zeros_like(out), joined
    candidates = keep[labels]  # the pixels of the patches still in question (a few balls' worth)
    mine = labels[candidates]
    # a flat disc (a door's knob, painted) shows its edge only: its filled hole is most of it
    keep &= np.bincount(mine, weights=shaded[candidates], minlength=n) >= (SHADING_EDGED_DRAWN if drawn else SHADING_EDGED) * area
    alone = np.ones(n, bool)
    if keep.any():  # alone on something flat (a shelf's books, a poster's shapes are among other edges) ...
        g = np.ceil(wide).astype(int)  # the ring around a patch's box, its half-width wide
        m = 2 if drawn else 0
        box = (np.maximum(x - m, 0), np.maximum(y - m, 0), np.minimum(x + bw + m, w), np.minimum(y + bh + m, h))
        grown = (np.maximum(x - g, 0), np.maximum(y - g, 0), np.minimum(x + bw + g, w), np.minimum(y + bh + g, h))
        ring = np.maximum((grown[2] - grown[0]) * (grown[3] - grown[1]) - (box[2] - box[0]) * (box[3] - box[1]), 1)
        alone = _box_sums(cv2.integral(edges, sdepth=cv2.CV_32S), grown, box) <= (SHADING_BUSY_DRAWN if drawn else SHADING_BUSY) * ring
    if keep.any():  # a sphere's lit side and its limb differ: a flat decal (a switch, a socket) is one grey
        shades = grey[candidates]
        keep &= _per_label(np.maximum, shades, mine, n, 0.0) - _per_label(np.minimum, shades, mine, n, 255.0) >= contrast
    if keep.any():  # a ball's rim turns all the way round: its gradient points every way, a corner's or a line end's not
        way = (direction[candidates] * (SHADING_WAYS / (2 * np.pi))).astype(np.int32) % SHADING_WAYS
        rim = shaded[candidates] > 0
        ways = np.zeros((n, SHADING_WAYS), bool)
        ways[mine[rim], way[rim]] = True
        keep &= ways.all(axis=1)
    cut = np.bincount(labels[cv2.dilate(straight.astype(np.uint8), None) > 0], minlength=n) > 0
    if not drawn and (keep & cut).any():  # a patch cut off a straight edge may be any piece of what the edge bounded (a table's
        # corner, a picture's inside): it must be a disc on its own, filling the ellipse in its box and little beyond
        yy, xx = np.nonzero(candidates)
        cx, cy, a, b = x + (bw - 1) / 2.0, y + (bh - 1) / 2.0, bw / 2.0, bh / 2.0
        inside = ((xx - cx[mine]) / a[mine]) ** 2 + ((yy - cy[mine]) / b[mine]) ** 2 <= 1.0
        within = np.bincount(mine[inside], minlength=n)
        disc = (within >= SHADING_DISC * np.pi * a * b) & (area - within <= (1 - SHADING_DISC) * area)
        keep &= ~cut | disc
    return (keep & alone).astype(np.uint8)[labels], (keep & ~alone).astype(np.uint8)[labels], joined


def _straight(edges: np.ndarray, direction: np.ndarray, length: float) -> np.ndarray:
    """The pixels of ``edges`` (uint8 0/1) on straight edges: 8-connected runs whose gradient ``direction``
    (radians) lies within one window of SHADING_TURN (windows stepped by half of it, so that every direction falls
    wholly inside one) and whose box's diagonal is ``length`` pixels or more. bool."""
    steps = 2 * int(round(2 * np.pi / SHADING_TURN))  # half-windows round the circle
    return straight_runs(edges, direction, steps, float(length))


def _pale(image: np.ndarray, target) -> np.ndarray:
    """Where ``image`` (BGR uint8) could show a white or grey ball (``target`` of every hue): saturation at most the
    range's top, value at least SHADING_VALUE of its bottom (a ball's shaded side). bool."""
    hsv = cv2.cvtColor(image, cv2.COLOR_BGR2HSV)
    return (hsv[..., 1] <= target.hsv_max[1]) & (hsv[..., 2] >= np.ceil(SHADING_VALUE * target.hsv_min[2]))


def _room(flat: np.ndarray) -> np.ndarray:
    """The parts of a window's flat map (bool, 4-connected) that reach its border: a wall goes on beyond a ball's disc,
    a ball's own flat, lit centre is closed in by its rim."""
    n, labels, stats, _ = cv2.connectedComponentsWithStats(flat.astype(np.uint8), connectivity=4)
    x, y, bw, bh = stats[:, 0], stats[:, 1], stats[:, 2], stats[:, 3]
    edge = (x == 0) | (y == 0) | (x + bw == flat.shape[1]) | (y + bh == flat.shape[0])
    edge[0] = False  # label 0: the cells that are not flat
    return edge[labels]


def _gradient(image: np.ndarray) -> np.ndarray:
    """Per pixel, the mean gradient magnitude (grey levels per pixel, Sobel) over its 3 x 3 neighbourhood of ``image`` (BGR float32)."""
    return cv2.blur(cv2.magnitude(*_sobel(image.mean(axis=2))), (3, 3))


def still_only(shaded: np.ndarray, foreground: np.ndarray) -> np.ndarray:
    """The patches of a shading map (uint8 0/1) that touch no moving cell: a moving ball is in the moving map already,
    whose disc is the ball's own (its shading patch, merged with its trail or a neighbour's edge, would move its centre)."""
    n, labels = cv2.connectedComponents(shaded, connectivity=8)
    if n <= 1:
        return shaded
    touched = np.bincount(labels[cv2.dilate(foreground, None) > 0], minlength=n) > 0
    touched[0] = True
    return (~touched).astype(np.uint8)[labels]


def _box_sums(table: np.ndarray, outer: tuple, inner: tuple) -> np.ndarray:
    """Per box, the sum of a summed-area table's map between the ``outer`` box and the ``inner`` one (x0, y0, x1, y1 arrays)."""

    def total(x0, y0, x1, y1):
        return table[y1, x1] - table[y0, x1] - table[y1, x0] + table[y0, x0]

    return total(*outer) - total(*inner)


_CROSS = cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3))


def halved(image: np.ndarray) -> np.ndarray:
    """The image on the background's grid: each SCALE x SCALE block's mean, rounded (cv2.resize's INTER_AREA by a
    whole factor; an odd last row or column is left out)."""
    h, w = image.shape[0] // SCALE, image.shape[1] // SCALE
    return cv2.resize(image[: SCALE * h, : SCALE * w], (w, h), interpolation=cv2.INTER_AREA)


_NO_MAP = np.zeros((0, 0), np.uint8)


class BackgroundModel:
    """One camera's background, learnt as frames come."""

    def __init__(self, camera: Camera, rate: float, threshold: float, rim_checked: Mapping[str, Target] | None = None, faint: bool = False):
        self.camera = camera
        self.keep_faint = faint  # make ``faint`` each frame too (a target whose streaks are looked for)
        self.faint: np.ndarray | None = None  # uint8 0/1 on the background's grid: cells changed by FAINT_SHARE of the threshold
        self.rim_checked = dict(rim_checked or {})  # targets of every hue (white, grey) by name: their discs are checked (_ghosts)
        self.rate = rate  # weight of each new frame in the running average (1 / frames it takes to learn a change)
        self.threshold = threshold  # grey levels
        self._background: np.ndarray | None = None  # float32, half size
        self._frames = 0  # frames learnt so far (the warm-up's running mean)
        self.compared = False  # has a frame been compared with a background learnt before it? (the first frame is the background)
        self.behind: np.ndarray | None = None  # the background (uint8 BGR, its grid) as it was before the last frame learnt
        self._previous: np.ndarray | None = None  # uint8, the last frame at that size (after its gain)
        self._calm: np.ndarray | None = None  # uint8, frames in a row each cell has not changed (at most 255)

    def start(self, frames_halved: Sequence[np.ndarray]) -> None:
        """Start the background as the per-pixel median of frames at its grid (``halved``), taken from the whole of a
        recording: where the balls are in fewer than half of them, it is the room alone, and the first frame tracked
        leaves no ghost ball behind (white_ball tune seeds: the start's ghosts and late balls were most of the errors)."""
        median = np.median(np.stack(frames_halved), axis=0).astype(np.uint8)
        self._background = median.astype(np.float32)
        self._previous = median
        self._calm = np.zeros(median.shape[:2], np.uint8)
        self._frames = int(np.ceil(1.0 / self.rate))  # learnt: no warm-up
        self.faint = np.zeros(median.shape[:2], np.uint8) if self.keep_faint else None

    def foreground(self, image: np.ndarray, balls: TrackedBalls | None = None) -> np.ndarray:
        """This frame's foreground at the image's size (H x W uint8 0/1); then learn the frame, except where ``balls`` are."""
        h, w = image.shape[:2]
        return cv2.resize(self.update(image, balls), (w, h), interpolation=cv2.INTER_NEAREST)

    def update(self, image: np.ndarray, balls: TrackedBalls | None = None, image_halved: np.ndarray | None = None) -> np.ndarray:
        """This frame's foreground on the background's grid (1 / SCALE of the image's size, uint8 0/1; the
        tracker reads it there, evidence/gather.py); then learn the frame, except where ``balls`` are.
        ``image_halved``: ``halved(image)``, when it was made already (ahead, in another thread: pipeline/run.py)."""
        h, w = image.shape[:2]
        if self._background is None:
            self._previous = halved(image) if image_halved is None else image_halved.copy()
            self._background = self._previous.astype(np.float32)
            self._calm = np.zeros(self._background.shape[:2], np.uint8)
            self._frames = 1
            self.faint = np.zeros(self._background.shape[:2], np.uint8) if self.keep_faint else None
            return np.zeros(self._background.shape[:2], np.uint8)
        self.compared = True
        learn = np.ones(self._background.shape[:2], np.uint8)
        every, balls = balls, self._moved(balls)
        if balls is not None and len(balls):
            uv, front, depth = self.camera.view(balls.centres)
            seen = self.camera.apparent_radius(balls.radii, depth)  # pixels of the evidence grid
            r = seen * KEEP_OUT_MARGIN / SCALE
            small = (halved(image) if image_halved is None else image_halved) if self.rim_checked else None
            ghost = self._ghosts(small, balls, uv, front, seen)
            if self.rim_checked:
                discs = self._discs(every)
                for (u, v), ok, radius, g, name, k in zip(uv, front, r, ghost, balls.targets, balls.track_ids):
                    if name in self.rim_checked and ok and not g and np.isfinite(u) and np.isfinite(v):
                        others = discs[every.track_ids != k]
                        self._unveil(small, u / SCALE, v / SCALE, radius, self.rim_checked[name], others)
            for (u, v), ok, radius, g in zip(uv.tolist(), front.tolist(), r.tolist(), ghost.tolist()):  # (as Python scalars)
                if ok and not g and -w < u < 2 * w and -h < v < 2 * h and radius < w:  # near the image (also not NaN)
                    cv2.circle(learn, (round(u / SCALE), round(v / SCALE)), math.ceil(radius) + 1, 0, -1)
        moving = np.empty(learn.shape, np.uint8)
        if self.behind is None:
            self.behind = np.empty(self._background.shape, np.uint8)
        gain = self._gain(image)
        rate = max(self.rate, 1.0 / (self._frames + 1))  # a running mean at first (warm-up), as MOG2 does
        self.faint = np.empty(learn.shape, np.uint8) if self.keep_faint else None
        calm_moving = background_step(
            halved(image) if image_halved is None else image_halved,
            self._background,
            self._previous,
            self._calm,
            learn,
            gain,
            rate,
            self.threshold,
            moving,
            self.behind,
            ABSORB_FRAMES,
            FAINT_SHARE * self.threshold,
            self.faint if self.faint is not None else _NO_MAP,
        )
        self._frames += 1
        if calm_moving >= MIN_GHOST_CELLS:
            self._absorb_ghosts(moving, learn)
        return moving

    def _ghosts(self, small: np.ndarray | None, balls: TrackedBalls, uv: np.ndarray, front: np.ndarray, r: np.ndarray) -> np.ndarray:
        """Per ball (``uv``, ``r``: its centre and apparent radius on the evidence grid), whether its disc is a ghost
        to be learnt all the same: for the targets of ``rim_checked``, a disc that shows nothing in this frame (a
        white ball's place in a white room, once the ball that sat there when the background started has gone). A
        white ball there, at rest or moving, shows its shading and rim. A track not settled yet may sit on a ghost on
        a textured wall too: its disc is a ghost where the frame shows less there than the background does (the
        background holds a ball the frame no longer shows) and has been calm a while (``_calm_disc``): a ball in front
        of the room shows at least as much, or moves. A white ball rolling before shelves of books shows less than the
        books, and was learnt under its own new track; the background kept some of it, a still ball beside the books for
        the rest of the scene (white_ball tune seed 44: 0.461 -> 0.983; tune seeds 0-119 summed +0.49)."""
        out = np.zeros(len(balls), bool)
        if not self.rim_checked:
            return out
        for k, ((u, v), ok, radius, name) in enumerate(zip(uv, front, r, balls.targets)):
            if name in self.rim_checked and ok and np.isfinite(u) and np.isfinite(v):
                seen = structure(small, u / SCALE, v / SCALE, radius / SCALE)
                out[k] = seen < STRUCTURE_MIN or (
                    not balls.settled[k]
                    and seen < structure(self._background, u / SCALE, v / SCALE, radius / SCALE)
                    and self._calm_disc(u / SCALE, v / SCALE, radius / SCALE)
                )
        return out

    def _calm_disc(self, u: float, v: float, r: float) -> bool:
        """Whether the disc (centre ``u``, ``v``, radius ``r`` on the background's grid) has been calm for ABSORB_FRAMES
        frames or more (the median of its cells' counts): a ghost stays where the ball left it, a ball moving in front of
        textured scenery changes its cells every frame."""
        h, w = self._calm.shape
        x0, x1 = max(int(u - r), 0), min(int(u + r) + 2, w)
        y0, y1 = max(int(v - r), 0), min(int(v + r) + 2, h)
        if x1 <= x0 or y1 <= y0:
            return False
        ys, xs = np.mgrid[y0:y1, x0:x1]
        disc = np.hypot(xs - u, ys - v) <= max(r, 1.0)
        return bool(disc.any()) and float(np.median(self._calm[y0:y1, x0:x1][disc])) >= ABSORB_FRAMES

    def changed(self, foreground: np.ndarray, u: float, v: float, r: float) -> bool:
        """Whether the box of a disc (centre ``u``, ``v``, radius ``r`` on the evidence grid) holds a cell of this frame's
        ``foreground`` (``update``'s) that changed in the last ABSORB_FRAMES frames: something moves there, rather than
        differing from the background while still (a thing put down, a white ball's shading at rest)."""
        h, w = self._calm.shape
        u, v, r = u / SCALE, v / SCALE, r / SCALE
        x0, x1 = max(int(u - r), 0), min(int(u + r) + 2, w)
        y0, y1 = max(int(v - r), 0), min(int(v + r) + 2, h)
        if x1 <= x0 or y1 <= y0:
            return False
        return bool(((foreground[y0:y1, x0:x1] > 0) & (self._calm[y0:y1, x0:x1] < ABSORB_FRAMES)).any())

    def _discs(self, balls: TrackedBalls) -> np.ndarray:
        """Per ball, its kept-out disc on the background's grid: B x 3 (u, v, radius; NaN behind the camera)."""
        uv, front, depth = self.camera.view(balls.centres)
        r = self.camera.apparent_radius(balls.radii, depth) * KEEP_OUT_MARGIN / SCALE
        out = np.column_stack([uv / SCALE, r])
        out[~front] = np.nan
        return out

    def _unveil(self, small: np.ndarray, u: float, v: float, r: float, target: Target, others: np.ndarray) -> None:
        """Learn at once the cells of a white or grey ball's kept-out disc (centre ``u``, ``v``, radius ``r`` on the
        background's grid) that the ball has left: the background holds the ball there and this frame, still for
        ABSORB_FRAMES, shows the room. A slow ball (or one moving along a camera's ray) stays within its own width while
        the background starts and is learnt into it; once it moves on, a track that settled on its ghost and the ball
        together kept the ghost out of the update for ever, its disc showing the ball's rim (no ghost for ``_ghosts``),
        and held the track off the ball (white_ball tune seeds 5, 16, 18, 23, 37). The ball has left a cell whose
        background is of its colour (``_pale``) and whose frame is not (a dark floor, a shelf), or whose background
        shows its shading (gradient of SHADING_MIN or more, or a hole in that: its flat, lit centre) where the frame
        is flat (under STRUCTURE_MIN) and the flat reaches past the disc (``_room``: a white wall; a ball's own flat,
        lit centre is closed in by its rim). The ball itself, in front of the room, is neither; nor
        are the cells in ``others`` (the other tracked balls' discs, N x 3: u, v, radius)."""
        h, w = small.shape[:2]
        g = int(np.ceil(r)) + 2
        x0, x1, y0, y1 = max(int(u) - g, 0), min(int(u) + g + 1, w), max(int(v) - g, 0), min(int(v) + g + 1, h)
        if x1 - x0 < 3 or y1 - y0 < 3:
            return
        bg = self._background[y0:y1, x0:x1]
        cur = small[y0:y1, x0:x1].astype(np.float32)
        ys, xs = np.mgrid[y0:y1, x0:x1]
        cells = (np.hypot(xs - u, ys - v) <= r) & (np.abs(cur - bg).sum(axis=2) > self.threshold)
        for ou, ov, orad in others:  # another ball there shows itself, not the room (one passing in front of one at rest)
            if np.hypot(ou - u, ov - v) < r + orad:
                cells &= np.hypot(xs - ou, ys - ov) > orad
        if not cells.any():
            return
        flat = _room(_gradient(cur) < STRUCTURE_MIN)
        left = (_gradient(bg) >= SHADING_MIN) & flat
        hole = ~left & ~_room(~left)  # the parts of the rest closed in by the shading: its flat, lit centre
        gone = _pale(bg.astype(np.uint8), target) & ~_pale(small[y0:y1, x0:x1], target)
        cells &= (self._calm[y0:y1, x0:x1] >= ABSORB_FRAMES) & (gone | (flat & (left | hole)))
        bg[cells] = cur[cells]

    def _absorb_ghosts(self, moving: np.ndarray, learn: np.ndarray) -> None:
        """Learn at once the moving patches none of whose cells has changed for ABSORB_FRAMES frames: a ghost
        (the room a ball uncovered, which the background still holds the ball in front of) or a thing that
        stopped, untracked. A moving thing's patch changes at its edges, a tracked ball's is kept out (``learn``).
        Called only when MIN_GHOST_CELLS moving cells or more are calm (a speck of noise is left to the running average)."""
        absorb_still_patches(moving, self._calm, learn, self._background, self._previous, ABSORB_FRAMES)

    def _moved(self, balls: TrackedBalls | None) -> TrackedBalls | None:
        """The tracked balls that keep the background from learning their discs: the settled ones (tracks/manager.py:
        moved since their track began, or lived a while). A new track that has not moved may hold a ghost (a ball
        that sat there when the background started, then left): protected, it would stay foreground for ever.
        A white or grey ball's (``rim_checked``) whatever its track's age: a ghost's disc is told by what it shows
        (``_ghosts``), and a white ball at rest under a new track, learnt like the room (absorbed whole once still
        for ABSORB_FRAMES), left a ghost ball where it had rested when it rolled on, which a new track took for 5-8
        frames (white_ball tune seeds 5, 6, 7, 17, 23, 27)."""
        if balls is None or not len(balls):
            return balls
        white = np.array([name in self.rim_checked for name in balls.targets], dtype=bool)
        return balls.where(balls.settled | white)

    def _gain(self, image: np.ndarray) -> np.ndarray:
        """Per channel, what this frame must be multiplied by to match the background where the room did not
        change: the median ratio over a grid of cells (a ball or a hand moves over a few of them, a light that
        dims or flickers, or a camera's exposure that hunts, changes them all)."""
        return frame_gain(image, self._background, GAIN_STEP, SCALE)
