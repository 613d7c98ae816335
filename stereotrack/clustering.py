"""Particles -> objects: weighted EM with ISODATA-style split / merge / discard (paper III-F).

EM runs on the particles' weights directly (a Gaussian mixture whose
responsibilities are multiplied by each particle's weight). scikit-learn's
GaussianMixture takes no sample weights, so using it means resampling the
particles first; it is kept as ``em: sklearn`` for comparison, and the
weighted numpy EM is the default (exact for weights and ~20x faster here:
see BENCHMARKS.md).

ISODATA rules, all driven by the ball radius R:
- seed: last frame's objects (warm start), plus the heaviest particle farther
  than ``2 R`` from every seed while it carries enough mass (new balls);
- discard: clusters with too little weight or too few particles;
- merge: two clusters whose centres are closer than ``R`` (one ball; two
  balls touching are ``2 R`` apart and stay two);
- split: a cluster whose particles, projected into some camera, spread wider
  than one ball looks there (``f R / Z``), into two along that direction.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from .camera import Camera

_LOG2PI = np.log(2 * np.pi)


@dataclass(frozen=True)
class ClusterSettings:
    radius: float  # ball radius R, metres
    min_likelihood: float = 0.05
    min_mass: float = 0.01
    min_particles: int = 8
    max_objects: int = 12
    em_iterations: int = 6
    split_factor: float = 1.0  # split when the projected spread (std) exceeds this many apparent radii
    method: str = "numpy"  # "numpy" (weighted EM) or "sklearn" (GaussianMixture on resampled particles)


@dataclass(frozen=True, eq=False)
class Clusters:
    means: np.ndarray  # K x 3
    covariances: np.ndarray  # K x 3 x 3
    masses: np.ndarray  # K, share of the population's weight
    counts: np.ndarray  # K particles
    labels: np.ndarray  # N, cluster index or -1 (not clustered)


def _empty(n: int) -> Clusters:
    return Clusters(np.zeros((0, 3)), np.zeros((0, 3, 3)), np.zeros(0), np.zeros(0, int), np.full(n, -1))


def _log_gauss(X: np.ndarray, means: np.ndarray, covs: np.ndarray) -> np.ndarray:
    """log N(x | mean_k, cov_k) for every point and component: N x K."""
    L = np.linalg.cholesky(covs)  # K x 3 x 3
    diff = X[None, :, :] - means[:, None, :]  # K x N x 3
    # Solve L y = diff for each component (3x3 triangular, batched).
    y = np.linalg.solve(L, diff.transpose(0, 2, 1))  # K x 3 x N
    maha = (y * y).sum(axis=1)  # K x N
    logdet = 2 * np.log(np.diagonal(L, axis1=1, axis2=2)).sum(axis=1)  # K
    return (-0.5 * (maha + logdet[:, None] + 3 * _LOG2PI)).T


def weighted_em(X: np.ndarray, w: np.ndarray, means: np.ndarray, covs: np.ndarray, iterations: int, reg: float):
    """EM for a Gaussian mixture where point i counts with weight w_i. Returns (means, covs, pis, resp)."""
    k = len(means)
    pis = np.full(k, 1.0 / k)
    eye = np.eye(3) * reg
    resp = None
    for _ in range(iterations):
        logp = _log_gauss(X, means, covs) + np.log(np.maximum(pis, 1e-300))
        logp -= logp.max(axis=1, keepdims=True)
        resp = np.exp(logp)
        resp /= resp.sum(axis=1, keepdims=True)
        rw = resp * w[:, None]  # N x K
        nk = rw.sum(axis=0) + 1e-300
        means = (rw.T @ X) / nk[:, None]
        diff = X[None, :, :] - means[:, None, :]
        covs = np.einsum("kn,kni,knj->kij", rw.T, diff, diff) / nk[:, None, None] + eye
        pis = nk / nk.sum()
    return means, covs, pis, resp


def _sklearn_em(X, w, means, covs, iterations, reg, rng):
    from sklearn.mixture import GaussianMixture

    idx = systematic_indices(w / w.sum(), min(len(X), 600), rng)
    Xs = X[idx]
    gm = GaussianMixture(
        len(means), covariance_type="full", max_iter=iterations, reg_covar=reg, means_init=means,
        precisions_init=np.linalg.inv(covs), random_state=int(rng.integers(2**31)), tol=1e-4,
    )
    gm.fit(Xs)
    resp = gm.predict_proba(X)
    return gm.means_, gm.covariances_, gm.weights_, resp


def systematic_indices(weights: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    """Systematic resampling: n indices drawn with probabilities ``weights`` (summing to 1)."""
    cdf = np.cumsum(weights)
    cdf[-1] = 1.0
    u = (rng.random() + np.arange(n)) / n
    return np.searchsorted(cdf, u, side="right").clip(0, len(weights) - 1)


def _seeds(X, w, prev_means, radius, min_mass, max_objects):
    """Warm-start seeds (previous objects with mass nearby) + greedy new modes."""
    seeds = []
    near_r2 = (2 * radius) ** 2
    for m in prev_means:
        d2 = ((X - m) ** 2).sum(1)
        near = d2 < near_r2
        if w[near].sum() >= min_mass:
            seeds.append(np.average(X[near], axis=0, weights=w[near]))
    free = np.ones(len(X), bool)
    for s in seeds:
        free &= ((X - s) ** 2).sum(1) >= near_r2
    while len(seeds) < max_objects and free.any():
        i = np.flatnonzero(free)[np.argmax(w[free])]
        d2 = ((X - X[i]) ** 2).sum(1)
        near = d2 < near_r2
        free &= ~near
        if w[near].sum() >= min_mass:
            seeds.append(np.average(X[near], axis=0, weights=w[near]))
    return np.array(seeds).reshape(-1, 3)


def _projected_spread(cameras: Sequence[Camera], X: np.ndarray, w: np.ndarray, mean: np.ndarray, radius: float):
    """Largest ratio (projected std / apparent ball radius) over cameras, and its camera's split direction in 3D."""
    best, direction = 0.0, None
    for cam in cameras:
        uv, ok = cam.project(X)
        if ok.sum() < 3:
            continue
        ww = w[ok] / w[ok].sum()
        c = (ww[:, None] * uv[ok]).sum(0)
        d = uv[ok] - c
        cov = (ww[:, None, None] * d[:, :, None] * d[:, None, :]).sum(0)
        evals, evecs = np.linalg.eigh(cov)
        z = cam.depth(mean[None])[0]
        if z <= 0:
            continue
        r_px = 0.5 * (cam.K[0, 0] + cam.K[1, 1]) * radius / z
        ratio = np.sqrt(max(evals[-1], 0.0)) / r_px
        if ratio > best:
            # Split along the 3D direction whose projection is the image's principal axis.
            proj = (uv[ok] - c) @ evecs[:, -1]
            hi = proj > 0
            if hi.any() and (~hi).any():
                a = np.average(X[ok][hi], axis=0, weights=ww[hi])
                b = np.average(X[ok][~hi], axis=0, weights=ww[~hi])
                best, direction = ratio, (a, b)
    return best, direction


