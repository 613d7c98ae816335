"""The tracks' motion model (constant velocity, gravity in free flight, drag on a fast ball) and its helpers.

Also: where a ball flew in from, how a fast track weighs its objects, whether a thing moved across the line of sight."""

from __future__ import annotations

import numpy as np


def motion_model(dt: float, accel_noise: float, gravity: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Constant-velocity transition over ``dt`` seconds: (F 6x6, Q 6x6, b 6) with x' = F x + b.

    Q is the continuous white-acceleration model (q = accel_noise m^2/s^3),
    b the known gravity acceleration (zero when ``gravity`` is None).
    """
    i = np.arange(3)
    F = np.eye(6)
    F[i, i + 3] = dt
    q = accel_noise
    Q = np.zeros((6, 6))
    Q[i, i] = q * dt**3 / 3
    Q[i, i + 3] = Q[i + 3, i] = q * dt**2 / 2
    Q[i + 3, i + 3] = q * dt
    b = np.zeros(6)
    if gravity is not None:
        b[:3] = 0.5 * gravity * dt * dt
        b[3:] = gravity * dt
    return F, Q, b


# m/s: a ball this fast flies (thrown, pitched, shot: no hand carries one so fast), under gravity and air drag, whose
# deceleration along its flight (6-18 m/s^2 for a pitch at 30 m/s) the constant-velocity model otherwise takes as noise.
# Far away its objects are too vague in depth for the free-flight test, so it gets gravity by its speed. With drag known
# it needs less noise (tracks.fast_accel_noise); only with gravity known ('up'): with its fall unknown, less noise lags.
# fast_ball tune seeds 0-159 (four kinds of ball, drag 0.006-0.02), MOTA summed against a track's plain model (noise 30,
# no gravity until the free-flight test): drag 0.012 with noise 9 +3.75 (median 0.950 -> 0.964), 3 +2.79, 30 +0.30;
# noise 9 with drag 0.006 +1.02, 0.02 +1.25, none -0.80. Seeds 160-319, never looked at: +2.37 (median 0.966 -> 0.976).
FAST_FLIGHT = 8.0


def fast_flight_model(dt: float, velocity: np.ndarray, accel_noise: float, gravity: np.ndarray | None, drag: float) -> tuple:
    """``motion_model`` of a ball in fast flight: gravity (when known) and air drag, -drag |v| v at the velocity it
    has now, as known accelerations over the step (at 8-30 m/s a frame changes the drag by a few per cent at most)."""
    F, Q, b = motion_model(dt, accel_noise, gravity)
    slowing = -drag * float(np.linalg.norm(velocity)) * np.asarray(velocity, float)
    return F, Q, b + np.r_[0.5 * slowing * dt * dt, slowing * dt]


def entering(entry: tuple, x: np.ndarray, P: np.ndarray, fast: float, in_view) -> list:
    """A track's ball the frame before its first hit, if it flew into the view then: [(time, position, 3 x 3 covariance,
    n_particles)], a hit as the track's tentative ones are given (TrackEstimate.before), or [] when it did not.

    ``entry``: (that frame's time, (the first hit's time, position, covariance, n_particles)); ``x``, ``P``: the track's
    state now (its velocity is what goes back); ``fast``: m/s, the least speed of a ball that flies into view (a hand
    does not carry one so fast); ``in_view``: per position (N x 3), inside every camera's image. It had come in when
    it was in every view then, and out of one a frame earlier still: a fast ball entering is cut by the image's edge
    in its first frame, too little of it for a blob (fast_ball tune seeds 0-159: 110 of 432 balls lost their first
    frame, 106 of them at an edge), and the later hits say where it was."""
    before, (time, position, covariance, n) = entry
    velocity, dt = x[3:], time - before
    if fast <= 0 or np.linalg.norm(velocity) < fast:
        return []
    back = position - velocity * dt
    inside = in_view(np.array([back, back - velocity * dt]))
    if not inside[0] or inside[1]:
        return []
    return [(before, back, covariance + dt * dt * P[3:, 3:], n)]


# A fast ball's far objects are vague in depth, and now and then far off within their vagueness (fast_ball tune seed 339
# frame 96: 0.9 m deep at 16 m, 2.6 sigma, where the objects around it were within 0.1 m). Taken at face value such an
# object bent its track's velocity, and the track ran 0.2-0.35 m off for the next 15 frames. An object farther than this
# many sigmas from a fast track's prediction counts as vaguer by its squared distance in sigmas, so it pulls the track
# less the farther off it lies (a redescending weight, as robust M-estimators give). fast_ball MOTA summed against the
# plain update: tune seeds 320-399 +0.61 (0.7 sigma +0.37, 1.4 sigmas +0.50, 2 sigmas +0.39, 3 none; a Student-t weight
# with one degree of freedom +0.90 there but -0.41 on the seeds below); seeds 400-519, never looked at, +1.51, the mean
# over three tracker seeds (each +0.98 to +2.06; the plain update's three spread over 1.1). Scaled by the distance in
# sigmas, not its square: +1.23 there (tracker seeds 0 and 1).
ROBUST_SIGMAS = 1.0


def robust_noise(predicted: np.ndarray, P: np.ndarray, z: np.ndarray, R: np.ndarray) -> np.ndarray:
    """An object's noise as a fast track weighs it: ``R`` times d^2 / k^2 beyond k = ROBUST_SIGMAS, d^2 the object's
    squared Mahalanobis distance from the track's predicted position (3; ``P`` its 3 x 3 covariance)."""
    nu = z - predicted  # the innovation, its covariance S = P + R
    return R * float(robust_scale(float(nu @ np.linalg.solve(P + R, nu))))


