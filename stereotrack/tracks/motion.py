"""The tracks' motion model: constant velocity under white acceleration noise, gravity known in free flight."""

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
