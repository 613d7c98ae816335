"""Objects must explain colour blobs: drop stereo ghosts and duplicates, refine positions.

With several balls of one colour, the particle filter also finds *ghosts*:
points whose projection lands on ball A in one camera and on ball B in the
other (the same ambiguity that makes epipolar matching of same-coloured
blobs fail). Eq. 14 scores a ghost as high as a ball. This stage looks at
which blob each object projects into in every camera and how large that blob
is compared with a ball of the known radius at the object's depth:

- clusters that see the same blob in every camera are merged (EM cuts one
  ball's depth-elongated particle cloud into pieces);
- objects are ranked by mass x size consistency (a ghost sits at the wrong
  depth, so its expected apparent size disagrees with its blobs), with a
  bonus for lying where a confirmed track predicts a ball;
- in that order an object is kept if it explains at least one blob that no
  kept object explains yet; otherwise every blob it sees is already
  accounted for (a ghost or a duplicate cluster) and it is dropped;
- a kept object that alone explains a blob of consistent size in every
  camera gets the triangulated blob centroids as its position (the particle
  mean is biased by the shape of the ball's likelihood plateau; centroids
  are not). With one such view, its ray fixes the direction; the depth comes
  from the particles, or, when the other view's blob is shared with another
  ball, from where along the ray this ball's disc and the other balls'
  discs best make up the shared blob (discs.py; the particles' mean is
  biased towards the other ball). Where the shared blob says little (a ball
  wholly hidden behind a nearer one) and the particles spread wide along the
  ray, the ball's track decides. A blob that does not fill the disc its
  larger side spans is a ball seen in part (something in front of it, the
  image's edge) and not clean either; with one clean view, the depth is
  where the ball's disc in the partial view holds every part that shows
  (discs.partial_mismatch: the particles' mean is biased towards the
  largest visible part). Otherwise (occlusion in every view) it keeps the
  particle mean.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from ..camera import triangulate_with_covariance
from ..config import TrackerSettings
from ..evidence.blobs import short_streaks
from ..evidence.colour import box_counts
from ..evidence.gather import CameraEvidence
from ..results import Object3D, TrackedBalls
from .discs import PARTIAL_LEAST_SEEN, PARTIAL_MOST_AROUND, RayFit, depth_on_ray, partial_mismatch, same_disc, union_mismatch
from .kernels import blob_signature
from .shapes import (
    CENTROID_SIGMA_PX,
    STREAK_LONGER,
    _blurred,
    _centres,
    _centroid_covs,
    _cut_short,
    _long,
    _slack,
    _streaks_may_be_thin,
    _whole,
)


@dataclass(frozen=True)
class ExplainSettings:
    """What explain-away needs of the tracker's settings (config.TrackerSettings) for one target: defaults are theirs."""

    radius: float  # ball radius, metres
    refine: bool = TrackerSettings.refine
    disc_fit: bool = TrackerSettings.disc_fit  # place a ball in a shared blob by fitting the union of ball discs to it
    # A short blur (blobs.short_streaks) counts as a streak. Not for a target of every hue (white, grey): its moving map takes
    # the ball's shaded side and a slow ball's trail (colour.motion_range), which stretch a ball's blob as a blur would
    # (white_ball tune seeds 0-19 with short blurs: median 0.837 -> 0.797, seeds 1, 6, 7, 18 down 0.06-0.12).
    short_streaks: bool = True
    # A ball's blob that does not fill its disc is a ball seen in part (discs.partial_mismatch). Not for a target of every
    # hue either: its shaded side is out of its range, so its blob is a crescent wherever it is (white_ball tune seeds
    # 0-19 with the partial-view fit: median 0.837 -> 0.806, seeds 5, 8, 18 down 0.07-0.16).
    partial_views: bool = True

    @classmethod
    def of(cls, tracker: TrackerSettings, radius: float, short_streaks: bool = True, partial_views: bool = True) -> ExplainSettings:
        return cls(radius, tracker.refine, tracker.disc_fit, short_streaks, partial_views)


