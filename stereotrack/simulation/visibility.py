"""How much of each ball a rendered camera shows (truth's ``visible`` counts a camera that shows one pixel of it).

A ball behind a prop but for a sliver, or deep in a hand, is "seen" by that count. ``shown`` says how much: the
ball's pixels in the frame's labels (``SceneRenderer.labels``) against the disc a ball of its radius makes at its
depth, f R / z pixels in radius, inside the image (the stretch of a ball far off the axis, up to a fifth more area at
the edge of a 70-degree view, aside). For sorting a tracker's misses (benchmarks/error_classes.py).
"""

from __future__ import annotations

import numpy as np

from .render import SceneRenderer


def shown(renderer: SceneRenderer, frame: int) -> np.ndarray:
    """Per camera and ball (C x B): the share of the ball's disc the camera shows at the frame's time; NaN where the
    ball is not in the scene or its disc lies wholly out of the image or behind the camera."""
    spec = renderer.spec
    centres = renderer.ball_positions(renderer.time(frame))
    present = np.flatnonzero(~np.isnan(centres[:, 0]))
    radii = np.array([b.radius for b in spec.balls], float)
    out = np.full((len(renderer.rig.cameras), len(spec.balls)), np.nan)
    for j, (cam, labels) in enumerate(zip(renderer.rig.cameras, renderer.labels(frame))):
        counts = np.bincount(labels[labels >= 0].ravel(), minlength=len(spec.balls))[: len(spec.balls)]
        uv, front, depth = cam.view(centres[present])
        for k, centre, ahead, r in zip(present, uv, front, cam.apparent_radius(radii[present], depth)):
            disc = _disc_pixels(centre, float(r), cam.width, cam.height) if ahead else 0
            if disc:
                out[j, k] = counts[k] / disc
    return out


def _disc_pixels(centre: np.ndarray, radius: float, width: int, height: int) -> int:
    """Pixels of the image whose centres lie within ``radius`` of ``centre``."""
    x0, x1 = max(int(np.floor(centre[0] - radius)), 0), min(int(np.ceil(centre[0] + radius)) + 1, width)
    y0, y1 = max(int(np.floor(centre[1] - radius)), 0), min(int(np.ceil(centre[1] + radius)) + 1, height)
    if x0 >= x1 or y0 >= y1:
        return 0
    ys, xs = np.ogrid[y0:y1, x0:x1]
    return int(((xs - centre[0]) ** 2 + (ys - centre[1]) ** 2 <= radius * radius).sum())
