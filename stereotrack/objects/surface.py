"""Is a still object a patch of a surface (a book's end, a poster's corner), not a ball before it? Does it show as a ball at all?

A ball's outline is a depth edge all round: what shows just outside its disc lies behind it (or in front), at another
depth. A patch of a surface of the ball's colour is bounded by the same surface, or by things on it: what shows just
outside it lies at its own depth. So around a still object, the ring just outside its disc is compared between two
views for surfaces at depths along the viewing ray: when the ring matches best at the object's own depth, and clearly
better there than at any depth two ball radii (in pixels of disparity) or more away, it is part of the surface it is seen
on. A uniform surround matches at every depth alike (no verdict); a periodic one at several (no verdict either).

Before that, a still object of a coloured ball must show as a ball (``ball_shaped``): in some view its blob a whole disc
of the size a ball has at the depth the views give it, or, where it merges with things of its colour behind it, its
outline all round in the image (``rimmed``). A bottle, a flag or a sign of the ball's colour is not one. And
it must be shaded (``flat``): a round sticker of the ball's colour on a plain wall, whose surround tells nothing, is one
flat colour in every view. And its outline must be round in some view (``rounded``): a cube of the ball's colour on a
stand is not. One that shows as a whole ball in every view, large enough for its shape to tell
(``whole_ball``), is a ball even where its surround lies at its own depth: a ball at rest against a wall.
"""

from __future__ import annotations

from collections.abc import Sequence

import cv2
import numpy as np

from ..camera import Camera
from ..config import Target
from ..evidence.colour import box_counts, target_mask, to_hsv
from ..evidence.gather import CameraEvidence
from ..evidence.outlines import OUTLINE_MIN_PX, centred, round_rim
from .shapes import ROUND_FILL, ROUND_MIN_PX