SIZE_TOLERANCE = 0.3  # sigma of log(blob radius / expected radius) in the ranking
REFINE_TOLERANCE = 0.3  # |log size ratio| below this in a camera makes its blob clean enough to refine with
TRACK_BONUS = 3.0  # rank multiplier for objects a confirmed track predicts
ONE_VIEW_DEPTH_SIGMA = 0.07  # metres: how little the particles say about depth when only one view is clean (far: _two_view_depth_floor)
DISC_FIT_TOLERANCE = 0.05  # pixels of mismatch that make a depth e times less likely, as a share of the ball's disc area
DISC_FIT_SIGMA = 0.01  # metres: the least depth uncertainty a disc fit claims
PARTIAL_DEPTHS = (0.75, 1.35)  # a partly seen view's fit searches these multiples of the particles' depth ...
PARTIAL_PRIOR = 0.15  # ... under a prior this wide, as a share of that depth
PARTIAL_PIXEL = 1.0  # pixels: how far off the partial views' discs may be; the fit claims no less depth error than this
PARTIAL_TOLERANCE = 0.01  # pixels of its mismatch that make a depth e times less likely, as a share of the disc's area


_NO_LABELS, _NO_LABEL_BLOB = np.zeros((1, 1), np.int32), np.full(1, -1)
_DEPTH_STEPS = np.linspace(0.0, 1.0, 41)  # the disc fit's candidate depths, spread over its search range
_PARTIAL_STEPS = np.linspace(0.0, 1.0, 121)  # the partial-view fit's: a step of 0.5 % of the depth, a pixel of disparity at 2 m


def _merge(objs: Sequence[Object3D]) -> Object3D:
    """One object from clusters that see the same blobs: mass-weighted mixture of them."""
    if len(objs) == 1:
        return objs[0]
    m = np.array([o.mass for o in objs])
    mu = np.array([o.position for o in objs])
    total = m.sum()
    mean = m @ mu / total
    d = mu - mean
    cov = (sum(mi * o.covariance for mi, o in zip(m, objs)) + (m[:, None] * d).T @ d) / total
    return Object3D(objs[0].target, mean, cov, float(total), int(sum(o.n_particles for o in objs)))


def _signatures(positions: np.ndarray, cameras, blobs, radius) -> tuple[np.ndarray, np.ndarray]:
    """Per object and camera: the blob it sees (its label there, else the nearest blob whose disc reaches
    it; -1: none) and log(blob radius / expected radius)."""
    k, c = len(positions), len(cameras)
    ids = np.full((k, c), -1)
    log_ratio = np.full((k, c), np.nan)
    if k == 0:
        return ids, log_ratio
    positions = np.ascontiguousarray(positions, dtype=float)
    for j, (cam, b) in enumerate(zip(cameras, blobs)):
        if len(b) == 0:
            continue
        if b.labels is None:  # the histogram blob finder: nearest blob only
            labels, label_blob, use_labels = _NO_LABELS, _NO_LABEL_BLOB, False
        else:
            labels, label_blob, use_labels = b.labels, b.label_blob, True
        ids[:, j], log_ratio[:, j] = blob_signature(
            positions, *cam._kernel_arrays, radius, cam.width, cam.height, labels, label_blob, b.label_scale, use_labels, b.centres, b.radii
        )
    return ids, log_ratio


def _rank(objects: Sequence[Object3D], log_ratio: np.ndarray, settings: ExplainSettings, predicted: np.ndarray | None) -> np.ndarray:
    """mass x size consistency, with a bonus where a confirmed track predicts a ball."""
    squares = (log_ratio / SIZE_TOLERANCE) ** 2
    consistency = np.exp(-0.5 * np.where(np.isnan(squares), 0.0, squares).sum(axis=1))  # (np.nansum, without its copies)
    score = np.array([o.mass for o in objects]) * np.maximum(consistency, 1e-3)
    if predicted is not None and len(predicted):
        pos = np.array([o.position for o in objects])
        near = (np.linalg.norm(pos[:, None] - predicted[None], axis=2) < 2 * settings.radius).any(axis=1)
        score = np.where(near, score * TRACK_BONUS, score)
    return score


