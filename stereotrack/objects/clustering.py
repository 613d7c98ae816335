"""Particles -> objects: weighted EM with ISODATA-style split / merge / discard (paper III-F).

EM runs on the particles' weights directly (a Gaussian mixture whose
responsibilities are multiplied by each particle's weight). scikit-learn's
GaussianMixture takes no sample weights, so using it means resampling the
particles first; it is kept as ``em: sklearn`` for comparison, and the
weighted EM (``kernels.weighted_em``; the setting's value is still called
``numpy``) is the default: exact for weights and many times faster (see
BENCHMARKS.md).

ISODATA rules, all driven by the ball radius R:
- seed: last frame's objects (warm start), plus the heaviest particle farther
  than ``2 R`` from every seed while it carries enough mass (new balls);
- discard: clusters with too little weight or too few particles;
- merge: two clusters closer than ``R``, or closer than ``2 R`` while no
  camera sees them more than half a ball apart (one ball's cloud is
  elongated along the viewing direction; two balls touching are ``2 R``
  apart and stay two);
- split: a cluster whose particles, projected into some camera, spread wider
  than one ball looks there (``f R / Z``), into two along that direction.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..camera import Camera, stacked_kernel_arrays
from ..config import TrackerSettings
from ..particles.resampling import systematic_indices
from .kernels import greedy_seeds, hard_labels, keep_heavy, label_moments, merge_one_ball_clusters, projected_spreads, weighted_em


@dataclass(frozen=True)
class ClusterSettings:
    """What clustering needs of the tracker's settings (config.TrackerSettings) for one target: defaults are theirs."""

    radius: float  # ball radius R, metres
    min_likelihood: float = TrackerSettings.cluster_min_likelihood
    min_mass: float = TrackerSettings.cluster_min_mass
    min_particles: int = TrackerSettings.cluster_min_particles
    max_objects: int = TrackerSettings.max_objects
    method: str = TrackerSettings.em  # "numpy" (weighted EM) or "sklearn" (GaussianMixture on resampled particles)

    @classmethod
    def of(cls, tracker: TrackerSettings, radius: float) -> ClusterSettings:
        return cls(
            radius, tracker.cluster_min_likelihood, tracker.cluster_min_mass, tracker.cluster_min_particles, tracker.max_objects, tracker.em
        )


ISODATA_ROUNDS = 4  # at most this many rounds of EM then discard / merge / split
EM_ITERATIONS = 4  # EM steps in the first round
LATER_EM_ITERATIONS = 2  # EM steps in later rounds: they only settle local changes
SPLIT_ROUNDS = 2  # splits only in the first rounds, so a cluster cannot split and merge back and forth
EM_POINTS = 250  # EM runs on at most this many particles, resampled by weight
SPLIT_FACTOR = 1.0  # split a cluster whose projected spread (std) exceeds this many apparent ball radii


@dataclass(frozen=True, eq=False)
class Clusters:
    means: np.ndarray  # K x 3
    covariances: np.ndarray  # K x 3 x 3
    masses: np.ndarray  # K, share of the population's weight
    counts: np.ndarray  # K particles
    labels: np.ndarray  # N, cluster index or -1 (not clustered)


def _empty(n: int) -> Clusters:
    return Clusters(np.zeros((0, 3)), np.zeros((0, 3, 3)), np.zeros(0), np.zeros(0, int), np.full(n, -1))


def _sklearn_em(X, w, means, covs, iterations, reg, rng):
    from sklearn.exceptions import ConvergenceWarning
    from sklearn.mixture import GaussianMixture

    idx = systematic_indices(w / w.sum(), min(len(X), 600), rng)
    Xs = X[idx]
    gm = GaussianMixture(
        len(means),
        covariance_type="full",
        max_iter=iterations,
        reg_covar=reg,
        means_init=means,
        precisions_init=np.linalg.inv(covs),
        random_state=int(rng.integers(2**31)),
        tol=1e-4,
    )
    with warnings.catch_warnings():  # a few iterations a frame, as the numpy EM's: stopping short is the design, not news
        warnings.simplefilter("ignore", ConvergenceWarning)  # for the user (two lines on the terminal, frame after frame)
        gm.fit(Xs)
    resp = gm.predict_proba(X)
    return gm.means_, gm.covariances_, gm.weights_, resp


def _views(cameras: Sequence[Camera], X: np.ndarray) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Every particle's projection, visibility and focal length over depth, per camera (computed once)."""
    out = []
    for cam in cameras:
        uv, ok, z = cam.view(X)
        f_over_z = cam.apparent_radius(1.0, z)  # pixels per metre of ball at each particle's depth
        out.append((uv, ok, f_over_z))
    return out


