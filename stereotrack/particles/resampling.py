"""Resampling a weighted particle set (the sequential part of each step, and EM's subsample of particles)."""

from __future__ import annotations

import numpy as np

from .kernels import systematic_resample


def systematic_indices(weights: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    """Systematic resampling: n indices drawn with probabilities ``weights`` (summing to 1)."""
    return systematic_resample(np.ascontiguousarray(weights, dtype=float), n, rng.random())