def explain(
    objects: Sequence[Object3D],
    views: Sequence[CameraEvidence],
    settings: ExplainSettings,
    predicted: TrackedBalls | None = None,
    occluders: TrackedBalls | None = None,
) -> tuple[list[Object3D], np.ndarray]:
    """Keep the objects that explain blobs of this target's evidence (``views``, one per camera).

    ``predicted``: the tracked balls of this colour (where tracks expect
    balls); ``occluders``: tracked balls of other colours, whose discs hide
    part of a ball behind them. Returns (kept objects, index of the kept
    object each input object went into, or -1 if it was dropped).
    """
    cameras, blobs = [v.camera for v in views], [v.blobs for v in views]
    predicted = predicted.centres if predicted is not None else None
    occluders = (occluders.centres, occluders.radii) if occluders is not None else None
    into = np.full(len(objects), -1)
    if not objects:
        return [], into
    # Clusters that see the same blobs in every camera are one ball: EM cut its cloud (long along
    # the viewing direction, longer still where two balls merge into one blob) into pieces.
    groups: dict[tuple[int, ...], list[int]] = {}
    ids, first_ratio = _signatures(np.array([o.position for o in objects]), cameras, blobs, settings.radius)
    for i, sig in enumerate(map(tuple, ids.tolist())):
        if any(k >= 0 for k in sig):
            groups.setdefault(sig, []).append(i)
    merged, members, blob_ids = [], [], []
    for sig, idx in groups.items():
        merged.append(_merge([objects[i] for i in idx]))
        members.append(idx)
        blob_ids.append(sig)
    if not merged:
        return [], into
    blob_ids = np.array(blob_ids)
    if all(len(idx) == 1 for idx in members):  # nothing merged: the sizes are those measured above
        log_ratio = first_ratio[[idx[0] for idx in members]]
    else:
        _, log_ratio = _signatures(np.array([o.position for o in merged]), cameras, blobs, settings.radius)
    score = _rank(merged, log_ratio, settings, predicted)
    c = len(cameras)
    used: set[tuple[int, int]] = set()
    kept: list[int] = []
    for i in np.argsort(-score, kind="stable"):
        seen = {(j, int(blob_ids[i, j])) for j in range(c) if blob_ids[i, j] >= 0}
        if seen <= used:
            continue  # every blob it sees belongs to a stronger object: a stereo ghost
        used |= seen
        kept.append(int(i))
    kept.sort()
    for n, i in enumerate(kept):
        into[members[i]] = n
    out = [merged[i] for i in kept]
    if settings.refine:
        hidden = _partly_hidden(np.array([merged[i].position for i in kept]), cameras, settings.radius, occluders)
        swept = _paired(*_swept(views, predicted, settings.radius, settings.short_streaks), blob_ids[kept])
        out = _refine_all(merged, kept, blob_ids, log_ratio, hidden, views, settings, predicted, swept)
    return _pieces_joined(out, into, blob_ids[kept], score[kept], cameras, blobs, settings.radius)


# Two blobs of their own are pieces of one ball when their centroids lie closer than this many of its apparent radii: a
# ball's halves cut apart by a band a third of its radius wide lie 1.1 radii apart, two balls' blobs two or more.
PIECES_APART = 1.5
PIECES_FILL = 1.5  # (a ball's moving blob is of the background's 2 x 2 cells and its rim's spread: more than its disc)


def _pieces_joined(objects: list[Object3D], into: np.ndarray, blob_ids: np.ndarray, score: np.ndarray, cameras, blobs, radius: float):
    """Kept objects whose blobs are pieces of one ball, joined into one (``objects`` and ``into`` as ``explain`` returns
    them, ``blob_ids`` and ``score`` theirs). Two balls' blobs of their own lie a disc or more apart (a ball in front of
    another makes one blob of both); two blobs whose centroids lie within PIECES_APART of the stronger object's apparent
    radius of each other in every camera that sees both, two cameras or more, are one ball cut in pieces (a white ball's band whose
    shade is the wall's, white_ball tune seeds 91, 223, 233: two tracks on one ball). The joined ball lies between the
    two, weighted by their blobs' areas, as the centroid of their union would put it."""
    k = len(objects)
    if k < 2:
        return objects, into
    centres = np.full((k, len(cameras), 2), np.nan)
    areas = np.zeros((k, len(cameras)))
    radius_px = np.full((k, len(cameras)), np.nan)
    positions = np.array([o.position for o in objects])
    for j, (cam, b) in enumerate(zip(cameras, blobs)):
        seen = blob_ids[:, j] >= 0
        centres[seen, j] = b.centres[blob_ids[seen, j]]
        areas[seen, j] = b.areas[blob_ids[seen, j]]
        _, front, z = cam.view(positions)
        radius_px[front, j] = cam.apparent_radius(radius, z[front])
    # [a, b]: seen by both in two cameras or more, and in every one their blobs' centroids (one blob, in some: a piece's
    # ghost pairing with the other piece) lie within PIECES_APART of a's apparent radius and their blobs together cover
    # no more than PIECES_FILL of its disc (a ball and a thing nearer or farther on nearly the same lines of sight, 0.3 m
    # apart, lie as near in both views: static_props tune seed 36)
    both = ~np.isnan(centres[:, None, :, 0]) & ~np.isnan(centres[None, :, :, 0]) & ~np.isnan(radius_px[:, None])
    near = np.linalg.norm(centres[:, None] - centres[None], axis=3) < PIECES_APART * radius_px[:, None]
    union = np.where(blob_ids[:, None] == blob_ids[None], areas[:, None], areas[:, None] + areas[None])
    small = union <= PIECES_FILL * np.pi * radius_px[:, None] ** 2
    pieces = (both.sum(axis=2) >= 2) & (~both | (near & small)).all(axis=2)
    np.fill_diagonal(pieces, False)
    joined = np.arange(k)  # the object each one is a piece of (itself: none)
    for a in np.argsort(-score, kind="stable"):  # the stronger object takes the pieces
        if joined[a] == a:
            joined[pieces[a] & (joined == np.arange(k))] = a
    if (joined == np.arange(k)).all():
        return objects, into
    out, number = [], np.full(k, -1)
    for a in range(k):
        if joined[a] != a:
            continue
        members = np.flatnonzero(joined == a)
        w = areas[members].sum(axis=1) / areas[members].sum()
        number[a] = len(out)
        out.append(replace(objects[a], position=w @ positions[members]) if len(members) > 1 else objects[a])
    renumber = np.append(number[joined], -1)  # the last entry maps -1 (dropped)
    return out, renumber[into]


