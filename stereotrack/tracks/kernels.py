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


@kernel
def rts_oldest(xf, Pf, xp, Pp, F, linked):
    """The Rauch-Tung-Striebel smoother's estimate of a track's oldest state from its later ones: K filtered states
    (xf K x 6, Pf K x 6 x 6, oldest first), and for each the prediction into it from the one before (xp, Pp, F;
    ``linked[k]`` False where the state was set anew, not predicted: a catch, a restart). Back from the newest,
    where smoothed equals filtered:
        C_k = Pf_k F_k+1' Pp_k+1^-1
        xs_k = xf_k + C_k (xs_k+1 - xp_k+1)
        Ps_k = Pf_k + C_k (Ps_k+1 - Pp_k+1) C_k'
    past a break (or a prediction whose covariance is singular) the smoothing starts over from the filtered state.
    Returns (xs_0, Ps_0)."""
    K = xf.shape[0]
    xs = xf[K - 1].copy()
    Ps = Pf[K - 1].copy()
    for k in range(K - 2, -1, -1):
        if not linked[k + 1]:
            xs = xf[k].copy()
            Ps = Pf[k].copy()
            continue
        try:
            Pinv = np.linalg.inv(Pp[k + 1])
        except Exception:  # a prediction certain along some axis (accel_noise and init_speed_sigma 0): no gain, start over
            xs = xf[k].copy()
            Ps = Pf[k].copy()
            continue
        C = Pf[k] @ F[k + 1].T @ Pinv
        xs = xf[k] + C @ (xs - xp[k + 1])
        Ps = Pf[k] + C @ (Ps - Pp[k + 1]) @ C.T
    return xs, Ps
