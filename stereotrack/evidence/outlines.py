"""A ball's outline in the image, and a ball at rest that one view buries in its own colour, found by it.

``round_rims`` asks the image itself, not a mask, whether a circle about a
ball's size has an edge crossing it radially all round: a ball's rim does,
wherever what lies behind it differs from it; a square's sides do in about
half the directions (objects/surface.py drops still things by it).

A white ball at rest before a white wall (or a ball before a wall of its hue)
can show in one view as a patch or disc of its own and in the other inside a
region of its colour: its ring is full there, so no particle on it scores,
nothing moves, and its shading's patch joins what stands beside it. It was
never found (white_ball tune seeds 34 and 103; hue_wall 16 and 3051: each a
ball at rest for the whole scene). The tracker searches for white or grey
targets only: a coloured target's larger balls showed round outlines of its
size too (pipeline/tracker.py). Its outline still shows in that view:
along the viewing ray of the disc, at the depths where the disc is about as
wide as the ball, the outline in the other view is round at one depth only,
the ball's (0.8-1.0 there, at most 0.6 a few pixels of disparity away).
``buried_partners`` looks for that depth and ``held_discs`` keeps a ball so
found; ``OutlineFinder`` picks the discs to ask frame after frame, and
``marked`` puts what it found into a camera's maps: the disc moves, and its
ring leaves the range. A disc that moves is not judged as a still object is
(objects/surface.py), so the finder asks the tracker's judge before it keeps
one: a knob on a door is round in both views too.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from ..camera import Camera
from .gather import CameraEvidence
from .kernels import rim_shares
from .motion import SCALE
from .stereo_patches import same_ball


@dataclass(frozen=True, eq=False)
class Find:
    """A ball found by its outline: its centre, and its disc in each camera that shows it."""

    point: np.ndarray  # 3, metres
    discs: tuple  # of (camera index, np.ndarray([u, v, r]) in its pixels)


def per_camera(finds: Sequence[Find], n: int) -> list[np.ndarray]:
    """The discs of ``finds`` per camera (``n`` of them): K x 3 arrays (u, v, r)."""
    out: list[list[np.ndarray]] = [[] for _ in range(n)]
    for find in finds:
        for j, disc in find.discs:
            out[j].append(disc)
    return [np.array(d).reshape(-1, 3) for d in out]


# round_rims: an edge crossing one circle about the ball's apparent size (OUTLINE_SCALES of it: its depth and centre are
# an estimate's) radially, OUTLINE_EDGE levels per pixel or more in some channel and within 22.5 degrees of the circle's
# normal, in OUTLINE_ANGLES directions from its centre (a direction counts where the circle next larger or smaller shows
# it too).
OUTLINE_ANGLES = 48
OUTLINE_SCALES = np.arange(0.7, 1.41, 0.05)
OUTLINE_EDGE = 6.0
# A view that shows it smaller says nothing: its circles span a few pixels, and a thing's corners pass for a rim (a book's
# end at 4.9 m, 3.6 pixels in radius: 0.77-0.88 in both views, hue_wall seed 147).
OUTLINE_MIN_PX = 5.0
_OUTLINE_TAN = np.tan(np.pi / 8)  # the gradient within 22.5 degrees of radial: its tangential part at most this of its radial
_OUTLINE_DIRECTIONS = np.stack([np.cos(a := np.linspace(0.0, 2 * np.pi, OUTLINE_ANGLES, endpoint=False)), np.sin(a)], axis=-1)

# buried_partners: a disc's depths are those where a ball would look WIDTH_RATIO times as wide as the disc or less, either
# way (the disc's radius is its blob's, cut by what stands before it or by the colour model's speckle)...
WIDTH_RATIO = 1.5
# ... where it would look FIND_MIN_PX or more in radius in both views: on smaller circles the corners of a shelf's books pass
# for a rim (hue_wall tune seeds 64, 106: false tracks at 5.4-6.8 pixels, 0.79-0.88 round in both views; the balls at
# rest found so, 7.6 pixels or more)...
FIND_MIN_PX = 7.0
# ... sampled so that the partner moves STEP_PX pixels or less in the other view from one depth to the next (its outline
# peaks within a pixel or two of disparity), at most MAX_STEPS depths
STEP_PX = 1.0
MAX_STEPS = 400
# ... and both outlines must be round (round_rims) there: the partner's in the other view FOUND_SHARE or more, the disc's
# own at the ball's size for that depth OWN_SHARE or more (the disc is a blob already; a white ball before a pale floor
# shows a weaker rim: 0.69-0.75 at white_ball tune seed 103, a ball at rest never found).
FOUND_SHARE = 0.8
OWN_SHARE = 0.65
# The partner is one: every depth whose outlines pass lies within its apparent radius of the best's in the other view (two
# round things on one epipolar line are no answer), and its core (CORE of its radius) is CORE_IN_RANGE or more in the
# target's range there.
CORE, CORE_IN_RANGE = 0.7, 0.5
# A disc's centre is looked for within this many pixels of its blob's (centred)
CENTRE_PX = 2
# A tracked ball is looked for again between its distance along a view's ray over and times this (held_discs)
HELD_RANGE = 1.15


def round_rims(image: np.ndarray, centres: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """Per circle (``centres`` K x 2 pixels, ``radii`` K), the share of OUTLINE_ANGLES directions from its centre in
    which an edge of ``image`` (OUTLINE_EDGE levels per pixel or more in some channel, Sobel) crosses a circle of
    OUTLINE_SCALES x its radius radially, at the one such circle (or the circles either side of it) where most do: 1
    for a ball's outline all round, at most about a half for a square's. Samples off the image count as no edge. The
    image's gradient is made once, over the box holding every sample."""
    centres = np.asarray(centres, float).reshape(-1, 2)
    radii = np.asarray(radii, float).reshape(-1)
    if not len(centres):
        return np.zeros(0)
    h, w = image.shape[:2]
    # the box of every circle, two pixels more each way (a sample rounds to the nearest pixel, and Sobel's 3 x 3 reads
    # beyond it); inside the image the gradient is the same as the whole image's
    reach = np.maximum(OUTLINE_SCALES[-1] * radii, 1.5) + 2
    x0, y0 = max(int(np.floor((centres[:, 0] - reach).min())), 0), max(int(np.floor((centres[:, 1] - reach).min())), 0)
    x1, y1 = min(int(np.ceil((centres[:, 0] + reach).max())) + 1, w), min(int(np.ceil((centres[:, 1] + reach).max())) + 1, h)
    if x1 - x0 < 1 or y1 - y0 < 1:
        return np.zeros(len(centres))
    patch = image[y0:y1, x0:x1].astype(np.float32)
    # per channel: a blue ball on a brown floor differs from it in colour, hardly in grey (hue_wall seed 3005)
    gx, gy = cv2.Sobel(patch, cv2.CV_32F, 1, 0, ksize=3) / 8.0, cv2.Sobel(patch, cv2.CV_32F, 0, 1, ksize=3) / 8.0
    if patch.ndim == 2:
        gx, gy = gx[..., None], gy[..., None]
    return rim_shares(gx, gy, centres - (x0, y0), radii, OUTLINE_SCALES, _OUTLINE_DIRECTIONS, OUTLINE_EDGE, _OUTLINE_TAN)