def _depth_along_ray(o, d, particle_depth: float, along_var: float, predicted, radius: float) -> float:
    """Where along a clean view's ray a ball sits whose other views are shared or hidden.

    The particles spread along the stretch of the ray that the shared blob
    allows, and their mean is biased wherever the other ball covers more of it
    (when the ball is hidden behind a nearer one, any point of the stretch
    fits the masks). A track predicted next to the ray knows better: its
    depth is used when it lies inside the particles' stretch.
    """
    if predicted is None or len(predicted) == 0:
        return particle_depth
    t = (predicted - o) @ d
    lateral = np.linalg.norm(predicted - (o + np.outer(t, d)), axis=1)
    k = int(np.argmin(lateral))
    if lateral[k] < 2 * radius and abs(t[k] - particle_depth) < 2.5 * np.sqrt(along_var):
        return float(t[k])
    return particle_depth


def _mates(i: int, kept: list[int], blob_ids: np.ndarray) -> list[tuple[int, list[int]]]:
    """(camera, the other kept balls in ball i's blob there) for every camera where i shares its blob."""
    out = []
    for j, b in enumerate(blob_ids[i]):
        mates = [k for k in kept if k != i and b >= 0 and blob_ids[k, j] == b]
        if mates:
            out.append((j, mates))
    return out


def _partly_hidden(positions: np.ndarray, cameras, radius: float, occluders) -> np.ndarray:
    """Per ball (K) and camera: a nearer ball of another colour covers part of its disc there (K x C bool).

    Its blob is then cut by the other ball's outline, and the centroid of
    what is left is not the ball's centre, even while the blob still looks
    about ball-sized (a disc cut on one side keeps its other extent).
    """
    out = np.zeros((len(positions), len(cameras)), bool)
    if occluders is None or not len(occluders[0]) or not len(positions):
        return out
    centres, radii = occluders
    for j, cam in enumerate(cameras):
        uv, front, z = cam.view(positions)
        ouv, ofront, oz = cam.view(centres)
        r = cam.apparent_radius(radius, z)
        orad = cam.apparent_radius(radii, oz)
        apart = np.linalg.norm(uv[:, None] - ouv[None], axis=2)
        out[:, j] = (front[:, None] & ofront[None] & (oz[None] < z[:, None]) & (apart < r[:, None] + orad[None])).any(axis=1)
    return out


def _clean_views(i: int, n: int, kept: list[int], blob_ids: np.ndarray, log_ratio: np.ndarray, hidden: np.ndarray, whole: np.ndarray):
    """(cameras where kept ball i (the n-th kept) has a blob of its own, of its size, round and full (``whole``) and
    not cut by a nearer ball of another colour, [(camera, mates)] where it shares its blob, cameras where it has a
    blob of its own that is not clean: a ball seen in part, or merged with something of its colour, whose moving
    part the partial-view fit reads)."""
    shared = _mates(i, kept, blob_ids)  # a blob shared with another ball: its centroid is of neither
    in_shared = {j for j, _ in shared}
    own = [j for j in range(blob_ids.shape[1]) if j not in in_shared and blob_ids[i, j] >= 0 and not hidden[n, j]]
    # unseen, clipped or occluded in a camera: not clean there
    good = [j for j in own if abs(log_ratio[i, j]) < REFINE_TOLERANCE and whole[i, j]]
    return good, shared, [j for j in own if j not in good]