def cluster_particles(
    positions: np.ndarray,
    weights: np.ndarray,
    likelihoods: np.ndarray,
    cameras: Sequence[Camera],
    settings: ClusterSettings,
    prev_means: np.ndarray | None = None,
    rng: np.random.Generator | None = None,
) -> Clusters:
    """Cluster one target's weighted particles into ball-sized objects."""
    n = len(positions)
    keep = likelihoods >= settings.min_likelihood
    if keep.sum() < settings.min_particles:
        return _empty(n)
    X, w = positions[keep], weights[keep]
    R = settings.radius
    reg = (R / 4) ** 2
    prev = np.zeros((0, 3)) if prev_means is None else prev_means
    means = _seeds(X, w, prev, R, settings.min_mass, settings.max_objects)
    if len(means) == 0:
        return _empty(n)
    covs = np.repeat((np.eye(3) * R * R)[None], len(means), axis=0)
    rng = rng or np.random.default_rng(0)
    for _round in range(4):  # ISODATA: EM, then discard / merge / split, until stable
        if settings.method == "sklearn":
            means, covs, pis, resp = _sklearn_em(X, w, means, covs, settings.em_iterations, reg, rng)
        else:
            means, covs, pis, resp = weighted_em(X, w, means, covs, settings.em_iterations, reg)
        labels = resp.argmax(axis=1)
        mass = np.bincount(labels, weights=w, minlength=len(means))
        count = np.bincount(labels, minlength=len(means))
        changed = False
        alive = (mass >= settings.min_mass) & (count >= settings.min_particles)
        if not alive.all():
            means, covs, changed = means[alive], covs[alive], True
            if len(means) == 0:
                return _empty(n)
            continue
        # Merge the closest pair if it is closer than one radius.
        if len(means) > 1:
            d = np.linalg.norm(means[:, None] - means[None], axis=2) + np.eye(len(means)) * 1e9
            i, j = np.unravel_index(np.argmin(d), d.shape)
            if d[i, j] < R:
                wi, wj = mass[i], mass[j]
                means[i] = (wi * means[i] + wj * means[j]) / (wi + wj)
                means, covs = np.delete(means, j, 0), np.delete(covs, j, 0)
                continue
        # Split the widest cluster if it is wider than one ball in some camera.
        if len(means) < settings.max_objects:
            worst, split = 0.0, None
            for k in range(len(means)):
                member = labels == k
                ratio, halves = _projected_spread(cameras, X[member], w[member], means[k], R)
                if ratio > settings.split_factor and ratio > worst and halves is not None:
                    worst, split = ratio, (k, halves)
            if split is not None:
                k, (a, b) = split
                means = np.vstack([np.delete(means, k, 0), a, b])
                covs = np.concatenate([np.delete(covs, k, 0), np.repeat((np.eye(3) * R * R)[None], 2, axis=0)])
                changed = True
                continue
        if not changed:
            break
    # Final labels and per-cluster weighted statistics over the kept particles.
    labels = weighted_em(X, w, means, covs, 1, reg)[3].argmax(axis=1)  # E-step against the final means
    K = len(means)
    out_means = np.zeros((K, 3))
    out_covs = np.zeros((K, 3, 3))
    masses = np.bincount(labels, weights=w, minlength=K)
    counts = np.bincount(labels, minlength=K)
    for k in range(K):
        m = labels == k
        if not m.any():
            continue
        ww = w[m] / w[m].sum()
        out_means[k] = ww @ X[m]
        d = X[m] - out_means[k]
        out_covs[k] = (ww[:, None] * d).T @ d
    good = (masses >= settings.min_mass) & (counts >= settings.min_particles)
    remap = np.full(K, -1)
    remap[good] = np.arange(good.sum())
    full = np.full(n, -1)
    full[np.flatnonzero(keep)] = remap[labels]
    return Clusters(out_means[good], out_covs[good], masses[good], counts[good], full)