RING = (1.5, 3.0)  # the ring's inner and outer radii, in the ball's apparent radius ...
RING_MARGIN_PX = (2.0, 4.0)  # ... at least this far outside the disc, and this wide: clear of its blurred edge
RING_ANGLES = 36
RING_CIRCLES = 3
# Surfaces at these multiples of the object's distance: every half per cent near it (a pixel of disparity is 0.5-1 per cent
# at a few metres), every 5 per cent out to half and twice it
DEPTH_FACTORS = np.unique(np.r_[np.linspace(0.9, 1.1, 41), np.exp(np.arange(np.log(0.5), np.log(2.0) + 1e-9, np.log(1.05)))])
OWN_PX, AWAY_PX = 2.0, 4.0  # pixels of disparity: within this of the object's depth is at it; at least this (and two radii) away is not
# The ring matches best at the object's depth, and this many times better there (its mean absolute difference, each view's
# mean taken out) than at any depth two ball radii of disparity or more away: the surround is at the object's depth. Still
# balls' rings (hue_wall, static_props tune seeds 48-59, 90 frames) never match best at their own depth; a book's end on a
# shelf (hue_wall 18) 4.6-4.9 times better there, a speck on a poster at 20 m (fast_ball 47) 5.7-9.3 where it does.
SURFACE_RATIO = 2.0
# ... or this many times better in both directions (the ring taken round the object in camera a and searched along b's
# epipolar lines, and the other way round): two searches that agree on the object's own depth are less likely a chance
# match of a plain surround than one is. Still balls' rings (hue_wall, static_props tune seeds 0-59, 121 samples) never
# match best at their own depth both ways (at most 1.44 one way, 0 the other); a green book's end on a shelf, 1.7 both
# ways (hue_wall tune seed 68)
SURFACE_RATIO_BOTH = 1.5
# A verdict is kept this long for an object still at the spot judged (within SAME_SPOT of its radius): scenery stays where
# it is, and judging costs a few hundred samples per depth searched; judged again after it, in case the first was wrong
VERDICT_SECONDS = 0.5
SAME_SPOT = 0.5
# A ball at rest shows as one (``ball_shaped``): in some view its blob fills ROUND_FILL to ROUND_FILL_MAX of the disc its
# larger side spans (a square fills 4 / pi), its second-moment axes no flatter than ROUND_AXES, and it is the size a ball
# is at its depth, to ROUND_SIZE (a log ratio: a quarter) or SIZE_PX. Still balls (static_props tune seeds 40-99, 999
# object-frames): fill 0.88-1.04, axes 0.89-0.99, size -0.02-0.13 (1st-99th percentiles), every one shaped so; still
# things that were no ball (423): 78 per cent were not (a bottle on a table, a flag, a sign a third larger than a ball at
# the depth its two views give it). A ball at rest before things of its colour merges with them and is lost (hue_wall
# tune seeds 90, 106, 154; static_props 13): a size of 0.4 kept those and lost half the gain (static_props 0-159 +3.01
# against +5.27, hue_wall +2.31 against +3.00), and letting a blob twice a ball's size say nothing +2.70 on hue_wall.
# ... and is shaded: lit on one side, darker towards its limb, with a highlight, where a round sticker or a painted dot
# of the ball's colour is one flat colour. A still thing whose disc's core (FLAT_CORE of its apparent radius) spans
# less than FLAT_SPREAD levels of value (HSV's V: 90th less 10th percentile) in every view is no ball. Only the core's
# pixels in the target's typed range whose eight neighbours are too count: a small sticker that is no disc has wall in
# the core, and its rim blends into the wall (static_props tune seed 300: an orange arrow on a purple wall spans 34-50
# over the whole core, 13-19 over its own pixels). The typed range, not the colour model's mask: that one leaves out a
# ball's highlight and limb, where its shading shows (a ball at rest before a wall of its hue, hue_wall tune seed 91:
# 27-43 over the mask's pixels, 42-48 over the range's). A view that shows the core under FLAT_MIN_PX pixels in radius,
# or fewer than FLAT_MIN_COUNT such pixels, tells nothing. static_props tune seeds 240-319, tracked rows every 10th
# frame, the larger of the views: on a ball 34 or more (1737 rows; 5th percentile 44), on stickers 8-11 (seed 265: a
# violet shape on a beige wall) and 13-19 (seed 300).
FLAT_SPREAD = 24.0
FLAT_CORE = 0.7
FLAT_MIN_PX = 2.0
FLAT_MIN_COUNT = 4
ROUND_FILL_MAX = 1.15
ROUND_AXES = 0.7
ROUND_SIZE = 0.25
SIZE_PX = 0.75  # a few pixels' ball: its blob's half side is quantised to half a pixel
# ... or, before things of its colour, shows its outline (``rimmed``). A ball at rest before a wall or a shelf of its hue
# merges with it in the mask, or the colour model keeps only parts of it, and no blob is its disc (hue_wall tune seeds
# 163, 145, 74, 90, 184: a ball lost for the whole scene). In the image it stands out from what is behind it by its
# shading and saturation all round, where a patch of the wall does not: across a circle of the ball's apparent size (to
# a fifth: its depth and centre are an estimate's) the colour steps by RIM_STEP (summed over the three channels,
# between points RIM_GAP of the radius, or RIM_GAP_PX, inside and outside it) in RIM_SHARE of RIM_ANGLES directions,
# in every view that shows it RIM_MIN_PX or more in radius. A thing of the ball's colour alone on a plain wall steps
# all round too (a flattened ellipsoid on a stick, static_props tune seeds 279, 292: kept, a false track for the
# whole scene), but its own blob is its outline, and the blob test's verdict stands: the outline counts only before
# things of the ball's colour, RIM_RING or more of the ring RING_OF_COLOUR (radii) round the disc in the range in
# some view. Still objects the blob test dropped (hue_wall tune seeds 0-199 and static_props 0-159, 240-319, the
# seeds where any was a ball or would be kept): balls 374 of 397 object-frames kept (12 seeds; their rings 0.38 or
# more in range in the view that shows most), things 1 of 552 (rings up to 0.24 where their outline steps all round).
# MOTA summed: hue_wall tune seeds 0-199 +2.21 (seeds under 0.85: 25 -> 20, none worse), static_props 0-159 and 240-319
# +0.08, +0.04; never looked at before, hue_wall 200-279 +0.26 and 280-399 +0.85 (under 0.85: 12 -> 10), static_props
# 400-479 +0.00 and 480-559 +0.20 (under 0.85: 8 -> 6).
RIM_ANGLES = 36
RIM_SCALES = (0.8, 0.9, 1.0, 1.1, 1.2)
RIM_GAP, RIM_GAP_PX = 0.15, 1.0
RIM_STEP = 30.0
RIM_SHARE = 0.9
RIM_MIN_PX = 3.0
RING_OF_COLOUR = (1.3, 1.8)
RIM_RING = 0.3
_ANGLES = np.linspace(0.0, 2 * np.pi, RIM_ANGLES, endpoint=False)
_DIRECTIONS = np.stack([np.cos(_ANGLES), np.sin(_ANGLES)], axis=-1)  # A x 2: the outline's directions from a centre
# A ball at rest against a wall, or a hand's breadth before it, has the wall round it at its own depth to a pixel or two of
# disparity, and by its surround alone it is a patch of the wall (static_props seed 469: a green ball at rest 1.9 m away
# before a mauve wall, dropped for the whole scene). Its shape says otherwise where it is seen large enough: a disc of its
# size (``ball_shaped``) with its outline all round (``_outlined``) in every view, WHOLE_MIN_PX or more in radius
# (``whole_ball``), is a ball wherever it rests, and its surround is not asked. Smaller, a disc's few pixels fit a far
# thing by chance, and the surround decides. Every still object that reached the surround test (shaped or outlined, not
# flat; hue_wall tune seeds 0-199, static_props 0-159, 240-319, 400-559): balls it dropped, 82 object-frames in 8 seeds,
# every one 9-13 pixels in radius in both views, a whole disc outlined all round in each; things it dropped, 125, every
# one 4-5 pixels (a book's end on a shelf at 4 m, hue_wall seeds 68, 147), shaped and outlined too.
WHOLE_MIN_PX = 6.0
# ... and in no view lies in a bar of its colour as wide as it: a blob BAR_LENGTH or more of its apparent radii long
# (semi-major axis), at most BAR_FLAT as wide as long, and BAR_WIDTH of its radii wide (semi-minor axis: a bar as wide as
# the ball reads 1.15). The end of a slat or a stripe that a shelf cuts short fills a ball's disc with most of its ring
# empty; seen with a piece of the same slats that is a ball's shape in the other view, it was a ball at rest for the
# whole scene (hue_wall tune seed 147: two such, 1.1 radii wide, and the ball that flew was never tracked). A ball at
# rest touching the end of a narrower stripe of its hue, or merged with wider things of it, is not in such a bar (tune
# seeds 14, 56: 0.6 and 1.9 radii; each ball lost for the whole scene with any width taken).
BAR_LENGTH = 2.5
BAR_FLAT = 0.5
BAR_WIDTH = (0.85, 1.5)
# ... and it lies at the bar's end, within BAR_END of its radii: a ball at rest before the middle of a stripe of its hue
# merges with it into a bar as wide (hue_wall tune seed 78: dropped, a ball lost for 68 frames)
BAR_END = 2.0
# ... and shows a round outline in some view (``round_rim``): an edge crossing one circle about its apparent size (0.7-1.4
# of it: its depth and centre are an estimate's) radially, OUTLINE_EDGE levels per pixel or more in some channel and within
# 22.5 degrees of the circle's normal, in OUTLINE_SHARE or more of OUTLINE_ANGLES directions from its centre (a direction
# counts where the circle next larger or smaller shows it too). A ball's rim is such an edge wherever what is behind it
# differs from it; a square's sides meet one circle within 22.5 degrees of their normals in at most half the directions
# (a shaded square as wide as the ball: 0.58). Some view, not every one: an object a little off a ball (its depth not
# yet found, or the ball hidden in one view) shows the ball's rim in one view and none in the other, and dropped, its
# track never came to the ball (hue_wall tune seeds 147, 156: -0.92, -0.17 with every view asked). Still objects that
# passed every test above, static_props and hue_wall tune seeds 0-159 (7,915 object-frames 5 pixels or more in radius
# in every view), in the view that shows it best: balls under 0.6 in none of 7,810 (the least 0.69); things in 33 of
# 105, 32 of them a green cube on a stand that both cameras see at one depth (static_props seed 151, a track for 85
# frames: 0.44-0.54).
OUTLINE_SHARE = 0.6  # (a view that shows it under OUTLINE_MIN_PX in radius says nothing: evidence/outlines.py)
MATCH_FLOOR = 1.0  # grey levels: a ring that matches better than this matches as well as the images' quantisation lets it