def _held_twice(predicted: np.ndarray | None, cameras, blobs, radius: float) -> list[set[int]]:
    """Per camera, the blobs two or more tracked balls project into: balls of one colour overlapping there."""
    if predicted is None or len(predicted) < 2:
        return [set() for _ in cameras]
    ids, _ = _signatures(np.asarray(predicted, float), cameras, blobs, radius)
    out = []
    for j in range(len(cameras)):  # a few balls: counted in a list (np.unique's sort and counts cost ten times more)
        held = [b for b in ids[:, j].tolist() if b >= 0]
        out.append({b for b in held if held.count(b) > 1})
    return out


# A ball is smeared in every view or in none: a blob shaped like a streak that is only in part moving, PAIRED_MOVING of it
# or more, is a streak where the same ball's blob in another view is one (``_paired``). A fast ball's faint streak, two
# pixels wide, read 0.2-0.6 moving on the background's half-size grid in one camera while the other camera's read 0.9;
# its object kept its particles' depth, 0.3 m far for 10 frames (fast_ball tune seed 436: 0.571 -> 0.762).
PAIRED_MOVING = 0.2


def _swept(views: Sequence[CameraEvidence], predicted: np.ndarray | None, radius: float, short_blurs: bool = True) -> tuple[list, list]:
    """Per camera, per blob: a fast ball's streak. Shaped like one (``Blobs.widths``), mostly moving (a static prop as
    long and as filled is not: its blob in the refine step would be clean, and its object a steady false track:
    clutter 0.976 -> 0.907), and not where two tracked balls overlap (two balls side by side look like a streak). And
    per camera, per blob: shaped like one and in part moving (PAIRED_MOVING), a streak if its ball's other view is one."""
    cameras, blobs = [v.camera for v in views], [v.blobs for v in views]
    shared = _held_twice(predicted, cameras, blobs, radius)
    out, partly = [], []
    for j, (v, b) in enumerate(zip(views, blobs)):
        swept = np.zeros(len(b), bool)
        some = swept.copy()
        if b.widths is not None and b.boxes is not None and b.axes is not None and v.moving_integral is not None and len(b):
            swept = b.widths != b.radii
            if short_blurs:
                swept |= short_streaks(b, v.counted if v.counted is not None else v.mask)
            ks = np.flatnonzero(swept)
            if len(ks):  # every candidate's box at once (a hue wall's stripes are dozens a frame)
                # Over the pixels its area was counted in (Blobs.pixel_boxes). In its bare box of label cells a small
                # streak whose rows fell off that grid read 0.64-0.77 moving (a drawn blur moving all over: 0.65), was no
                # streak, and its object kept its particles' depth (fast_ball tune seed 29: 0.3-0.4 m far for 27 frames).
                moving = box_counts(v.moving_integral, *b.pixel_boxes(ks).T)
                alone = np.array([k not in shared[j] for k in ks.tolist()], bool)
                swept[ks] = (moving >= 0.8 * b.areas[ks]) & alone
                some[ks] = (moving >= PAIRED_MOVING * b.areas[ks]) & alone
        out.append(swept)
        partly.append(some)
    return out, partly


def _paired(swept: list[np.ndarray], partly: list[np.ndarray], blob_ids: np.ndarray) -> list[np.ndarray]:
    """``swept`` (per camera, per blob) with the blobs that are ``partly`` streaks (_swept) where a kept object's blob
    (``blob_ids``: per object, per camera, -1 none) is a streak in another camera."""
    if not any(p.any() for p in partly):
        return swept
    out = [s.copy() for s in swept]
    for row in blob_ids:
        seen = [(j, b) for j, b in enumerate(row.tolist()) if b >= 0]
        if any(swept[j][b] for j, b in seen):
            for j, b in seen:
                out[j][b] |= partly[j][b]
    return out


