"""Colour-window likelihood of particles (paper eq. 14), vectorised over particles.

    p(z | x) = prod_c max(1, r_c) / W^2

r_c is the number of target-coloured pixels in the W x W window around the
particle's projection in camera c, read in O(1) from the mask's integral
image. A projection outside the image (or behind the camera) counts r = 0,
i.e. the floor: no probability wells, no reward.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from .camera import Camera


def window_counts(integral: np.ndarray, uv: np.ndarray, valid: np.ndarray, window: int) -> np.ndarray:
    """Mask pixels inside the W x W window centred on each pixel position (N x 2).

    Windows that reach past the image edge count only their inside part;
    positions outside the image or not ``valid`` count 0.
    """
    h, w = integral.shape[0] - 1, integral.shape[1] - 1
    half = window // 2
    with np.errstate(invalid="ignore"):
        c = np.rint(np.nan_to_num(uv, nan=-1e9, posinf=-1e9, neginf=-1e9))
    cx = c[:, 0].clip(-1e6, 1e6).astype(np.int64)
    cy = c[:, 1].clip(-1e6, 1e6).astype(np.int64)
    inside = valid & (cx >= 0) & (cx < w) & (cy >= 0) & (cy < h)
    x0 = np.clip(cx - half, 0, w)
    x1 = np.clip(cx + half + 1, 0, w)
    y0 = np.clip(cy - half, 0, h)
    y1 = np.clip(cy + half + 1, 0, h)
    count = integral[y1, x1] - integral[y0, x1] - integral[y1, x0] + integral[y0, x0]
    return np.where(inside, count, 0)


def camera_factor(camera: Camera, integral: np.ndarray, positions: np.ndarray, window: int) -> np.ndarray:
    """One camera's factor max(1, r) / W^2 for every particle."""
    uv, in_front = camera.project(positions)
    r = window_counts(integral, uv, in_front, window)
    return np.maximum(1, r) / float(window * window)


def hidden_by_balls(camera: Camera, positions: np.ndarray, centres: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """Particles whose line of sight from ``camera`` passes through a ball in front of them (N bool).

    A particle inside a ball is not hidden by that ball.
    """
    hidden = np.zeros(len(positions), bool)
    if len(centres) == 0 or len(positions) == 0:
        return hidden
    c = camera.centre
    to_p = positions - c
    dist_p = np.linalg.norm(to_p, axis=1)
    d = to_p / np.maximum(dist_p, 1e-12)[:, None]
    for centre, r in zip(centres, radii):  # a loop over tracked balls, vectorised over particles
        v = centre - c
        along = d @ v
        perp2 = v @ v - along**2
        hidden |= (perp2 < r * r) & (along > 0) & (along < dist_p - r)
    return hidden


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
    out = np.ones(len(positions))
    for cam, integ in zip(cameras, integrals):
        f = camera_factor(cam, integ, positions, window)
        if occluders is not None:
            f = np.where(hidden_by_balls(cam, positions, *occluders), 1.0, f)
        out *= f
    return out
