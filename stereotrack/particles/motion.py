"""Motion models: how a particle moves from one frame to the next (the sequential part's prediction)."""

from __future__ import annotations

import numpy as np


class RandomWalk:
    """The paper's isotropic Gaussian random walk, plus the drift of the velocity a particle's track lends it:

    x' = x + v dt + N(0, sigma^2 I)
    """

    def __init__(self, sigma: float):
        self.sigma = sigma  # metres per frame

    def __call__(self, positions: np.ndarray, velocities: np.ndarray, dt: float, rng: np.random.Generator) -> np.ndarray:
        return positions + velocities * dt + rng.normal(0.0, self.sigma, positions.shape)