def round_rim(image: np.ndarray, centre: np.ndarray, r: float) -> float:
    """``round_rims`` of one circle."""
    return float(round_rims(image, np.asarray(centre, float)[None], np.array([r]))[0])


def buried_partners(
    discs: Sequence[np.ndarray],
    images: Sequence[np.ndarray],
    cameras: Sequence[Camera],
    in_range: Sequence[np.ndarray],
    radius: float,
    d_min: float,
    d_max: float,
    judge: Callable[[np.ndarray], bool] | None = None,
) -> list[Find]:
    """The balls found by their outlines (Find: centre and discs, u, v, r in each camera's pixels): for each of the ``discs``
    seen in a camera (M x 3: centre and radius, its pixels), the one depth along its viewing ray, between ``d_min``
    and ``d_max`` metres and where a ball of ``radius`` metres would look about as wide (WIDTH_RATIO), at which another
    camera shows a round outline of the ball's size (FOUND_SHARE) and the disc's own outline is round at that size too
    (OWN_SHARE), whose core is in the target's colour there (``in_range``: each camera's range mask, uint8 0/1, on a grid
    a whole number of times coarser than its ``images``), and that ``judge`` (a point, 3) does not call a thing: two
    views agree on any real thing, and a knob on a door or a pale square on a poster is round in both. Both discs are
    given, the seen one at the ball's size."""
    finds: list[Find] = []
    for i, cam in enumerate(cameras):
        for u, v, width in np.asarray(discs[i], float).reshape(-1, 3):
            if width < FIND_MIN_PX / WIDTH_RATIO:
                continue
            u, v, share = centred(images[i], u, v, width)
            if share < OWN_SHARE:  # its own outline is no ball's at its own width: no depth will make it one
                continue
            origin, direction = (a[0] for a in cam.rays(np.array([[u, v]])))
            z1 = cam.view((origin + direction)[None])[2][0]  # depth (z) per metre along the ray
            near = max(d_min, cam.focal_px * radius / (WIDTH_RATIO * width))
            far = min(d_max, cam.focal_px * radius * WIDTH_RATIO / width)
            if z1 <= 0 or near >= far:
                continue
            for j, other in enumerate(cameras):
                if j == i:
                    continue
                hit = _partner(images[i], images[j], cam, other, in_range[j], origin, direction, near / z1, far / z1, (u, v), radius)
                if hit is not None and not (judge is not None and judge(hit[2])):
                    finds.append(Find(hit[2], ((i, np.array([u, v, hit[0]])), (j, hit[1]))))
    return finds


