"""Abductive proposal (paper section III-E): colour blobs -> viewing rays -> particles on rays.

Particles go uniformly along each blob's viewing ray, between the depths the
ball's apparent size allows, and around the points where the rays of two
cameras cross (the blobs come from ``evidence/blobs.py``).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..camera import Camera
from ..config import TrackerSettings
from ..evidence.colour import box_counts
from ..evidence.gather import CameraEvidence
from ..results import TrackedBalls
from .kernels import crossing_points


def depth_range_from_size(
    camera: Camera,
    radius_px: np.ndarray,
    ball_radius: float,
    d_min: float,
    d_max: float,
    slack: float = 1.6,
    off_axis: np.ndarray | float = 1.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Distance range along each blob's ray implied by the ball's apparent size.

    A ball of radius R at depth Z looks about f R / Z pixels wide; a blob
    clipped by the image edge or another ball looks smaller, so only the
    lower bound of the size is trusted loosely (``slack`` either way).
    Blobs of unknown size (NaN) keep [d_min, d_max].

    ``off_axis``: per blob, the cosine of its ray's angle to the camera's
    axis (1: read the size as on the axis). A ray at angle a meets depth Z at
    Z / cos a along it, and a ball there is stretched away from the image's
    centre to f R / (Z cos a): a blob's larger side puts its ball from
    1 / cos a to 1 / cos^2 a farther along its ray than f R / size.
    """
    f = camera.focal_px
    known = radius_px > 0  # NaN is not
    z = f * ball_radius / np.where(known, radius_px, 1.0)
    near = np.where(known, np.clip(z / off_axis / slack, d_min, d_max), d_min)
    far = np.where(known, np.clip(z / off_axis**2 * slack, d_min, d_max), d_max)
    far = np.maximum(far, near + 1e-3)
    return near, far


