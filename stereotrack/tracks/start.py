"""How a fast ball's track starts moving: its second object gives its velocity (a two-point start).

A track seen once is at rest, give or take ``init_speed_sigma``. A ball thrown
at 20 m/s moves a third of a metre between frames at 60 fps, where that prior
gates a few centimetres: its second object falls outside the gate
(``second_objects`` pairs it with the nearest free object within
``max_speed``), or inside it but gone across a camera's line of sight as
only a flying ball goes (``motion.flies_across``). Either way the track
starts at the two objects' velocity (``start_moving``), not from rest.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.optimize import linear_sum_assignment

from .kernels import kalman_predict
from .state import TrackState

EPS_TIME = 1e-6  # seconds: frame times are floats; 0.1 s at 30 fps must count as 0.1 s
INFEASIBLE = 1e9  # cost of a pair outside the gate (the solver then maximises the number of gated pairs)
# A fast ball's first object is off by about twice its claimed sigma, against later ones (fast_ball tune seeds 0-39:
# |error| / sigma along the rays, median 0.33 against 0.21 from the fourth on, 90th percentile 1.93 against 0.78).
# Counted so (variance x 4), the smoother revises it from later hits: fast_ball tune median 0.950 -> 0.964 (x 2-100: 0.958-0.963).
FIRST_HIT_SIGMAS = 2.0


def second_objects(young: Sequence[TrackState], z: np.ndarray, free: np.ndarray, time: float, max_speed: float) -> list:
    """The tracks seen once (``young``, unmatched this frame) paired with their second object: among the ``free``
    objects (indices into ``z``, N x 3 positions), the nearest within ``max_speed`` of where each was seen, one object
    per track (Hungarian). A static ball's noisy first objects still meet in the ordinary gate, where the prior keeps its
    velocity small. (track, object index, its first position, seconds between them) per pair."""
    if not len(young) or not len(free):
        return []
    first = np.array([t.x[:3] for t in young])  # a track seen once has no velocity: its prediction is where it was seen
    dt = np.array([max(time - t.last_hit, EPS_TIME) for t in young])
    dist = np.linalg.norm(first[:, None] - z[free][None], axis=2)
    near = dist <= max_speed * dt[:, None]
    rows, cols = linear_sum_assignment(np.where(near, dist, INFEASIBLE))
    return [(young[r], int(free[c]), first[r], float(dt[r])) for r, c in zip(rows, cols) if near[r, c]]


def start_moving(tr: TrackState, first: np.ndarray, z: np.ndarray, R: np.ndarray, dt: float, model: tuple, max_speed: float) -> None:
    """A track seen once at ``first`` takes its second object (``z``, noise ``R``) ``dt`` seconds on: the velocity
    is their difference, as uncertain as both. The first hit counts no sharper than the second, and FIRST_HIT_SIGMAS
    times vaguer than that: a ball coming in is cut by the image's edge (or found in part by particles that have
    just reached it), its first object vague and off towards the inside (fast_ball tune seed 7 frame 49: 0.54 m,
    sigma 0.28; taken as sharp as the second, the velocity missed the third hit by 0.5 m, and a new track took it).
    The first frame's state in its history is rewritten so, velocity open up to ``max_speed``, and linked to this one
    by ``model`` (F, Q, b over ``dt``, not in flight): the smoother then revises the first hit from the later ones (set
    anew, it was written where it was seen: a miss and a false positive)."""
    past, k = tr.past, tr.past.n - 1
    mine = k >= 0 and abs(past.times[k] - tr.last_hit) <= EPS_TIME and dt > EPS_TIME  # its first hit, the frame before
    R1 = past.P[k, :3, :3].copy() if mine else R
    R1 = FIRST_HIT_SIGMAS**2 * (R1 if np.trace(R1) > np.trace(R) else R)
    P = np.zeros((6, 6))
    P[:3, :3], P[:3, 3:], P[3:, :3], P[3:, 3:] = R, R / dt, R / dt, (R1 + R) / dt**2
    tr.x, tr.P, tr.link = np.r_[z, (z - first) / dt], P, None
    if mine:
        F, Q, b = model
        tr.link = (*kalman_predict(*past.restate_newest(R1, max_speed), F, Q, b), F)