def _sample(image: np.ndarray, uv: np.ndarray, grey: bool = True) -> np.ndarray:
    """Grey values (float, the mean of the channels) of ``image`` at pixels ``uv`` (... x 2), bilinear; with ``grey``
    False, every channel (... x C)."""
    shape = uv.shape[:-1]
    maps = uv.reshape(1, -1, 2).astype(np.float32)
    out = cv2.remap(image, maps[..., 0], maps[..., 1], cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE).astype(np.float32)
    if not grey:
        return out.reshape(shape + (-1,))
    if out.ndim == 3:
        out = out.mean(axis=2)
    return out.reshape(shape)


def surface_ratio(position: np.ndarray, radius: float, a: Camera, b: Camera, image_a: np.ndarray, image_b: np.ndarray) -> float:
    """How many times better the ring around a ball of ``radius`` at ``position`` matches between cameras a and b at its own
    depth than at other depths; NaN when it cannot be told (out of a view, or no depth far enough from its own searched)."""
    p = np.asarray(position, float)
    uv0, front, z = a.view(p[None])
    uvb, front_b = b.project(p[None])
    if not (front[0] and front_b[0] and a.in_image(uv0)[0] and b.in_image(uvb)[0]):
        return np.nan
    r = float(a.apparent_radius(radius, z[0]))
    inner = max(RING[0] * r, r + RING_MARGIN_PX[0])
    outer = max(RING[1] * r, inner + RING_MARGIN_PX[1])
    # The ring as points around the object across camera a's ray (metres: pixels at its depth), each slid along its own
    # ray from camera a to the depths searched: it stays where it is in camera a's view, and moves along the epipolar lines in b's
    ray = p - a.centre
    distance = float(np.linalg.norm(ray))
    ray /= max(distance, 1e-12)
    across = np.linalg.svd(ray[None])[2][1:]  # two unit vectors across the ray
    angles = np.linspace(0.0, 2 * np.pi, RING_ANGLES, endpoint=False)
    radii = np.linspace(inner, outer, RING_CIRCLES) * z[0] / a.focal_px
    circle = np.stack([np.cos(angles), np.sin(angles)], axis=-1) @ across  # RING_ANGLES x 3
    ring = (p + (radii[:, None, None] * circle[None]).reshape(-1, 3)) - a.centre
    seen_a, front_a = a.project(a.centre + ring)
    inside = front_a & a.in_image(seen_a)
    if inside.sum() < len(ring) // 2:
        return np.nan
    ring, seen_a = ring[inside], seen_a[inside]
    points = a.centre + ring[None] * DEPTH_FACTORS[:, None, None]  # S x N x 3
    uv, ok = b.project(points.reshape(-1, 3))
    seen = (ok & b.in_image(uv)).reshape(len(DEPTH_FACTORS), -1)
    grey_a = _sample(image_a, seen_a)
    uv[~ok] = 0.0  # (behind camera b: not seen)
    grey_b = _sample(image_b, uv.reshape(len(DEPTH_FACTORS), -1, 2))
    grey_a = grey_a - grey_a.mean()
    grey_b = grey_b - grey_b.mean(axis=1, keepdims=True)
    diff = np.abs(grey_b - grey_a[None]).mean(axis=1)
    diff[~seen.all(axis=1)] = np.nan
    centres, _ = b.project(a.centre + (p - a.centre) * DEPTH_FACTORS[:, None])
    shift = np.linalg.norm(centres - uvb, axis=1)  # pixels of disparity from the object's depth
    # The best match must lie at the object's own depth, to a blob's disparity's precision (OWN_PX: a speck's centroid jumps
    # a pixel or two, fast_ball tune seed 47); a ball's ring matches best where what lies behind it is (hue_wall tune seed 7:
    # a wall 8 pixels of disparity behind a ball of 10 pixels' radius, its ring's match falling all the way there)
    if not np.isfinite(diff).any():
        return np.nan
    best = int(np.nanargmin(diff))
    away = diff[shift >= max(AWAY_PX, 2.0 * r)]
    if not np.isfinite(away).any():
        return np.nan
    if shift[best] > OWN_PX:
        return 0.0
    return float(np.nanmin(away) / max(float(diff[best]), MATCH_FLOOR))