def held_discs(
    points: np.ndarray, images: Sequence[np.ndarray], cameras: Sequence[Camera], in_range: Sequence[np.ndarray], radius: float
) -> list[Find]:
    """The balls tracked at ``points`` (P x 3) found again (Find) as
    buried_partners finds them, from a view that shows a round outline of their size near where they project (centred)
    and within HELD_RANGE of their distance along its ray: a ball found by its outline stays found, whatever the colour
    model since learnt of it (hue_wall seed 3051: once its track had taught the model its colours, the wall behind it
    took them too, and its disc was no seed of its own); and where it rolls away, its depth follows it (white_ball tune
    seed 145: discs drawn where the track was held it there while the ball rolled 11 cm away from the cameras)."""
    finds: list[Find] = []
    for point in np.asarray(points, float).reshape(-1, 3):
        shown = []  # (share, view, centre) of each view where the ball's outline is round enough
        for j, (cam, image) in enumerate(zip(cameras, images)):
            uv, front, depth = cam.view(point[None])
            r = float(cam.apparent_radius(radius, depth)[0])
            h, w = image.shape[:2]
            if front[0] and r >= OUTLINE_MIN_PX and 0 <= uv[0, 0] < w and 0 <= uv[0, 1] < h:
                u, v, share = centred(image, uv[0, 0], uv[0, 1], r)
                if share >= OWN_SHARE:
                    shown.append((share, j, (u, v)))
        for _, i, (u, v) in sorted(shown):  # from the weakest view: the other must show it FOUND_SHARE
            cam = cameras[i]
            origin, direction = (a[0] for a in cam.rays(np.array([[u, v]])))
            along = float(np.dot(point - origin, direction))
            near, far = along / HELD_RANGE, along * HELD_RANGE
            hits = [
                (j, _partner(images[i], images[j], cam, cameras[j], in_range[j], origin, direction, near, far, (u, v), radius, False))
                for _, j, _ in shown
                if j != i
            ]
            hits = [(j, hit) for j, hit in hits if hit is not None]
            if hits:
                finds.append(Find(hits[0][1][2], ((i, np.array([u, v, hits[0][1][0]])), *((j, hit[1]) for j, hit in hits))))
                break
    return finds


def centred(image: np.ndarray, u: float, v: float, width: float) -> tuple[float, float, float]:
    """The centre within CENTRE_PX pixels of (``u``, ``v``) where a circle ``width`` wide is roundest (round_rims), and
    its share: a blob's centroid is a grid's (the shading's is on the background's, two pixels a cell), its outline's is
    the ball's."""
    offsets = np.arange(-CENTRE_PX, CENTRE_PX + 1, dtype=float)
    centres = np.stack(np.meshgrid(u + offsets, v + offsets), axis=-1).reshape(-1, 2)
    shares = round_rims(image, centres, np.full(len(centres), width))
    best = np.flatnonzero(shares == shares.max())
    k = best[np.argmin(np.linalg.norm(centres[best] - (u, v), axis=1))]  # the nearest of equals
    return float(centres[k, 0]), float(centres[k, 1]), float(shares[k])