def _agree(
    point: np.ndarray,
    obj: Object3D,
    cov: np.ndarray,
    slack: float | None,
    radius: float,
    origin: np.ndarray,
    along_ray: bool = True,
    cameras: Sequence = (),
) -> bool:
    """Are the triangulated blobs ``point`` (covariance ``cov``) and the particles' mean ``obj`` the same ball? Within
    3 radii; for streaks (``slack`` not None) 3 standard deviations of the triangulation and of the particles more
    (a far fast ball's particles judge a streak a ball wide but as long as a fifth of its disparity along the epipolar
    lines, and their mean strays 0.3 m at 16 m; the centroids triangulate to their half pixel: fast_ball tune seed 9),
    and along the viewing ray (from ``origin``) a share ``slack`` of the distance more: the particles judge a streak's
    size somewhere between its width and its length, so their depth may be off by as much as its width falls short of
    its length (a short blur's particles 15 % too near, fast_ball tune seed 5; their spread claimed 0.2 m of 1 m)."""
    gap = point - obj.position
    valid = obj.covariance is not None and np.shape(obj.covariance) == (3, 3) and np.isfinite(obj.covariance).all()
    spread = obj.covariance if valid else np.zeros((3, 3))
    distance = float(np.linalg.norm(point - origin))
    ray = (point - origin) / max(distance, 1e-9)
    along = float(gap @ ray)
    across = float(np.linalg.norm(gap - along * ray))
    if slack is None:
        if np.linalg.norm(gap) <= 3.0 * radius:
            return True
        # Farther apart only along the viewing ray, within what the triangulation and the particles claim, where the
        # particles claim no better than three radii there (a far ball's: 7 radii at 12 m, fast_ball tune seed 16; a near
        # ball's particles claiming 2 radii, 3.5 radii off, keep their word: lighting tune seed 6 0.967 -> 0.856 else).
        # Claiming better, they keep it only where they and the centroids are not one disc in every view (discs.same_disc): a
        # far ball's particles judge its depth by its size, which its mask understates, and drift far while claiming
        # 0.1-0.2 m (fast_ball tune seed 1: a handball at 7.3 m, 0.3 m far and on to 0.95 m, its centroids within 2 cm).
        # A white or grey ball's too: its blob is its shading's disc or its moving patch, not only its lit crescent. A
        # ball at rest kept its particles' depth, 0.12-0.17 m near and claiming 0.12 m, while its blobs triangulated to
        # 2 cm (white_ball seed 222: 0.422 -> 1.000; seeds 0-279 +0.94). It was refused this when its blob was the
        # crescent alone (white_ball tune seeds 4 and 16 fell then; they lose 0.02 each now).
        if not along_ray:
            return False
        if ray @ spread @ ray <= (3.0 * radius) ** 2:
            return same_disc(point, obj.position, cameras, radius)
        sigma = float(np.sqrt(max(ray @ (cov + spread) @ ray, 0.0)))
        return bool(across <= 3.0 * radius and abs(along) <= 3.0 * radius + 2.0 * sigma)
    cov = cov + spread
    u = gap / max(float(np.linalg.norm(gap)), 1e-9)
    tol = 3.0 * radius + 3.0 * float(np.sqrt(max(u @ cov @ u, 0.0)))
    return across <= tol and abs(along) <= tol + slack * distance