def on_surface(position: np.ndarray, radius: float, cameras: Sequence[Camera], images: Sequence[np.ndarray]) -> bool:
    """Is an object at ``position`` a patch of the surface it is seen on (``surface_ratio`` at least SURFACE_RATIO between the
    first camera and every other that tells, or SURFACE_RATIO_BOTH both ways)? False when none tells."""
    ratios = np.array([surface_ratio(position, radius, cameras[0], b, images[0], images[k]) for k, b in enumerate(cameras[1:], 1)])
    told = np.isfinite(ratios)
    if not told.any():
        return False
    if (ratios[told] >= SURFACE_RATIO).all():
        return True
    if (ratios[told] < SURFACE_RATIO_BOTH).any():
        return False
    back = [surface_ratio(position, radius, b, cameras[0], images[k], images[0]) for k, b in enumerate(cameras[1:], 1) if told[k - 1]]
    return bool((np.nan_to_num(back) >= SURFACE_RATIO_BOTH).all())


def ball_shaped(position: np.ndarray, radius: float, views: Sequence[CameraEvidence]) -> bool:
    """Does a ball at ``position`` show as one in some view: the blob nearest its centre (within its apparent radius)
    a whole disc of the size a ball has at that depth? A ball of fewer than ROUND_MIN_PX pixels is judged by its size
    alone (its fill and axes say nothing); blobs without an outline (the paper's histogram maxima) say nothing."""
    for v in views:
        b = v.blobs
        if b.axes is None:  # blob_method 'histogram': an area and a size that are no outline's
            return True
        if not len(b.centres):
            continue
        uv, r = _seen(v.camera, position, radius)
        if r <= 0:
            continue
        gaps = np.hypot(*(b.centres - uv).T)
        k = int(np.argmin(gaps))
        if gaps[k] > max(r, 2.0):
            continue
        side = max(float(b.radii[k]), 0.5)  # half the blob's larger side
        sized = abs(np.log(side / max(r, 0.5))) < ROUND_SIZE or abs(side - r) <= SIZE_PX
        if r < ROUND_MIN_PX:
            if sized:
                return True
            continue
        fill = b.areas[k] / (np.pi * side**2)
        axes = b.axes[k][1] / max(b.axes[k][0], 1e-6)
        if sized and ROUND_FILL <= fill <= ROUND_FILL_MAX and axes >= ROUND_AXES:
            return True
    return False