def _partner(image, other_image, cam, other, in_range, origin, direction, s_near, s_far, uv, radius, find=True):
    """(the ball's radius in ``cam``, its disc u, v, r in ``other``, its centre) where ``other`` shows the partner of the disc
    at ``uv`` along its ray between ``s_near`` and ``s_far`` metres (buried_partners), or None. ``find`` False: a tracked
    ball's (held_discs), OUTLINE_MIN_PX in radius or more in both views, not FIND_MIN_PX."""
    ends, front, _ = other.view(origin + np.array([s_near, s_far])[:, None] * direction)
    if not front.all():
        return None
    steps = int(min(max(np.ceil(np.linalg.norm(ends[1] - ends[0]) / STEP_PX) + 1, 2), MAX_STEPS))
    s = 1.0 / np.linspace(1.0 / s_near, 1.0 / s_far, steps)  # even steps of disparity
    points = origin + s[:, None] * direction
    there, front, depth = other.view(points)
    r_there = other.apparent_radius(radius, depth)
    r_here = cam.apparent_radius(radius, cam.view(points)[2])
    h, w = other_image.shape[:2]
    least = FIND_MIN_PX if find else OUTLINE_MIN_PX
    ok = front & (r_there >= least) & (r_here >= least) & (there[:, 0] >= 0) & (there[:, 0] < w) & (there[:, 1] >= 0) & (there[:, 1] < h)
    if not ok.any():
        return None
    here_share = round_rims(image, np.broadcast_to(np.asarray(uv, float), (int(ok.sum()), 2)), r_here[ok])
    there_share = round_rims(other_image, there[ok], r_there[ok])
    passes = (here_share >= OWN_SHARE) & (there_share >= FOUND_SHARE)
    if not passes.any():
        return None
    k = np.flatnonzero(passes)[np.argmax(there_share[passes] + here_share[passes])]
    best, r = there[ok][k], r_there[ok][k]
    if np.linalg.norm(there[ok][passes] - best, axis=1).max() > r:
        return None  # two round things on the line
    if _core_in_range(in_range, best, r, w) < CORE_IN_RANGE:
        return None
    return float(r_here[ok][k]), np.array([best[0], best[1], r]), points[ok][k]


def _core_in_range(in_range: np.ndarray, centre: np.ndarray, r: float, image_width: int) -> float:
    """The share of the disc of CORE x ``r`` round ``centre`` (image pixels) in the range mask (on a grid
    image_width / its width times coarser)."""
    k = image_width / in_range.shape[1]
    (u, v), rr = (np.asarray(centre) - 0.5 * (k - 1)) / k, max(CORE * r / k, 0.5)
    x0, x1 = max(int(np.floor(u - rr)), 0), min(int(np.ceil(u + rr)) + 1, in_range.shape[1])
    y0, y1 = max(int(np.floor(v - rr)), 0), min(int(np.ceil(v + rr)) + 1, in_range.shape[0])
    if x1 <= x0 or y1 <= y0:
        return 0.0
    ys, xs = np.mgrid[y0:y1, x0:x1]
    core = (xs - u) ** 2 + (ys - v) ** 2 <= rr * rr
    return float(in_range[y0:y1, x0:x1][core].mean()) if core.any() else 0.0


# OutlineFinder: a seed with STILL_SHARE of its disc's box in the foreground or more moves (the moving map shows it), and is
# not looked for; of the still ones, the widest BURIED_MOST per camera (1-2 ms each at 640x480) ...
STILL_SHARE = 0.5
BURIED_MOST = 6
# ... that no other camera shows as the same ball: a seed there within PAIR_PX pixels (and a share of their radii) of the
# point they triangulate to (stereo_patches.same_ball).
PAIR_PX = 2.0
# A ball found is kept only where one was found within HELD_GAP ball radii in the RECENT frames before, and a confirmed
# track that near is held (held_discs) while it is still.
HELD_GAP = 2.0
RECENT = 3
# marked: the half-side of the box, in ball radii, whose ring round a ball found so is taken out of the range
# (ball_shape.OUTER: the ring the likelihood reads), where RING_BURIED or more of that ring is in the range
RING = 1.8
RING_BURIED = 0.25


