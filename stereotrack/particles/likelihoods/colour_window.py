"""The colour-window likelihood of the paper (eq. 14), vectorised over particles: ``tracker.likelihood: colour_window``.

    p(z | x) = prod_c max(1, r_c) / W^2

r_c is the number of target-coloured pixels in the W x W window around the
particle's projection in camera c, read in O(1) from the mask's integral
image. A projection outside the image (or behind the camera) counts r = 0,
i.e. the floor: no probability wells, no reward.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ...camera import Camera
from ...config import Target, TrackerSettings
from ...evidence.gather import CameraEvidence
from ...results import TrackedBalls
from .. import kernels


def window_counts(integral: np.ndarray, uv: np.ndarray, valid: np.ndarray, window: int) -> np.ndarray:
    """Mask pixels inside the W x W window centred on each pixel position (N x 2).

    Windows that reach past the image edge count only their inside part;
    positions outside the image or not ``valid`` count 0.
    """
    return kernels.window_counts(integral, np.ascontiguousarray(uv, dtype=float), np.ascontiguousarray(valid, dtype=bool), window)


def hidden_by_balls(camera: Camera, positions: np.ndarray, centres: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """Particles whose line of sight from ``camera`` passes through a ball in front of them (N bool).

    A particle inside a ball is not hidden by that ball.
    """
    f64 = lambda a: np.ascontiguousarray(a, dtype=float).reshape(-1, 3)  # noqa: E731
    return kernels.hidden_by_balls(camera.centre, f64(positions), f64(centres), np.ascontiguousarray(radii, dtype=float))


def likelihood(
    cameras: Sequence[Camera],
    integrals: Sequence[np.ndarray],
    positions: np.ndarray,
    window: int,
    occluders: tuple[np.ndarray, np.ndarray] | None = None,
) -> np.ndarray:
    """Eq. 14: the product over cameras of max(1, r_c) / W^2 (cameras independent).

    With ``occluders`` (centres B x 3, radii B) of tracked balls, a camera whose
    view of a particle is blocked by one of them says nothing about it (factor
    1): the ball in front, not the particle, decides what that camera sees.
    """
    positions = np.ascontiguousarray(positions, dtype=float).reshape(-1, 3)
    centres, radii = occluders if occluders is not None else (np.zeros((0, 3)), np.zeros(0))
    centres = np.ascontiguousarray(centres, dtype=float).reshape(-1, 3)
    radii = np.ascontiguousarray(radii, dtype=float)
    out = np.ones(len(positions))
    for cam, integ in zip(cameras, integrals):
        kernels.camera_likelihood(out, positions, *cam._kernel_arrays, integ, window, cam.centre, centres, radii)
    return out


class Model:
    """Eq. 14 over the target's mask in every camera: the product of max(1, r_c) / W^2."""

    def __init__(self, window: int, occlusion: bool = True):
        self.window = window  # W, pixels (odd)
        self.occlusion = occlusion  # a camera whose view a ball of another colour blocks says nothing

    @classmethod
    def from_settings(cls, settings: TrackerSettings, target: Target) -> Model:
        return cls(settings.window, settings.occlusion)

    def __call__(self, positions: np.ndarray, views: Sequence[CameraEvidence], occluders: TrackedBalls | None) -> np.ndarray:
        blockers = (occluders.centres, occluders.radii) if self.occlusion and occluders is not None and len(occluders) else None
        return likelihood([v.camera for v in views], [v.integral for v in views], positions, self.window, blockers)


ColourWindow = Model