def in_bar(position: np.ndarray, radius: float, views: Sequence[CameraEvidence]) -> bool:
    """Does a ball at ``position`` lie, in some view, at the end of a bar of its colour as wide as it: its centre's pixel
    in a blob BAR_LENGTH or more of its apparent radii long, at most BAR_FLAT as wide as long and BAR_WIDTH of its radii
    wide, within BAR_END of its radii of the blob's end? Blobs without labels say nothing."""
    for v in views:
        b = v.blobs
        if b.axes is None or b.labels is None or not len(b):
            continue
        uv, r = _seen(v.camera, position, radius)
        if r <= 0:
            continue
        x, y = int(uv[0]) // b.label_scale, int(uv[1]) // b.label_scale
        if not (0 <= y < b.labels.shape[0] and 0 <= x < b.labels.shape[1]):
            continue
        k = b.label_blob[b.labels[y, x]]
        major, minor = b.axes[k] if k >= 0 else (0.0, 0.0)
        if major >= BAR_LENGTH * r and minor <= BAR_FLAT * major and BAR_WIDTH[0] * r <= minor <= BAR_WIDTH[1] * r:
            along = abs(float(np.dot(uv - b.centres[k], b.major[k])))  # a bar's half length is sqrt(3) / 2 its semi-major axis
            if np.sqrt(3.0) / 2.0 * major - along <= BAR_END * r:
                return True
    return False