def particles_on_rays(
    origins: np.ndarray,
    directions: np.ndarray,
    near: np.ndarray,
    far: np.ndarray,
    n: int,
    rng: np.random.Generator,
) -> tuple[np.ndarray, np.ndarray]:
    """``n`` particles shared fairly among M rays, uniform in distance between near and far.

    Returns (positions n x 3, ray index n).
    """
    m = len(origins)
    if m == 0 or n == 0:
        return np.zeros((0, 3)), np.zeros(0, int)
    # Fair share: every ray gets n // m, the remainder goes to a random subset.
    counts = np.full(m, n // m)
    counts[rng.permutation(m)[: n - counts.sum()]] += 1
    ray = np.repeat(np.arange(m), counts)
    dist = near[ray] + rng.random(n) * (far[ray] - near[ray])
    return origins[ray] + dist[:, None] * directions[ray], ray


def ray_crossings(
    views: Sequence[CameraEvidence],
    radius: float,
    d_min: float,
    d_max: float,
    skip=None,
    slack: float = 1.6,
    stretch=None,
    narrowed=None,
    more=None,
) -> np.ndarray:
    """Where blob rays of two cameras (nearly) meet: K x 3 midpoints of their closest approach.

    A ball seen in two views sits where its two rays cross; so does a stereo
    ghost (ball A's ray in one view with ball B's in the other), which the
    explain-away stage drops later. Pairs whose rays pass farther apart than
    one ball radius, meet outside [d_min, d_max], or whose blobs are more than
    ``slack`` times larger or smaller than a ball there would look (a
    same-coloured poster on the wall, most ghosts) are not crossings, nor
    are blobs marked in ``skip`` (per camera, a bool per blob). ``stretch``
    (per camera, a factor per blob, at least 1): how much larger than a
    ball's width a blob's larger side may be besides (None: 1, a ball on the
    camera's axis and still); ``narrowed`` (likewise, at least 1): how much
    narrower than a ball a blob's width may read besides (None: 1; a fast
    ball's streak loses its faded sides from its mask). ``more`` (per camera,
    or None): rays of blobs of another map, as (origins, directions, widths in
    pixels, log stretch, use flags); given, only the pairs with one of them or
    two are crossed (with the blobs' and with each other), the blobs' own pairs
    not.
    """
    use = [np.ones(len(v.blobs), bool) if skip is None else ~np.asarray(skip[j], bool) for j, v in enumerate(views)]
    if any(len(u) != len(v.blobs) for u, v in zip(use, views)):  # the kernel reads one flag per blob, unchecked
        raise ValueError("ray_crossings: skip needs one flag per blob of each view")

    def logs(factors):  # per camera, per blob: the log of a factor (None: 1), as the kernel reads it
        return [np.zeros(len(v.blobs)) if factors is None else np.log(np.asarray(factors[j], float)) for j, v in enumerate(views)]

    ks, ns = logs(stretch), logs(narrowed)
    rays = [(*v.rays, v.blobs.ball_radii(), ks[j], ns[j], use[j]) for j, v in enumerate(views)]
    # each pair of cameras' rays is crossed with these flags: every blob's with every blob's, or with ``more`` those of the
    # other map (all of camera j's with k's others, then j's others with k's blobs): no pair twice, none of two blobs
    flags = [lambda j, k: (rays[j][5], rays[k][5])]
    if more is not None:
        for j, (o, d, widths, k, u) in enumerate(more):  # after the blobs' rays (none narrowed)
            o1, d1, w1, k1, n1, u1 = rays[j]
            rays[j] = (np.vstack([o1, o]), np.vstack([d1, d]), np.r_[w1, widths], np.r_[k1, k], np.r_[n1, np.zeros(len(o))], np.r_[u1, u])
        others = [np.r_[np.zeros(len(v.blobs), bool), m[4]] for v, m in zip(views, more)]
        blobs = [np.r_[u, np.zeros(len(m[0]), bool)] for u, m in zip(use, more)]
        flags = [lambda j, k: (rays[j][5], rays[k][5] & others[k]), lambda j, k: (rays[j][5] & others[j], blobs[k])]
    out = [
        crossing_points(
            *rays[j][:5],
            use_j,
            *rays[k][:5],
            use_k,
            a.camera.R,
            a.camera.t,
            a.camera.focal_px,
            b.camera.R,
            b.camera.t,
            b.camera.focal_px,
            radius,
            d_min,
            d_max,
            slack,
        )  # fmt: skip
        for j, a in enumerate(views)
        for k, b in enumerate(views)
        if j < k and len(rays[j][0]) and len(rays[k][0])
        for use_j, use_k in (f(j, k) for f in flags)
    ]
    return np.vstack(out) if out else np.zeros((0, 3))


def alone_particles(n: int, share: float, mask_crossings: int, alone_crossings: int) -> int:
    """How many of ``n`` abductive particles go around the crossings of moving blobs of their own (Seeds.alone), besides
    the mask's crossings' ``share``: ALONE_EACH per crossing, at most a quarter of ``n``, from the rays' part; the share
    when the mask has no crossings. Shared among the mask's crossings, they took particles from a ball's own crossing
    (hands tune seed 36: frames not yet found 11 -> 29); a share spread over all, a wall of the ball's hue crossing 60-265
    times left the ball's crossing under one (hue_wall tune seeds 95, 20)."""
    if not alone_crossings:
        return 0
    if not mask_crossings:
        return int(round(share * n))
    return min(ALONE_EACH * alone_crossings, n // 4, n - int(round(share * n)))  # (never more than the rays' part)


def _holders(projected: tuple[np.ndarray, np.ndarray], centres: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """Per blob (``centres``, ``radii``): how many of the tracked balls project into it (HELD_MIN_PX); ``projected``:
    their pixels and in-front flags in the blobs' camera (Camera.project), made once a frame for both calls."""
    uv, ok = projected
    d = np.linalg.norm(uv[:, None] - centres[None], axis=2)
    return (ok[:, None] & (d < np.maximum(radii[None], HELD_MIN_PX))).sum(axis=0)


def _alone_rays(views: Sequence[CameraEvidence], seeds: Sequence, projected: list | None) -> list | None:
    """Per camera, the rays of its seeds that are moving blobs of their own (Seeds.alone: a coloured ball moving before a
    wall of its colour, one blob with the wall in the mask, too large to cross) as ray_crossings pairs them (``more``):
    origins, directions, widths, log stretch (read off the camera's axis as a moving blob's: _off_axis) and whether to
    use each (not one a tracked ball projects into: ``projected``, as _holders takes it). None when no seed is such."""
    if not any(b.alone is not None and b.alone.any() for b in seeds):
        return None
    out = []
    for j, (v, b) in enumerate(zip(views, seeds)):
        a = np.flatnonzero(b.alone) if b.alone is not None else np.zeros(0, int)
        use = _holders(projected[j], b.centres[a], b.radii[a]) == 0 if projected is not None else np.ones(len(a), bool)
        widths = (b.widths if b.widths is not None else b.radii)[a]
        out.append((b.origins[a], b.directions[a], widths, -np.log(_off_axis(v.camera, b.directions[a])), use))
    return out


def _still(view: CameraEvidence) -> np.ndarray:
    """Per blob of the view: no pixel of its box moves (the moving map's summed-area table)."""
    (u, v), r = view.blobs.centres.T, view.blobs.radii
    return box_counts(view.moving_integral, np.floor(u - r), np.floor(v - r), np.ceil(u + r) + 1, np.ceil(v + r) + 1) == 0


# A moving blob's ray this far off the camera's axis or farther (cos 0.9: 26 degrees, a stretch of 11 %) has its size
# read off the axis. Nearer, its stretch is within the size's slack, and the reading stays as it was: read at every
# angle, the ranges of moving hands near the middle of the view moved by 1-5 %, and hands tune seeds 0-159 lost 3.7 of
# summed MOTA (seed 12 0.78 -> -0.39, alike with three tracker seeds) and white_ball 0-159 lost 0.5.
OFF_AXIS_COS = 0.9


def _off_axis(camera: Camera, directions: np.ndarray) -> np.ndarray:
    """Per ray (unit ``directions``) of a moving blob: the cosine of its angle to the camera's axis where that is
    under OFF_AXIS_COS (at least 0.1), else 1 (read as on the axis).

    Off the axis a ball's image is stretched away from the image's centre by 1 / cos (1.2x at the edge of a 70-degree
    view) and, moving, blurred along its path: its larger side, read as on the axis, put a ball 7.7 m along its ray
    (6.3 m deep) 3.8 m away, beyond its depth range and its crossings' size test, and a clearly seen ball had no
    particle for 6 frames (fast_ball tune seed 407). A still blob keeps the reading on the axis: read off it too, a
    wall's patches of the ball's hue at the image's edges made ghosts (hue_wall tune seeds 0-199: -1.1 summed)."""
    cos = camera.axis_cosines(directions)
    return np.where(cos < OFF_AXIS_COS, np.maximum(cos, 0.1), 1.0)


def frustum_particles(camera: Camera, n: int, d_min: float, d_max: float, rng: np.random.Generator) -> np.ndarray:
    """Particles spread over the camera's field of view between d_min and d_max (no information)."""
    uv = rng.random((n, 2)) * np.array([camera.width, camera.height])
    o, d = camera.rays(uv)
    dist = d_min + rng.random(n) * (d_max - d_min)
    return o + dist[:, None] * d


MOVING_SHARE = 0.5  # at least this share of the particles along rays goes to the rays of the moving map's own blobs:
# a white ball on a white wall is one moving blob among a hundred specks of the colour mask, and a fair share per ray left it a few particles
# A moving blob's size is a ball's only roughly: a slow ball's trail (the background half learnt where it just was) can
# double it, a ball whose middle matches the wall behind it moves at its edges only. Its depth range allows that much.
MOVING_SLACK = 2.5
ALONE_EACH = 8  # particles around each crossing of a moving blob of its own (alone_particles)
HELD_MIN_PX = 3.0  # a tracked ball holds a blob when it projects within the blob's radius, or this many pixels of its centre


class RayProposal:
    """The abductive proposal (the birth sampler): ``n`` particles from this frame's evidence alone.

    Along every blob's viewing ray, between the depths its size allows, and a
    share (``crossing_share``) around the points where two cameras' rays
    cross; with no blob anywhere, spread blindly over the first camera's view.
    """

    def __init__(self, settings: TrackerSettings, radius: float, moving_first: bool = False):
        self.settings = settings
        self.radius = radius
        # A ball of every hue (Target.any_hue): its colour mask is specks of the wall, its moving blobs come first
        # (MOVING_SHARE, MOVING_SLACK). A ball of one hue is a colour blob; there the shares stay fair (the moving
        # share cost hands seed 5 0.58 -> -0.18 and hue_wall seed 3 0.91 -> 0.63).
        self.moving_first = moving_first

    def __call__(self, views: Sequence[CameraEvidence], n: int, mine: TrackedBalls | None, rng: np.random.Generator) -> np.ndarray:
        """``mine``: this target's tracked balls (their blobs make no crossings: their balls have particles)."""
        s = self.settings
        origins, dirs, near, far, moved = [], [], [], [], []
        seeds = [v.proposal_seeds() for v in views]
        # How many tracked balls of this colour project into each blob: a held blob's ball has its particles (no
        # crossings there), and two balls overlapping look like one ball's streak (their size is the larger side's,
        # not the streak's width).
        holders = projected = None
        if mine is not None and len(mine):
            projected = [v.camera.project(mine.centres) for v in views]
            holders = [_holders(p, b.centres, b.radii) for p, b in zip(projected, seeds)]
        for j, (v, b) in enumerate(zip(views, seeds)):
            if len(b) == 0:
                continue
            if s.depth_from_size:
                size = b.radii if b.widths is None else np.where(holders[j] > 1, b.radii, b.widths) if holders is not None else b.widths
                off_axis = 1.0 if b.moved is None else np.where(b.moved, _off_axis(v.camera, b.directions), 1.0)
                lo, hi = depth_range_from_size(v.camera, size, self.radius, s.d_min, s.d_max, off_axis=off_axis)
                # a moving streak narrower than its ball has lost its blur's faded sides: its ball may be as near
                # as the streak's length says
                if b.moved is not None and (streak := b.moved & (size < b.radii)).any():
                    lo = np.where(streak, depth_range_from_size(v.camera, b.radii, self.radius, s.d_min, s.d_max, off_axis=off_axis)[0], lo)
                if self.moving_first and b.moved is not None and b.moved.any():  # a moving blob's size says less: see MOVING_SLACK
                    wide = depth_range_from_size(v.camera, size, self.radius, s.d_min, s.d_max, MOVING_SLACK, off_axis)
                    lo, hi = np.where(b.moved, wide[0], lo), np.where(b.moved, wide[1], hi)
            else:
                lo, hi = np.full(len(b), s.d_min), np.full(len(b), s.d_max)
            origins.append(b.origins)
            dirs.append(b.directions)
            near.append(lo)
            far.append(hi)
            moved.append(b.moved if self.moving_first and b.moved is not None else np.zeros(len(b), bool))
        if not origins:  # nothing of this colour in any image: search blindly
            return frustum_particles(views[0].camera, n, s.d_min, s.d_max, rng)
        crossings = alone = np.zeros((0, 3))
        n_cross = n_alone = 0
        if s.crossing_share > 0:
            # Crossings are for balls no track holds yet: blobs a tracked ball of this colour projects
            # into are left out (their ball has its particles; a partly hidden one's shifted centroid
            # would cross at the wrong depth).
            held = stretch = narrowed = still = None
            if projected is not None:
                # per blob of the mask, as ray_crossings reads them (the seeds may be fewer or more blobs)
                held = [_holders(p, v.blobs.centres, v.blobs.radii) > 0 for p, v in zip(projected, views)]
            if all(v.moving_integral is not None for v in views):
                # per blob of the mask: its ray's cosine to its camera's axis (1 near the axis), and whether it is still
                cosines = [_off_axis(v.camera, v.rays[1]) for v in views]
                # and whether it is a streak: a coloured ball's moving streak can read narrower than its ball, as the
                # blur's faded sides fall out of its mask (not a white ball's: its colour's thin specks are the room's)
                streaks = [(v.blobs.ball_radii() < v.blobs.radii) & (not self.moving_first) for v in views]
                if self.moving_first or any((c < 1.0).any() or w.any() for c, w in zip(cosines, streaks)):
                    # (most frames of a coloured ball: no blob far off the axis nor a streak, nothing to ask)
                    still = [_still(v) for v in views]
                    stretch = [np.where(m, 1.0, 1.0 / c) for m, c in zip(still, cosines)]
                    narrowed = [
                        np.where(m | ~w, 1.0, v.blobs.radii / np.maximum(v.blobs.ball_radii(), 0.5))
                        for m, w, v in zip(still, streaks, views)
                    ]
                if self.moving_first:  # a white ball's crossings are its moving blobs': the colour's specks cross everywhere
                    held = still if held is None else [h | m for h, m in zip(held, still)]
            crossings = ray_crossings(views, self.radius, s.d_min, s.d_max, held, stretch=stretch, narrowed=narrowed)
            alone_rays = None if self.moving_first else _alone_rays(views, seeds, projected)
            if alone_rays is not None:
                alone = ray_crossings(views, self.radius, s.d_min, s.d_max, held, stretch=stretch, narrowed=narrowed, more=alone_rays)
            n_cross = int(round(s.crossing_share * n)) if len(crossings) else 0
            n_alone = alone_particles(n, s.crossing_share, len(crossings), len(alone))
        pts = self._on_rays(
            np.vstack(origins),
            np.vstack(dirs),
            np.concatenate(near),
            np.concatenate(far),
            np.concatenate(moved),
            n - n_cross - n_alone,
            rng,
        )
        for points, count in ((crossings, n_cross), (alone, n_alone)):  # each group's particles fairly among its crossings
            if count:
                at = np.repeat(np.arange(len(points)), count // len(points))
                at = np.r_[at, rng.permutation(len(points))[: count - len(at)]]
                pts = np.vstack([pts, points[at] + rng.normal(0.0, 0.5 * self.radius, (count, 3))])
        return pts

    @staticmethod
    def _on_rays(origins, dirs, near, far, moved, n: int, rng: np.random.Generator) -> np.ndarray:
        """``n`` particles along the rays: the moving map's own rays share at least MOVING_SHARE of them (more when they
        are more than that share of the rays), the others the rest; each group fairly among its rays."""
        m = int(moved.sum())
        if m == 0 or m == len(moved):
            return particles_on_rays(origins, dirs, near, far, n, rng)[0]
        n_moved = int(round(max(MOVING_SHARE, m / len(moved)) * n))
        parts = [particles_on_rays(origins[k], dirs[k], near[k], far[k], c, rng)[0] for k, c in ((moved, n_moved), (~moved, n - n_moved))]
        return np.vstack(parts)
