"""Compiled loops of the track stage: the Kalman filter's steps and association costs (``manager.py``).

See ``stereotrack/kernels.py`` for how kernels are compiled, cached and warmed up.
"""

from __future__ import annotations

import numpy as np

from ..kernels import _inverse_logdet, kernel


@kernel
def association_costs(positions, covs, z, R):
    """Every (track, object) pair's squared Mahalanobis distance d2 and its negative log-likelihood
    cost d2 + log det S, S = P_track + R_object (positions T x 3 with covariances T x 3 x 3, objects
    M x 3 with R M x 3 x 3). Returns (d2, cost), both T x M."""
    T, M = positions.shape[0], z.shape[0]
    d2 = np.empty((T, M))
    cost = np.empty((T, M))
    for a in range(T):
        for b in range(M):
            inv, logdet = _inverse_logdet(covs[a] + R[b])
            y0, y1, y2 = z[b, 0] - positions[a, 0], z[b, 1] - positions[a, 1], z[b, 2] - positions[a, 2]
            m = (
                inv[0, 0] * y0 * y0
                + inv[1, 1] * y1 * y1
                + inv[2, 2] * y2 * y2
                + 2.0 * (inv[0, 1] * y0 * y1 + inv[0, 2] * y0 * y2 + inv[1, 2] * y1 * y2)
            )
            d2[a, b] = m
            cost[a, b] = m + logdet
    return d2, cost


@kernel
def kalman_predict(x, P, F, Q, b):
    """One Kalman prediction: (F x + b, F P F' + Q) for a 6-state."""
    n = x.shape[0]
    x2 = b.copy()
    FP = np.zeros((n, n))
    for i in range(n):
        for k in range(n):
            if F[i, k] != 0.0:
                x2[i] += F[i, k] * x[k]
                for j in range(n):
                    FP[i, j] += F[i, k] * P[k, j]
    P2 = Q.copy()
    for i in range(n):
        for j in range(n):
            acc = 0.0
            for k in range(n):
                acc += FP[i, k] * F[j, k]
            P2[i, j] += acc
    return x2, P2


@kernel
def kalman_correct(x, P, z, R):
    """One Kalman update with a position measurement z (covariance R) of the state's first 3 entries
    (H = [I 0]); the covariance in Joseph form, which stays symmetric positive definite."""
    n = x.shape[0]
    Sinv, _ = _inverse_logdet(P[:3, :3] + R)
    K = np.zeros((n, 3))  # P H' S^-1
    for i in range(n):
        for a in range(3):
            for c in range(3):
                K[i, a] += P[i, c] * Sinv[c, a]
    x2 = x.copy()
    for i in range(n):
        for a in range(3):
            x2[i] += K[i, a] * (z[a] - x[a])
    A = np.eye(n)  # I - K H
    for i in range(n):
        for a in range(3):
            A[i, a] -= K[i, a]
    KR = np.zeros((n, 3))
    for i in range(n):
        for a in range(3):
            for c in range(3):
                KR[i, a] += K[i, c] * R[c, a]
    AP = np.zeros((n, n))
    for i in range(n):
        for k in range(n):
            for j in range(n):
                AP[i, j] += A[i, k] * P[k, j]
    P2 = np.zeros((n, n))
    for i in range(n):
        for j in range(n):
            acc = 0.0
            for k in range(n):
                acc += AP[i, k] * A[j, k]
            for a in range(3):
                acc += KR[i, a] * K[j, a]
            P2[i, j] = acc
    return x2, P2
