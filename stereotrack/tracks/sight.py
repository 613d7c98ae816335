"""Where tracks are in the cameras' images: what a 3D distance cannot tell along a ray."""

from __future__ import annotations

import numpy as np

from ..camera import Rig

# One ball in every view (``on_balls``): within this many ball radii of a track's ball, or of the streak it drew since
# the last frame, in every camera's image. Along a ray two places metres apart can be that.
SHADOW_RADII = 2.0


def in_view(rig: Rig | None, positions: np.ndarray) -> np.ndarray:
    """Per position (N x 3): inside every camera's image (always true without a rig)."""
    inside = np.ones(len(positions), bool)
    if rig is None or not len(positions):
        return inside
    for cam in rig.cameras:
        uv, ok = cam.project(positions)
        inside &= ok & cam.in_image(uv)
    return inside


def on_balls(rig: Rig | None, radius: float, points: np.ndarray, ends: np.ndarray, velocities: np.ndarray, dt: float) -> np.ndarray:
    """Per point (N x 3) and ball (at ``ends``, M x 3, moving at ``velocities``): is the point, in every camera's image,
    within SHADOW_RADII ball radii (``radius``, metres) of the ball or of the streak it drew over the last ``dt`` seconds?
    All false without a rig or a radius."""
    near = np.zeros((len(points), len(ends)), bool)
    if rig is None or not len(points) or not len(ends) or radius <= 0.0:
        return near
    near[:] = True
    starts = ends - dt * velocities
    for cam in rig.cameras:
        q, q_ok = cam.project(points)
        b, b_ok, depth = cam.view(ends)
        a, a_ok = cam.project(starts)
        a = np.where(a_ok[:, None], a, b)  # a streak from behind the camera: its ball alone
        # Distance from each point's pixel to each ball's segment a -> b (its frame's streak).
        ab = b - a
        w = np.clip(np.einsum("nmk,mk->nm", q[:, None] - a[None], ab) / np.maximum(np.einsum("mk,mk->m", ab, ab), 1e-12), 0.0, 1.0)
        gap = np.linalg.norm(q[:, None] - (a[None] + w[..., None] * ab[None]), axis=2)
        near &= q_ok[:, None] & b_ok[None] & (gap <= SHADOW_RADII * cam.apparent_radius(radius, depth)[None])
    return near