class OutlineFinder:
    """One target's balls that one view buries in their colour, found by their outlines (buried_partners, held_discs),
    frame after frame: where it looks, and the balls it found the frames before (a track there is held)."""

    def __init__(self, cameras: Sequence[Camera], scales: Sequence[int], target, settings):
        self.cameras, self.scales, self.target = list(cameras), list(scales), target
        self.d_min, self.d_max = settings.d_min, settings.d_max
        self.recent: deque[np.ndarray] = deque(maxlen=RECENT)  # the balls' centres found in each of the RECENT frames before

    def __call__(
        self,
        views: Sequence[CameraEvidence],
        in_range: Sequence[np.ndarray],
        foregrounds: Sequence[np.ndarray | None],
        images: Sequence[np.ndarray],
        tracked: np.ndarray,
        judge: Callable[[np.ndarray], bool] | None = None,
    ) -> list[np.ndarray]:
        """Per camera, the discs (K x 3: u, v, r in image pixels) of the balls found this frame: from the still seeds of
        ``views`` that no other camera shows as the same ball, and from the confirmed tracks (``tracked``, P x 3) at balls
        found so the frames before; only where one was found in the RECENT frames before. ``foregrounds``: each camera's
        (motion.py, on the background's grid); ``judge`` as buried_partners takes it."""
        t = self.target
        seeds = [_seed_discs(view, k) for view, k in zip(views, self.scales)]
        discs = [self._unpartnered(i, d, seeds, fg) for i, (d, fg) in enumerate(zip(seeds, foregrounds))]
        before = np.vstack([np.zeros((0, 3)), *self.recent])
        near = [len(before) > 0 and np.linalg.norm(before - c, axis=1).min() < HELD_GAP * t.radius for c in tracked]
        still = tracked[[n and self._still_in_every_view(c, foregrounds) for n, c in zip(near, tracked)]].reshape(-1, 3)
        if sum(len(d) for d in discs) == 0 and not len(still):
            self.recent.append(np.zeros((0, 3)))
            return [np.zeros((0, 3)) for _ in self.cameras]
        finds = buried_partners(discs, images, self.cameras, in_range, t.radius, self.d_min, self.d_max, judge)
        finds += held_discs(still, images, self.cameras, in_range, t.radius) if len(still) else []  # a ball found so stays found
        self.recent.append(np.array([f.point for f in finds]).reshape(-1, 3))
        # a ball at rest is found frame after frame (most frames): one found in no frame of the RECENT before is a fluke
        # of clutter (a shelf of books: hue_wall tune seed 84, finds in single frames that seeded a false track for 37 frames)
        again = [f for f in finds if len(before) and np.linalg.norm(before - f.point, axis=1).min() < HELD_GAP * t.radius]
        return per_camera(again, len(self.cameras))

    def _unpartnered(self, i: int, discs: np.ndarray, seeds: list, foreground: np.ndarray | None) -> np.ndarray:
        """The ``discs`` of camera i (M x 3, image pixels) that do not move (``foreground``: camera i's) and that no other
        camera's ``seeds`` show as the same ball (stereo_patches.same_ball), the widest BURIED_MOST."""
        cams, t = self.cameras, self.target
        discs = discs[_still(discs, foreground, self.scales[i])]
        for j in range(len(cams)):
            if j == i or not len(discs) or not len(seeds[j]):
                continue
            a, b = (g.ravel() for g in np.meshgrid(np.arange(len(discs)), np.arange(len(seeds[j])), indexing="ij"))
            di, dj = discs[a], seeds[j][b]
            ok, _ = same_ball(cams[i], cams[j], di[:, :2], di[:, 2], dj[:, :2], dj[:, 2], t.radius, self.d_min, self.d_max, PAIR_PX)
            discs = discs[~np.isin(np.arange(len(discs)), a[ok])]
        return discs[np.argsort(-discs[:, 2], kind="stable")[:BURIED_MOST]]

    def _still_in_every_view(self, point: np.ndarray, foregrounds: Sequence[np.ndarray | None]) -> bool:
        """Does a ball at ``point`` move in no view (its disc under STILL_SHARE in each camera's foreground)?"""
        for cam, k, foreground in zip(self.cameras, self.scales, foregrounds):
            uv, front, depth = cam.view(point[None])
            disc = np.array([[uv[0, 0], uv[0, 1], cam.apparent_radius(self.target.radius, depth[0])]])
            if front[0] and not _still(disc, foreground, k)[0]:
                return False
        return True