def rimmed(position: np.ndarray, radius: float, cameras: Sequence[Camera], images: Sequence[np.ndarray], colour: Target) -> bool:
    """Does a ball at ``position`` show its outline in every view that shows it RIM_MIN_PX or more in radius (the colour
    steps by RIM_STEP or more across a circle about its apparent size, RIM_SCALES, in RIM_SHARE of RIM_ANGLES directions
    from its centre), and stand before things of ``colour`` (the target's range) in one of them (RIM_RING of the ring
    round its disc)? Not when no view shows it so large."""
    shown = []  # (image, centre, apparent radius) of each view that shows it large enough
    for cam, image in zip(cameras, images):
        uv, r = _seen(cam, position, radius)
        if r < RIM_MIN_PX or image.ndim != 3:
            continue
        if not _outlined(image, uv, r):
            return False
        shown.append((image, uv, r))
    # The colour round it only once every view showed its outline (most things fail that, and it is the cheap part)
    return any(_ring_in_range(image, centre, r, colour) >= RIM_RING for image, centre, r in shown)


def rounded(position: np.ndarray, radius: float, cameras: Sequence[Camera], images: Sequence[np.ndarray], recentre: bool = False) -> bool:
    """Does a ball at ``position`` show a round outline (``round_rim`` at least OUTLINE_SHARE) in some view that shows it
    OUTLINE_MIN_PX or more in radius? True when no view shows it so large (nothing told). With ``recentre``, each view's
    circle where it is roundest within outlines.CENTRE_PX pixels (``centred``): a white ball's object is its shading's
    cluster, a pixel or two off its outline's centre."""
    told = False
    for cam, image in zip(cameras, images):
        uv, r = _seen(cam, position, radius)
        if r >= OUTLINE_MIN_PX:
            share = centred(image, uv[0], uv[1], r)[2] if recentre else round_rim(image, uv, r)
            if share >= OUTLINE_SHARE:
                return True
            told = True
    return not told


def whole_ball(
    position: np.ndarray, radius: float, cameras: Sequence[Camera], views: Sequence[CameraEvidence], images: Sequence[np.ndarray]
) -> bool:
    """Does a ball at ``position`` show whole in every view, and large enough there for its shape to tell (WHOLE_MIN_PX
    in radius): its blob a disc of its size (``ball_shaped``) and its outline all round in the image (as ``rimmed``
    reads it)? Then it is a ball wherever it rests (WHOLE_MIN_PX)."""
    for cam, view, image in zip(cameras, views, images):
        uv, r = _seen(cam, position, radius)
        if r < WHOLE_MIN_PX or image.ndim != 3 or not ball_shaped(position, radius, [view]) or not _outlined(image, uv, r):
            return False
    return bool(len(cameras))


def _seen(cam: Camera, position: np.ndarray, radius: float) -> tuple[np.ndarray, float]:
    """Where a ball at ``position`` shows in ``cam`` and its apparent radius there (0 when out of view)."""
    uv, front, z = cam.view(np.asarray(position, float)[None])
    if not front[0] or not np.isfinite(uv).all():
        return uv[0], 0.0
    return uv[0], float(cam.apparent_radius(radius, z[0]))


def _outlined(image: np.ndarray, centre: np.ndarray, r: float) -> bool:
    """Does the colour step by RIM_STEP across a circle about ``r`` (RIM_SCALES) round ``centre`` in RIM_SHARE of
    RIM_ANGLES directions (between points RIM_GAP of it, or RIM_GAP_PX, inside and outside)?"""
    gap = max(RIM_GAP * r, RIM_GAP_PX)  # each side of the outline: clear of its blur
    circles = np.asarray(RIM_SCALES)[:, None, None] * r * _DIRECTIONS  # S x A x 2, about the centre
    inside = _sample(image, centre + circles - gap * _DIRECTIONS, grey=False)
    outside = _sample(image, centre + circles + gap * _DIRECTIONS, grey=False)
    step = np.abs(outside - inside).sum(axis=-1).max(axis=0)  # per direction, at the circle where it steps most
    return bool((step >= RIM_STEP).mean() >= RIM_SHARE)


