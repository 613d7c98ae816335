"""How much of each ball a rendered camera shows (truth's ``visible`` counts a camera that shows one pixel of it).

A ball behind a prop but for a sliver, or deep in a hand, is "seen" by that count. ``shown`` says how much: the
ball's pixels in the frame's labels (``SceneRenderer.labels``) against the disc a ball of its radius makes at its
depth (``render.disc_shares``, which truth's ``clear`` counts too). For sorting a tracker's misses
(benchmarks/error_classes.py).
"""

from __future__ import annotations

import numpy as np

from .render import SceneRenderer, disc_shares


def shown(renderer: SceneRenderer, frame: int) -> np.ndarray:
    """Per camera and ball (C x B): the share of the ball's disc the camera shows at the frame's time
    (``render.disc_shares``); NaN where the ball is not in the scene or its disc lies wholly out of the image or behind
    the camera."""
    n = len(renderer.spec.balls)
    counts = [np.bincount(labels[labels >= 0].ravel(), minlength=n)[:n] for labels in renderer.labels(frame)]
    radii = np.array([b.radius for b in renderer.spec.balls], float)
    return disc_shares(renderer.rig.cameras, renderer.ball_positions(renderer.time(frame)), radii, counts)