def _refine_all(merged, kept, blob_ids, log_ratio, hidden, evidence, settings, predicted, swept) -> list[Object3D]:
    """Blob centroids where they belong to a ball alone and have its size; else the particles' word.

    Balls with two or more clean views are triangulated together (one call per set of cameras); a
    ball with one clean view takes its ray and a depth (``_one_view``). A ball that shares a blob is
    then placed against the other balls' discs there, one ball at a time, each against the latest
    positions of the others.
    """
    cameras, blobs, rays = [v.camera for v in evidence], [v.blobs for v in evidence], [v.rays for v in evidence]
    whole = _whole(blob_ids, blobs, log_ratio) | (not settings.partial_views)  # before streaks are measured by their width
    smeared = whole & (log_ratio > STREAK_LONGER)  # (NaN: no blob, no smear)
    whole |= _blurred(whole, smeared, blob_ids, evidence, swept)
    whole &= ~_cut_short(blob_ids, blobs, swept, cameras, merged)
    log_ratio = _streaks_may_be_thin(log_ratio, blob_ids, blobs, swept)
    views = {i: _clean_views(i, n, kept, blob_ids, log_ratio, hidden, whole) for n, i in enumerate(kept)}
    # A ball longer than itself in some view is fast (a streak, blurred), not hidden: its disc would hold none of its
    # views (fast_ball tune seed 7 fell 0.534 -> -0.155 with the partial-view fit on its streaks).
    fast = [i for i in kept if smeared[i].any() or not settings.partial_views]  # (or no partial views for this target)
    views.update({i: (*views[i][:2], []) for i in fast})
    out = {i: merged[i] for i in kept}
    by_cameras: dict[tuple[int, ...], list[int]] = {}
    for i in kept:
        if len(views[i][0]) >= 2:
            by_cameras.setdefault(tuple(views[i][0]), []).append(i)
    for good, idx in by_cameras.items():
        # A streak's centre is where its ball covered the most over the exposure, not its mask's centroid (coverage.py).
        px = [_centres(evidence[j], blob_ids[idx, j], swept[j][blob_ids[idx, j]]) for j in good]
        # Centroid noise of a shaded, sensor-noisy ball: about half a pixel.
        streaky = [swept[j][blob_ids[idx, j]] for j in good[:2]]
        spread = [_centroid_covs(blobs[j], blob_ids[idx, j], on) for j, on in zip(good[:2], streaky)] if any(map(np.any, streaky)) else None
        points, covs = triangulate_with_covariance([cameras[j] for j in good], px, CENTROID_SIGMA_PX, spread)
        origin = cameras[good[0]].centre
        for i, point, cov in zip(idx, points, covs):
            slack = _slack(list(good), blob_ids[i], blobs, swept)
            # A long streak in one view and a disc in another is no one ball's pair of views (a ball is smeared in every view
            # or in none): a disc merged with a pale moving patch beside it, its centroid off along the epipolar line
            # (lighting tune seed 61: a warm-up ghost in a streak's colour beside the ball, 9 pixels off, 0.29 m near; 0.939 -> 0.967).
            long = slack is None and any(_long(blobs[j], blob_ids[i, j]) for j in good)
            if _agree(point, merged[i], cov, slack, settings.radius, origin, not long, [cameras[j] for j in good]):
                out[i] = replace(merged[i], position=point, covariance=cov, swept=slack is not None)
    one_view = [i for i in kept if len(views[i][0]) == 1]
    for i in one_view:
        out[i] = _one_view(
            merged[i], i, *views[i][:2], blob_ids, cameras, blobs, rays, settings, predicted, partial=views[i][2], evidence=evidence
        )
    if settings.disc_fit:
        positions = {i: o.position for i, o in out.items()}
        for i in one_view:
            if views[i][1]:
                out[i] = _one_view(merged[i], i, *views[i][:2], blob_ids, cameras, blobs, rays, settings, predicted, positions)
                positions[i] = out[i].position
    return [out[i] for i in kept]


def _one_view(
    obj, i, good, shared, blob_ids, cameras, blobs, rays, settings, predicted=None, positions=None, partial=(), evidence=None
) -> Object3D:
    """One clean view: its ray fixes the direction, the particles (or the shared blobs) the distance along it.

    The covariance says so (tight across the ray, the depth's uncertainty
    along it), so the track's Kalman filter leans on its own prediction for
    the depth. ``positions`` (the other balls' latest positions) enables the
    disc fit through shared blobs.
    """
    j = good[0]
    o, d = rays[j][0][blob_ids[i, j]], rays[j][1][blob_ids[i, j]]
    spread = float(d @ obj.covariance @ d)
    along = max(spread, ONE_VIEW_DEPTH_SIGMA**2)
    own = float((obj.position - o) @ d)
    if np.linalg.norm(obj.position - (o + d * own)) > 3 * settings.radius:
        return obj  # the blob and the particles disagree: trust the particles
    # Only a blob shared with another ball, with the particles spread wide along the ray, makes
    # their depth ambiguous; otherwise the track's prediction would feed its velocity back into itself.
    ambiguous = bool(shared) and spread > ONE_VIEW_DEPTH_SIGMA**2
    depth = _depth_along_ray(o, d, own, along, predicted, settings.radius) if ambiguous else own
    # The shared blob itself measures the depth, wherever the ball shows in it; that depth is only
    # the prior for the fit (it decides where the blob cannot, e.g. behind a nearer ball).
    fit = _fit_shared_blobs(o, d, depth, along, i, shared, blob_ids, cameras, blobs, settings, positions) if shared else None
    if not shared and partial and evidence is not None:
        # The other views see the ball only in part: the particles' depth is pulled to where their smaller discs on
        # the visible parts put it. The disc that holds what shows of the ball, and nothing around it, says where.
        fit = _fit_partial_views(o, d, own, [evidence[k] for k in partial], settings.radius)
    if fit is not None:
        depth, along = fit.depth, max(fit.sigma, DISC_FIT_SIGMA) ** 2
    point = o + d * depth
    z = float(cameras[j].depth(point[None])[0])
    # No better than two views would place it: the particles claim a far ball's depth as sharply as a near one's
    # (ONE_VIEW_DEPTH_SIGMA), where a pixel of disparity is 0.26 m at 12.7 m (fast_ball's 1.25 m baseline).
    along = max(along, _two_view_depth_floor(point, d, j, cameras, z, along))
    across = (CENTROID_SIGMA_PX * z / cameras[j].focal_px) ** 2
    cov = across * (np.eye(3) - np.outer(d, d)) + along * np.outer(d, d)
    return replace(obj, position=point, covariance=cov)


