"""Motion models: how a particle moves from one frame to the next (the sequential part's prediction)."""

from __future__ import annotations

import numpy as np

# Every STOPPED_EVERY-th particle keeps still instead of drifting with its track's velocity. A track's velocity is
# what its ball did up to the last frame: a ball caught in a hand stops at once, and a cloud that drifted on wholly
# overshot it by v dt (7 cm a frame at 2 m/s and 30 fps, two ball radii), found the half-hidden ball no more and was
# resampled away; the track coasted off the held ball (hands tune seed 36: no object for 11 frames of each catch).
# The still ones cost a ball in flight a share of its cloud, and after a throw they stay on the hand it left, where a
# skin of the ball's hue keeps them (every second particle: hands tune seeds 5 and 17 gained a track on the empty
# hand). Tune seeds (hands, hue_wall, static_props, motion_blur, white_ball 0-39; fast_ball 0-159), MOTA summed over
# the six categories against every particle drifting, tracker seeds 0 / 1: every 2nd +2.00 / -2.01, every 4th +1.36 /
# +0.15 (seeds under 0.85: 45 -> 42 / 44 -> 42).
STOPPED_EVERY = 4


class RandomWalk:
    """The paper's isotropic Gaussian random walk, plus the drift of the velocity a particle's track lends it:

    x' = x + s v dt + N(0, sigma^2 I),   s = 0 for every STOPPED_EVERY-th particle, else 1

    Systematic resampling keeps the order of the particles it draws from, and the abductive ones are appended ray
    by ray, so a cloud's particles come in long runs and every STOPPED_EVERY-th is about that share of each cloud.
    """

    def __init__(self, sigma: float, stopped_every: int = STOPPED_EVERY):
        self.sigma = sigma  # metres per frame
        self.stopped_every = stopped_every  # 0: every particle drifts

    def __call__(self, positions: np.ndarray, velocities: np.ndarray, dt: float, rng: np.random.Generator) -> np.ndarray:
        drift = velocities * dt
        if self.stopped_every:
            drift[:: self.stopped_every] = 0.0
        return positions + drift + rng.normal(0.0, self.sigma, positions.shape)