def _ring_in_range(image: np.ndarray, centre: np.ndarray, r: float, colour: Target) -> float:
    """The share of the ring RING_OF_COLOUR (in apparent radii ``r``) round ``centre`` in ``colour``'s range (0: none of
    it in the image)."""
    (u, v), h, w, grow = centre, image.shape[0], image.shape[1], int(np.ceil(RING_OF_COLOUR[1] * r))
    x0, x1, y0, y1 = max(int(u) - grow, 0), min(int(u) + grow + 1, w), max(int(v) - grow, 0), min(int(v) + grow + 1, h)
    ys, xs = np.mgrid[y0:y1, x0:x1]
    gaps = np.hypot(xs - u, ys - v)
    ring = (gaps >= RING_OF_COLOUR[0] * r) & (gaps <= RING_OF_COLOUR[1] * r)
    if not ring.any():
        return 0.0
    return float(target_mask(to_hsv(np.ascontiguousarray(image[y0:y1, x0:x1])), colour)[ring].mean())


def flat(
    position: np.ndarray, radius: float, cameras: Sequence[Camera], images: Sequence[np.ndarray], colour: Target | None = None
) -> bool:
    """Is a ball at ``position`` one flat colour in every view that shows enough of it (FLAT_SPREAD, FLAT_MIN_PX,
    FLAT_MIN_COUNT)? Not when no view does. With ``colour`` (the target), only the core's pixels in its range whose eight
    neighbours are too count; without, every pixel of the core."""
    told = False
    for cam, image in zip(cameras, images):
        uv, r = _seen(cam, position, radius)
        r *= FLAT_CORE
        if r < FLAT_MIN_PX:
            continue
        (u, v), h, w = uv, image.shape[0], image.shape[1]
        x0, x1, y0, y1 = max(int(u - r), 0), min(int(u + r) + 1, w), max(int(v - r), 0), min(int(v + r) + 1, h)
        if x1 - x0 < 2 or y1 - y0 < 2:
            continue
        ys, xs = np.mgrid[y0:y1, x0:x1]
        core = (xs - u) ** 2 + (ys - v) ** 2 <= r * r
        if colour is not None and image.ndim == 3:  # the range's pixels away from their rim (the image's border counts as in it)
            m0, m1, n0, n1 = max(y0 - 1, 0), min(y1 + 1, h), max(x0 - 1, 0), min(x1 + 1, w)
            in_range = target_mask(to_hsv(np.ascontiguousarray(image[m0:m1, n0:n1])), colour)
            inner = cv2.erode(in_range, np.ones((3, 3), np.uint8), borderType=cv2.BORDER_REPLICATE)
            core &= inner[y0 - m0 : y1 - m0, x0 - n0 : x1 - n0] > 0
        if core.sum() < FLAT_MIN_COUNT:
            continue
        patch = image[y0:y1, x0:x1]
        value = (patch.max(axis=2) if patch.ndim == 3 else patch)[core]  # HSV's V: the largest channel
        low, high = np.percentile(value, [10, 90])
        if high - low >= FLAT_SPREAD:
            return False
        told = True
    return told


def still(position: np.ndarray, radius: float, views: Sequence[CameraEvidence]) -> bool:
    """Is no pixel of the moving map in the box of a ball's disc at ``position`` in any view? (False without motion.)"""
    for v in views:
        if v.moving_integral is None:
            return False
        uv, front, z = v.camera.view(np.asarray(position, float)[None])
        if not front[0] or not np.isfinite(uv).all():
            continue
        r = float(v.camera.apparent_radius(radius, z[0])) + 1.0
        cu, cv = uv[0]
        if box_counts(v.moving_integral, cu - r, cv - r, cu + r + 1, cv + r + 1) > 0:
            return False
    return True


