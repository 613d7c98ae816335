"""Motion: a background model per camera, so scenery of a ball's colour that never moves stops looking like a ball.

The background is a running average of the frames, kept at half resolution
(sensor noise averages out and it costs a quarter), and updated everywhere
except under the discs of the balls the tracks predict: a ball that comes to
rest (in a hand, on a table, at a pendulum's turning point) is never learnt
into the background and stays foreground. A pixel is foreground when it
differs from the background by more than ``threshold`` grey levels, summed
over its three channels. The first frame starts the background, so nothing is foreground in
it: motion adds evidence (a ball moving in front of a wall of its own
colour), it never takes colour evidence away.

The first frame holds the balls too: where one was, the background is the
ball until learnt away, and once it has moved on, a wall of its colour there
differs from it: a "ghost" ball in the moving map. A track that forms on the
ghost keeps it out of the update, and the ghost lasts for ever. So the
background starts as the mean of the frames seen so far (rate 1 / (n + 1) at
the n-th frame, down to ``rate``; OpenCV's MOG2 starts the same way): a
ball's first position fades within a few frames, before a track confirms.
"""

from __future__ import annotations

import cv2
import numpy as np

from ..camera import Camera
from ..results import TrackedBalls
from .kernels import background_step

SCALE = 2  # the background is kept at 1 / SCALE of the image's width and height
KEEP_OUT_MARGIN = 1.5  # the discs kept out of the background update, in ball radii (a ball moves between frames)


class BackgroundModel:
    """One camera's background, learnt as frames come."""

    def __init__(self, camera: Camera, rate: float, threshold: float):
        self.camera = camera
        self.rate = rate  # weight of each new frame in the running average (1 / frames it takes to learn a change)
        self.threshold = threshold  # grey levels
        self._background: np.ndarray | None = None  # float32, half size
        self._frames = 0  # frames learnt so far (the warm-up's running mean)
        self.hsv: np.ndarray | None = None  # the background in HSV (uint8, its grid) as it was before the last frame learnt

    def foreground(self, image: np.ndarray, balls: TrackedBalls | None = None) -> np.ndarray:
        """This frame's foreground at the image's size (H x W uint8 0/1); then learn the frame, except where ``balls`` are."""
        h, w = image.shape[:2]
        return cv2.resize(self.update(image, balls), (w, h), interpolation=cv2.INTER_NEAREST)

    def update(self, image: np.ndarray, balls: TrackedBalls | None = None) -> np.ndarray:
        """This frame's foreground on the background's grid (1 / SCALE of the image's size, uint8 0/1; the
        tracker reads it there, evidence/gather.py); then learn the frame, except where ``balls`` are."""
        h, w = image.shape[:2]
        if self._background is None:
            self._background = cv2.resize(image, (w // SCALE, h // SCALE), interpolation=cv2.INTER_AREA).astype(np.float32)
            self._frames = 1
            return np.zeros(self._background.shape[:2], np.uint8)
        learn = np.ones(self._background.shape[:2], np.uint8)
        if balls is not None and len(balls):
            uv, front, depth = self.camera.view(balls.centres)
            r = self.camera.apparent_radius(balls.radii, depth) * KEEP_OUT_MARGIN / SCALE
            for (u, v), ok, radius in zip(uv, front, r):
                if ok and -w < u < 2 * w and -h < v < 2 * h and radius < w:  # near the image (also not NaN)
                    cv2.circle(learn, (int(round(u / SCALE)), int(round(v / SCALE))), int(np.ceil(radius)) + 1, 0, -1)
        moving = np.empty(learn.shape, np.uint8)
        self.hsv = cv2.cvtColor(cv2.convertScaleAbs(self._background), cv2.COLOR_BGR2HSV)  # what the moving pixels replaced
        background_step(image, self._background, learn, max(self.rate, 1.0 / (self._frames + 1)), self.threshold, moving)
        self._frames += 1
        return moving