def marked(moving: np.ndarray, in_range: np.ndarray, discs: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Copies of a camera's ``moving`` map (on the background's grid) and range mask (on its evidence grid, ``k`` image
    pixels a side) with balls found by their outlines (``discs``, K x 3 image pixels) marked: each disc moves (where the
    room holds the ball's colour, the colour model may keep a speckle of it), and the ring the likelihood reads round it
    is out of the range where RING_BURIED or more of it is in it (its outline parts it from what is behind; a view whose
    ring is clean shows the ball apart already, and a neighbour stays whole)."""
    moving, carved = moving.copy(), in_range.copy()
    for u, v, r in discs:  # evidence pixel e is image pixel k e; the background's cell c, evidence pixels 2c and 2c + 1
        centre = (int(round(16 * (u / k - 0.5) / SCALE)), int(round(16 * (v / k - 0.5) / SCALE)))  # 4 bits of fraction
        cv2.circle(moving, centre, max(int(round(16 * r / (k * SCALE))), 8), 1, -1, cv2.LINE_8, 4)
        x0, y0 = (max(int(round((c - RING * r) / k)), 0) for c in (u, v))
        box = carved[y0 : int(round((v + RING * r) / k)) + 1, x0 : int(round((u + RING * r) / k)) + 1]  # a view: carved in place
        if not box.size:
            continue
        ring = np.ones_like(box)
        cv2.circle(ring, (int(round(16 * u / k)) - 16 * x0, int(round(16 * v / k)) - 16 * y0), int(round(16 * r / k)), 0, -1, cv2.LINE_8, 4)
        if cv2.countNonZero(cv2.bitwise_and(ring, box)) >= RING_BURIED * cv2.countNonZero(ring):
            box[ring > 0] = 0
    return moving, carved


def _seed_discs(view: CameraEvidence, k: int) -> np.ndarray:
    """A view's seeds as discs (M x 3: centre and the radius of the ball each would be, image pixels; ``k``: image pixels
    per evidence pixel)."""
    seeds = view.proposal_seeds()
    widths = seeds.widths if seeds.widths is not None else seeds.radii
    return np.column_stack([seeds.centres * k, widths * k]).reshape(-1, 3)


def _still(discs: np.ndarray, foreground: np.ndarray | None, k: int) -> np.ndarray:
    """Which discs (image pixels; ``k`` image pixels per evidence pixel) do not move, under STILL_SHARE of their box in the
    ``foreground`` (on the background's grid), and are OUTLINE_MIN_PX / WIDTH_RATIO or more in radius: bool."""
    if foreground is None:
        return np.zeros(len(discs), bool)
    cell = k * SCALE
    wide = discs[:, 2] >= OUTLINE_MIN_PX / WIDTH_RATIO
    return wide & np.array([_share_in(foreground, u / cell, v / cell, r / cell) < STILL_SHARE for u, v, r in discs], bool).reshape(-1)


def _share_in(cells: np.ndarray, u: float, v: float, r: float) -> float:
    """The share of the box round a disc (centre ``u``, ``v``, radius ``r``, in cells) that is set in ``cells`` (0/1)."""
    h, w = cells.shape
    x0, x1 = max(int(u - r), 0), min(int(np.ceil(u + r)) + 1, w)
    y0, y1 = max(int(v - r), 0), min(int(np.ceil(v + r)) + 1, h)
    return float(cells[y0:y1, x0:x1].mean()) if x1 > x0 and y1 > y0 else 0.0
