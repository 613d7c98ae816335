"""Abductive proposal (paper section III-E): colour blobs -> viewing rays -> particles on rays.

Particles go uniformly along each blob's viewing ray, between the depths the
ball's apparent size allows, and around the points where the rays of two
cameras cross (the blobs come from ``evidence/blobs.py``).
"""

from __future__ import annotations

import numpy as np

from ..camera import Camera
from .kernels import crossing_points


def depth_range_from_size(
    camera: Camera, radius_px: np.ndarray, ball_radius: float, d_min: float, d_max: float, slack: float = 1.6
) -> tuple[np.ndarray, np.ndarray]:
    """Distance range along each blob's ray implied by the ball's apparent size.

    A ball of radius R at distance Z looks about f R / Z pixels wide; a blob
    clipped by the image edge or another ball looks smaller, so only the
    lower bound of the size is trusted loosely (``slack`` either way).
    Blobs of unknown size (NaN) keep [d_min, d_max].
    """
    f = camera.focal_px
    known = radius_px > 0  # NaN is not
    z = f * ball_radius / np.where(known, radius_px, 1.0)
    near = np.where(known, np.clip(z / slack, d_min, d_max), d_min)
    far = np.where(known, np.clip(z * slack, d_min, d_max), d_max)
    far = np.maximum(far, near + 1e-3)
    return near, far


def particles_on_rays(
    origins: np.ndarray,
    directions: np.ndarray,
    near: np.ndarray,
    far: np.ndarray,
    n: int,
    rng: np.random.Generator,
) -> tuple[np.ndarray, np.ndarray]:
    """``n`` particles shared fairly among M rays, uniform in distance between near and far.

    Returns (positions n x 3, ray index n).
    """
    m = len(origins)
    if m == 0 or n == 0:
        return np.zeros((0, 3)), np.zeros(0, int)
    # Fair share: every ray gets n // m, the remainder goes to a random subset.
    counts = np.full(m, n // m)
    counts[rng.permutation(m)[: n - counts.sum()]] += 1
    ray = np.repeat(np.arange(m), counts)
    dist = near[ray] + rng.random(n) * (far[ray] - near[ray])
    return origins[ray] + dist[:, None] * directions[ray], ray


def ray_crossings(cameras, blobs, radius: float, d_min: float, d_max: float, skip=None, slack: float = 1.6, rays=None) -> np.ndarray:
    """Where blob rays of two cameras (nearly) meet: K x 3 midpoints of their closest approach.

    A ball seen in two views sits where its two rays cross; so does a stereo
    ghost (ball A's ray in one view with ball B's in the other), which the
    explain-away stage drops later. Pairs whose rays pass farther apart than
    one ball radius, meet outside [d_min, d_max], or whose blobs are more than
    ``slack`` times larger or smaller than a ball there would look (a
    same-coloured poster on the wall, most ghosts) are not crossings, nor
    are blobs marked in ``skip`` (per camera, a bool per blob). ``rays``: the
    blobs' viewing rays per camera, (origins, directions), if already known.
    """
    if rays is None:
        rays = [cam.rays(b.centres) for cam, b in zip(cameras, blobs)]
    rays = [r if len(b) else None for r, b in zip(rays, blobs)]
    use = [np.ones(len(b), bool) if skip is None else ~np.asarray(skip[j], bool) for j, b in enumerate(blobs)]
    out = [
        crossing_points(
            *rays[j],
            blobs[j].radii,
            use[j],
            *rays[k],
            blobs[k].radii,
            use[k],
            cameras[j].R,
            cameras[j].t,
            cameras[j].focal_px,
            cameras[k].R,
            cameras[k].t,
            cameras[k].focal_px,
            radius,
            d_min,
            d_max,
            slack,
        )
        for j in range(len(rays))
        for k in range(j + 1, len(rays))
        if rays[j] is not None and rays[k] is not None
    ]
    return np.vstack(out) if out else np.zeros((0, 3))