class SurfacePatches:
    """One target's still objects judged patches of a surface or not (``on_surface``), each verdict remembered for
    VERDICT_SECONDS while an object stays at its spot, and, with ``shapes``, whether they show as a ball at all
    (``ball_shaped``, ``flat``: shaded over its pixels of ``colour``, the target's range, when given): a stage object
    the tracker keeps, one per target."""

    def __init__(self, radius: float, cameras: Sequence[Camera], shapes: bool = True, colour: Target | None = None):
        self.radius = radius
        self.cameras = tuple(cameras)
        self.shapes = shapes
        self.colour = colour
        self.spots = np.zeros((0, 3))  # K x 3: where objects were judged ...
        self.verdicts = np.zeros(0, bool)  # ... on a surface or not ...
        self.times = np.zeros(0)  # ... and when

    def drop(
        self,
        objects: Sequence,
        views: Sequence[CameraEvidence],
        images: Sequence[np.ndarray],
        travelled: np.ndarray,
        now: float,
        calm: np.ndarray | None = None,
    ) -> np.ndarray:
        """Per object: is it a patch of the surface it is seen on, or (``shapes``) no ball's shape in any view? Only an
        object still in every view (``still``) and two radii or more from every ball that has travelled (``travelled``,
        B x 3: a ball that moved is no scenery, wherever it came to rest) is judged; the others are not dropped. A still
        object whose outline is round in no view (``rounded``) is no ball either.
        ``calm`` (a white or grey target's; per object): nothing in its disc changed lately in any view (motion.
        BackgroundModel.changed). Such a ball's shading keeps it in the moving map at rest, and ``still`` never holds;
        away from every ball that has travelled, it must show a round outline in some view (``rounded``, re-centred). A
        white table's corner or shelf board, shaded like a ball, does not: 0.17-0.42 where resting balls read 0.69 or
        more in the view that shows them best (white_ball tune seeds 0-119: seed 89, a false track for 70 frames)."""
        out = np.zeros(len(objects), bool)
        for k, o in enumerate(objects):
            if (np.linalg.norm(travelled - o.position, axis=1) < 2 * self.radius).any():
                continue
            if still(o.position, self.radius, views):
                out[k] = self._scenery(o.position, views, images, now)
            if not out[k] and calm is not None and calm[k]:
                out[k] = not rounded(o.position, self.radius, self.cameras, images, recentre=True)
        return out

    def _scenery(self, position: np.ndarray, views: Sequence[CameraEvidence], images: Sequence[np.ndarray], now: float) -> bool:
        """A still object: (``shapes``) no ball's shape, flat or round in no view; else (unless a whole ball) a patch of
        the surface it is seen on."""
        if self.shapes and (
            not self._shows_as_ball(position, views, images)
            or flat(position, self.radius, self.cameras, images, self.colour)
            or not rounded(position, self.radius, self.cameras, images)
        ):
            return True
        if self.shapes and whole_ball(position, self.radius, self.cameras, views, images):
            return False
        return self.on_surface(position, images, now)

    def _shows_as_ball(self, position: np.ndarray, views: Sequence[CameraEvidence], images: Sequence[np.ndarray]) -> bool:
        """A disc of a ball's size in some view and at no bar's end in any (``ball_shaped``, ``in_bar``), or its outline all
        round before things of its colour (``rimmed``)."""
        shaped = ball_shaped(position, self.radius, views) and not in_bar(position, self.radius, views)
        return shaped or self._rimmed(position, images)

    def _rimmed(self, position: np.ndarray, images: Sequence[np.ndarray]) -> bool:
        """``rimmed``, with the target's range (none given: never)."""
        return self.colour is not None and rimmed(position, self.radius, self.cameras, images, self.colour)

    def on_surface(self, position: np.ndarray, images: Sequence[np.ndarray], now: float) -> bool:
        """``on_surface`` for a still thing at ``position``, or the verdict given at its spot in the last VERDICT_SECONDS."""
        fresh = (now - self.times <= VERDICT_SECONDS) & (now >= self.times)
        self.spots, self.verdicts, self.times = self.spots[fresh], self.verdicts[fresh], self.times[fresh]
        near = np.flatnonzero(np.linalg.norm(self.spots - position, axis=1) < SAME_SPOT * self.radius)
        if len(near):
            return bool(self.verdicts[near[0]])
        verdict = on_surface(position, self.radius, self.cameras, images)
        self.spots = np.vstack([self.spots, position])
        self.verdicts, self.times = np.r_[self.verdicts, verdict], np.r_[self.times, now]
        return verdict
