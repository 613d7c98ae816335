"""The track stage's compiled kernels against the textbook formulas."""

import numpy as np

from stereotrack.tracks import kernels as track_kernels
from stereotrack.tracks.manager import motion_model


def test_kalman_steps_match_the_textbook_formulas():
    rng = np.random.default_rng(2)
    F, Q, b = motion_model(1 / 30, 30.0, np.array([0.0, 0.0, -9.81]))
    H = np.hstack([np.eye(3), np.zeros((3, 3))])
    for _ in range(20):
        A, B = rng.normal(size=(6, 6)), rng.normal(size=(3, 3))
        P, R = A @ A.T + 0.1 * np.eye(6), B @ B.T + 0.01 * np.eye(3)
        x, z = rng.normal(size=6), rng.normal(size=3)
        xp, Pp = track_kernels.kalman_predict(x, P, F, Q, b)
        assert np.allclose(xp, F @ x + b) and np.allclose(Pp, F @ P @ F.T + Q)
        K = P @ H.T @ np.linalg.inv(H @ P @ H.T + R)
        IKH = np.eye(6) - K @ H
        xc, Pc = track_kernels.kalman_correct(x, P, z, R)
        assert np.allclose(xc, x + K @ (z - H @ x)) and np.allclose(Pc, IKH @ P @ IKH.T + K @ R @ K.T)


def test_association_costs_match_numpy():
    rng = np.random.default_rng(6)
    pos, z = rng.normal(size=(4, 3)), rng.normal(size=(5, 3))
    A, B = rng.normal(size=(4, 3, 3)), rng.normal(size=(5, 3, 3))
    P, R = A @ A.transpose(0, 2, 1) + 0.1 * np.eye(3), B @ B.transpose(0, 2, 1) + 0.01 * np.eye(3)
    d2, cost = track_kernels.association_costs(pos, P, z, R)
    S = P[:, None] + R[None]
    y = z[None] - pos[:, None]
    want = np.einsum("tmi,tmi->tm", y, np.linalg.solve(S, y[..., None])[..., 0])
    assert np.allclose(d2, want) and np.allclose(cost, want + np.linalg.slogdet(S)[1])