def robust_scale(d2: np.ndarray | float) -> np.ndarray:
    """How much vaguer a fast track takes an object ``d2`` squared sigmas from its prediction: d^2 / k^2 beyond k =
    ROBUST_SIGMAS, else 1 (``robust_noise``)."""
    return np.maximum(1.0, np.asarray(d2, float) / ROBUST_SIGMAS**2)


def within_max_speed(
    x: np.ndarray, P: np.ndarray, fast: np.ndarray, z: np.ndarray, R: np.ndarray, d2: np.ndarray, max_speed: float
) -> np.ndarray:
    """Per track (T: states ``x`` T x 6, covariances ``P`` T x 6 x 6) and object (M: ``z`` M x 3, noise ``R`` M x 3 x 3;
    ``d2`` T x M their squared Mahalanobis distances): does the object leave the track no faster than ``max_speed``,
    its velocity corrected as the track's update would (robustly where ``fast``: ``robust_noise``)? No ball is
    faster, so an object that would push a track past it is not its ball: a young fast track took one 0.7 m off along
    the line of sight, 4 sigmas, went from 25 to 51 m/s and lost its ball for 5 frames (fast_ball seed 2028). A track
    already past the limit (set too low for its balls) is left free."""
    noise = R[None] * np.where(fast[:, None], robust_scale(d2), 1.0)[..., None, None]  # T x M x 3 x 3
    S = P[:, None, :3, :3] + noise
    gain = np.linalg.solve(S, (z[None] - x[:, None, :3])[..., None])[..., 0]  # S^-1 (z - H x)
    after = x[:, None, 3:] + np.einsum("tij,tmj->tmi", P[:, 3:, :3], gain)  # x + K (z - H x), its velocity
    past = np.linalg.norm(after, axis=2) > max_speed
    return ~(past & (np.linalg.norm(x[:, 3:], axis=1) <= max_speed)[:, None])


def flies_across(first: np.ndarray, position: np.ndarray, dt: float, centres: list) -> bool:
    """Has a thing gone from ``first`` to ``position`` in ``dt`` seconds faster than FAST_FLIGHT across some camera's line
    of sight (``centres``: each camera's centre)? Along it a far still thing's depth strays as far from frame to frame.
    A track's second object that does (fast_ball tune seed 74: a ball at 12 m/s stepped from rest to 4.7 m/s, claiming
    1.7 m/s, and ran 0.2-0.3 m off for 9 frames) starts it at the two objects' velocity."""
    return dt > 1e-6 and moved_across_sight(first, position, FAST_FLIGHT * dt, centres)


def moved_across_sight(start: np.ndarray, position: np.ndarray, limit: float, centres: list | None) -> bool:
    """Has a thing gone more than ``limit`` metres from ``start`` to ``position`` across the line of sight of some camera
    (centres: each camera's centre; None: in any direction)?"""
    gone = position - start
    if centres is None:
        return bool(np.linalg.norm(gone) > limit)
    for centre in centres:
        ray = start - centre
        ray = ray / max(float(np.linalg.norm(ray)), 1e-9)
        if np.linalg.norm(gone - (gone @ ray) * ray) > limit:
            return True
    return False
