"""A ball in free flight: the parabola under known gravity through its recent positions, and where it lands.

The track manager decides *whether* a ball flies freely (``in_free_flight``:
a parabola with a free acceleration accelerates like gravity); once it does,
gravity is known, so only the position and velocity are fitted (two unknowns
per axis instead of three: steadier from a few frames). ``landing`` then
says where and when that parabola comes down through a height the user
chose, e.g. a catcher's hand or the floor.
"""

from __future__ import annotations

import math

import numpy as np

from ..results import Parabola


def in_free_flight(times: np.ndarray, positions: np.ndarray, gravity: np.ndarray) -> bool:
    """Does a parabola fitted to these positions accelerate like gravity (within half of g) rather than not at all?"""
    t = times - times.mean()
    A = np.stack([np.ones_like(t), t, 0.5 * t * t], axis=1)
    coef, *_ = np.linalg.lstsq(A, positions, rcond=None)
    accel = coef[2]
    return bool(np.linalg.norm(accel - gravity) < 0.5 * np.linalg.norm(gravity))


def fit_parabola(times: np.ndarray, positions: np.ndarray, gravity: np.ndarray) -> Parabola:
    """Least-squares position and velocity at the latest time, with gravity as the known acceleration.

    ``times`` (N >= 2 seconds, not all equal), ``positions`` (N x 3 metres), ``gravity`` (3, m/s^2).
    """
    times = np.asarray(times, float)
    gravity = np.asarray(gravity, float)
    dt = times - times[-1]
    # positions - gravity dt^2 / 2 = p + v dt: a straight-line fit per axis, in closed form
    y = np.asarray(positions, float) - 0.5 * dt[:, None] ** 2 * gravity
    mean_t = dt.mean()
    spread = dt - mean_t
    velocity = spread @ (y - y.mean(axis=0)) / (spread @ spread)
    position = y.mean(axis=0) - velocity * mean_t
    return Parabola(float(times[-1]), position, velocity, gravity.copy())


def landing(flight: Parabola, height: float, after: float | None = None) -> tuple[np.ndarray, float] | None:
    """Where (world point) and when (seconds) the parabola comes down through ``height`` metres along the up axis.

    The up axis is the one gravity points against. None when the parabola never
    reaches that height, or came down through it before ``after`` (default: the
    parabola's own time), i.e. the ball is already below it and falling.
    """
    # plain floats: this runs per flying ball and frame in the network sender, where numpy's per-call cost dominates
    acc, pos, vel = flight.acceleration.tolist(), flight.position.tolist(), flight.velocity.tolist()
    g = math.hypot(*acc)
    if g <= 0:
        return None
    up = [-a / g for a in acc]
    h0 = sum(p * u for p, u in zip(pos, up)) - height  # height above the landing plane
    vh = sum(v * u for v, u in zip(vel, up))
    disc = vh * vh + 2.0 * g * h0
    if disc < 0:  # the apex stays below the plane
        return None
    dt = (vh + math.sqrt(disc)) / g  # the later root: on the way down
    when = flight.time + dt
    if when < (flight.time if after is None else after):
        return None
    point = np.array([p + v * dt + 0.5 * a * dt * dt for p, v, a in zip(pos, vel, acc)])
    return point, float(when)