def _two_view_depth_floor(point: np.ndarray, d: np.ndarray, j: int, cameras, z: float, claimed: float) -> float:
    """The variance along ``d`` that two views would give ``point`` (``z`` deep in camera ``j``): triangulated from
    camera ``j`` and the next one, their centroids CENTROID_SIGMA_PX off. 0 where it cannot bind: with one camera, or
    where its rough figure, sigma z^2 / (f b), is under half the sigma of the ``claimed`` variance (a near ball; the
    triangulation cost 3 % of pendulum4's step)."""
    if len(cameras) < 2:
        return 0.0
    pair = [cameras[j], cameras[(j + 1) % len(cameras)]]
    rough = np.sqrt(2.0) * CENTROID_SIGMA_PX * z * z / (pair[0].focal_px * float(np.linalg.norm(pair[0].centre - pair[1].centre)) + 1e-12)
    if (2.0 * rough) ** 2 < claimed:
        return 0.0
    cov = triangulate_with_covariance(pair, [c.project(point[None])[0] for c in pair], CENTROID_SIGMA_PX)[1][0]
    along = float(d @ cov @ d)
    return along if np.isfinite(along) else 0.0  # (behind the other camera: no floor)


def _fit_shared_blobs(o, d, depth, along, i, shared, blob_ids, cameras, blobs, settings, positions) -> RayFit | None:
    """Depth along a clean view's ray at which this ball's disc and the other balls' discs make up the
    blobs they share (see discs.py); None when it cannot be measured."""
    if positions is None or any(blobs[j].boxes is None for j, _ in shared):
        return None
    half = 3.0 * np.sqrt(along)
    lo = max(depth - half, 0.05)
    depths = lo + (depth + half - lo) * _DEPTH_STEPS
    candidates = o + depths[:, None] * d
    mismatch = np.zeros(len(depths))
    area = 0.0
    for j, mates in shared:
        others = np.array([positions[k] for k in mates])
        mismatch += union_mismatch(cameras[j], blobs[j], int(blob_ids[i, j]), candidates, others, settings.radius)
        z = float(cameras[j].depth((o + depth * d)[None])[0])
        area += np.pi * cameras[j].apparent_radius(settings.radius, max(z, 0.05)) ** 2
    return depth_on_ray(mismatch, depths, depth, np.sqrt(along), DISC_FIT_TOLERANCE * area)


def _fit_partial_views(o, d, depth, views: Sequence[CameraEvidence], radius: float) -> RayFit | None:
    """Depth along a clean view's ray at which the ball's disc in the ``views`` that see it in part holds their
    evidence there and little else (discs.partial_mismatch); None when they show too little of a ball there, or
    something beside it."""
    depths = depth * (PARTIAL_DEPTHS[0] + (PARTIAL_DEPTHS[1] - PARTIAL_DEPTHS[0]) * _PARTIAL_STEPS)
    candidates = o + depths[:, None] * d
    mismatch, around, inside, area = (np.zeros(len(depths)) for _ in range(4))
    for v in views:
        m, a, h = partial_mismatch(v, candidates, radius)
        mismatch += m
        around += a
        inside += h
        area += np.pi * v.camera.apparent_radius(radius, np.maximum(v.camera.depth(candidates), 0.05)) ** 2
    best = int(np.argmin(mismatch))
    if not np.isfinite(mismatch[best]) or inside[best] < PARTIAL_LEAST_SEEN * area[best] or around[best] > PARTIAL_MOST_AROUND * area[best]:
        return None
    fit = depth_on_ray(mismatch, depths, depth, PARTIAL_PRIOR * depth, PARTIAL_TOLERANCE * area[len(depths) // 2])
    if fit is None:
        return None
    # A pixel of the disc's slide along the epipolar line is 4 cm of depth at 2.7 m (hue_wall tune seed 5, a ball of
    # 7 pixels): the fit is good to about that, and a tighter claim pulls the track off with the odd pixel's error.
    uv = views[0].camera.project(candidates[[0, -1]])[0]
    per_metre = float(np.linalg.norm(uv[1] - uv[0])) / max(depths[-1] - depths[0], 1e-9)
    return replace(fit, sigma=max(fit.sigma, PARTIAL_PIXEL / max(per_metre, 1e-9)))