def _split_halves(views, X: np.ndarray, w: np.ndarray, member: np.ndarray, camera: int):
    """The two halves of one cluster across the principal axis of its projection in ``camera``."""
    uv_all, ok_all, _ = views[camera]
    sel = member & ok_all
    uv, ww = uv_all[sel], w[sel] / w[sel].sum()
    d = uv - ww @ uv
    _, evecs = np.linalg.eigh((ww[:, None] * d).T @ d)
    hi = d @ evecs[:, -1] > 0
    if not hi.any() or hi.all():
        return None
    Xs = X[sel]
    return (ww[hi] @ Xs[hi] / ww[hi].sum(), ww[~hi] @ Xs[~hi] / ww[~hi].sum())


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
    X_all, w_all = positions[keep], weights[keep]
    rng = rng or np.random.default_rng(0)
    if len(X_all) > EM_POINTS:
        # EM on a weight-proportional subsample (systematic, so it keeps the weights' shape) is as
        # accurate for ball-sized clusters and several times cheaper; labels come from all particles.
        idx = systematic_indices(w_all / w_all.sum(), EM_POINTS, rng)
        X, w = X_all[idx], np.full(EM_POINTS, w_all.sum() / EM_POINTS)
    else:
        X, w = X_all, w_all
    R = settings.radius
    reg = (R / 4) ** 2
    prev = np.zeros((0, 3)) if prev_means is None else prev_means
    views = _views(cameras, X)
    uv, ok, f_over_z = (np.stack(a) for a in zip(*views))
    means = greedy_seeds(X, w, np.ascontiguousarray(prev, dtype=float), R, settings.min_mass, settings.max_objects, uv, ok, f_over_z)
    if len(means) == 0:
        return _empty(n)
    covs = np.repeat((np.eye(3) * R * R)[None], len(means), axis=0)
    for _round in range(ISODATA_ROUNDS):  # ISODATA: EM, then discard / merge / split, until stable
        iterations = EM_ITERATIONS if _round == 0 else LATER_EM_ITERATIONS
        if settings.method == "sklearn":
            means, covs, pis, resp = _sklearn_em(X, w, means, covs, iterations, reg, rng)
        else:
            means, covs, pis, resp = weighted_em(X, w, means, covs, iterations, reg)
        # Discard light clusters. On a subsample min_particles counts its points: a cluster under min_particles / EM_POINTS
        # of the weight goes (0.032 at the defaults, above min_mass). That is a floor against weak modes the tracker relies
        # on: counted in the population's particles instead, a ball held in a hand (2 % of the weight) stayed a cluster,
        # and so did the empty hand and a prop's edge. Seeds 80-159 (earlier changes were tuned on them too), four tracker seeds each
        # (benchmarks/compare_runs.py): hands -0.68, hue_wall -0.09, static_props -0.63 summed (each within luck),
        # white_ball +0.08; runs under 0.85 in the first three 76 -> 85 of 960. No better, so not changed.
        alive, mass, labels = keep_heavy(resp, w, settings.min_mass, settings.min_particles)
        changed = not alive.all()
        means, covs = means[alive], covs[alive]
        if len(means) == 0:
            return _empty(n)
        # Merge every pair that is one ball (touching balls are 2R apart and stay two).
        kept, means, mass, labels = merge_one_ball_clusters(means, mass, labels, R, *stacked_kernel_arrays(tuple(cameras)))
        covs = covs[kept]
        changed = changed or not kept.all()
        # Split every cluster wider than one ball in some camera (early rounds only: no ping-pong).
        if not changed and _round < SPLIT_ROUNDS:
            new_means, new_covs = [], []
            # A cluster whose 3D spread is under one radius cannot look wider than one ball.
            wide = np.sqrt(np.linalg.eigvalsh(covs)[:, -1]) > SPLIT_FACTOR * R
            ratios, cams = projected_spreads(uv, ok, f_over_z, w, labels, len(means), R)
            ratios = np.where(wide, ratios, 0.0)
            for k in range(len(means)):
                split = ratios[k] > SPLIT_FACTOR and len(means) + len(new_means) < settings.max_objects
                halves = _split_halves(views, X, w, labels == k, cams[k]) if split else None
                if halves is not None:
                    new_means += list(halves)
                    new_covs += [np.eye(3) * R * R] * 2
                    changed = True
                else:
                    new_means.append(means[k])
                    new_covs.append(covs[k])
            means, covs = np.array(new_means), np.array(new_covs)
        if not changed:
            break
    # Final labels (E-step against the final mixture) and weighted statistics over all kept particles.
    means, covs, pis, _ = weighted_em(X, w, means, covs, 1, reg)
    labels = hard_labels(X_all, means, covs, pis)
    K = len(means)
    masses, out_means, out_covs, counts = label_moments(X_all, w_all, labels, K)
    good = (masses >= settings.min_mass) & (counts >= settings.min_particles)
    remap = np.full(K, -1)
    remap[good] = np.arange(good.sum())
    full = np.full(n, -1)
    full[np.flatnonzero(keep)] = remap[labels]
    return Clusters(out_means[good], out_covs[good], masses[good], counts[good], full)
