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
TRAVEL = 2.0  # a track keeps its disc out of the background once it has gone this many ball radii from where it started ...
SETTLED_FRAMES = 8  # ... or once it has lived this many frames (a ghost under it is learnt by then: ABSORB_FRAMES; 10 lost a pendulum ball at a turning point)
ABSORB_FRAMES = 5  # a moving patch none of whose cells changed for this many frames, under no travelled ball, is background at once
MIN_GHOST_CELLS = 2  # fewer calm moving cells than this (a speck of noise) are left to the running average
GAIN_STEP = 8  # the lighting's gain is measured on every GAIN_STEP-th background cell in each direction


class BackgroundModel:
    """One camera's background, learnt as frames come."""

    def __init__(self, camera: Camera, rate: float, threshold: float):
        self.camera = camera
        self.rate = rate  # weight of each new frame in the running average (1 / frames it takes to learn a change)
        self.threshold = threshold  # grey levels
        self._background: np.ndarray | None = None  # float32, half size
        self._frames = 0  # frames learnt so far (the warm-up's running mean)
        self.hsv: np.ndarray | None = None  # the background in HSV (uint8, its grid) as it was before the last frame learnt
        self._previous: np.ndarray | None = None  # uint8, the last frame at that size (after its gain)
        self._calm: np.ndarray | None = None  # uint8, frames in a row each cell has not changed (at most 255)
        self._start: dict[int, np.ndarray] = {}  # where each track was first seen
        self._age: dict[int, int] = {}  # frames each track has been seen
        self._travelled: set[int] = set()  # the tracks that have moved from there, or lived SETTLED_FRAMES

    def foreground(self, image: np.ndarray, balls: TrackedBalls | None = None) -> np.ndarray:
        """This frame's foreground at the image's size (H x W uint8 0/1); then learn the frame, except where ``balls`` are."""
        h, w = image.shape[:2]
        return cv2.resize(self.update(image, balls), (w, h), interpolation=cv2.INTER_NEAREST)

    def update(self, image: np.ndarray, balls: TrackedBalls | None = None) -> np.ndarray:
        """This frame's foreground on the background's grid (1 / SCALE of the image's size, uint8 0/1; the
        tracker reads it there, evidence/gather.py); then learn the frame, except where ``balls`` are."""
        h, w = image.shape[:2]
        if self._background is None:
            self._previous = cv2.resize(image, (w // SCALE, h // SCALE), interpolation=cv2.INTER_AREA)
            self._background = self._previous.astype(np.float32)
            self._calm = np.zeros(self._background.shape[:2], np.uint8)
            self._frames = 1
            return np.zeros(self._background.shape[:2], np.uint8)
        learn = np.ones(self._background.shape[:2], np.uint8)
        balls = self._moved(balls)
        if balls is not None and len(balls):
            uv, front, depth = self.camera.view(balls.centres)
            r = self.camera.apparent_radius(balls.radii, depth) * KEEP_OUT_MARGIN / SCALE
            for (u, v), ok, radius in zip(uv, front, r):
                if ok and -w < u < 2 * w and -h < v < 2 * h and radius < w:  # near the image (also not NaN)
                    cv2.circle(learn, (int(round(u / SCALE)), int(round(v / SCALE))), int(np.ceil(radius)) + 1, 0, -1)
        moving = np.empty(learn.shape, np.uint8)
        self.hsv = cv2.cvtColor(cv2.convertScaleAbs(self._background), cv2.COLOR_BGR2HSV)  # what the moving pixels replaced
        gain = self._gain(image)
        rate = max(self.rate, 1.0 / (self._frames + 1))  # a running mean at first (warm-up), as MOG2 does
        background_step(image, self._background, self._previous, self._calm, learn, gain, rate, self.threshold, moving)
        self._frames += 1
        self._absorb_ghosts(moving, learn)
        return moving

    def _absorb_ghosts(self, moving: np.ndarray, learn: np.ndarray) -> None:
        """Learn at once the moving patches none of whose cells has changed for ABSORB_FRAMES frames: a ghost
        (the room a ball uncovered, which the background still holds the ball in front of) or a thing that
        stopped, untracked. A moving thing's patch changes at its edges, a tracked ball's is kept out (``learn``)."""
        calm = self._calm >= ABSORB_FRAMES
        if np.count_nonzero(cv2.bitwise_and(moving, calm.view(np.uint8))) < MIN_GHOST_CELLS:
            return
        n, labels = cv2.connectedComponents(moving, connectivity=8)
        changing = np.zeros(n, bool)
        changing[0] = True  # the label of what does not move
        changing[labels[(moving > 0) & ~calm]] = True  # a patch with a cell that changed lately is a thing that moves
        still = ~changing[labels] & (learn > 0)
        self._background[still] = self._previous[still]
        moving[still] = 0

    def _moved(self, balls: TrackedBalls | None) -> TrackedBalls | None:
        """The tracked balls that have travelled since their track began, or lived SETTLED_FRAMES frames: only they
        keep the background from learning their discs. A new track that has not moved may hold a ghost (a ball
        that sat there when the background started, then left): protected, it would stay foreground for ever."""
        if balls is None or not len(balls):
            self._start.clear()
            self._age.clear()
            self._travelled.clear()
            return balls
        ids = balls.track_ids.tolist()
        for tid, centre, radius in zip(ids, balls.centres, balls.radii):
            start = self._start.setdefault(tid, centre)
            self._age[tid] = self._age.get(tid, 0) + 1
            if tid not in self._travelled and (np.linalg.norm(centre - start) > TRAVEL * radius or self._age[tid] >= SETTLED_FRAMES):
                self._travelled.add(tid)
        live = set(ids)
        self._start = {k: v for k, v in self._start.items() if k in live}
        self._age = {k: v for k, v in self._age.items() if k in live}
        self._travelled &= live
        return balls.where(np.array([tid in self._travelled for tid in ids], bool))

    def _gain(self, image: np.ndarray) -> np.ndarray:
        """Per channel, what this frame must be multiplied by to match the background where the room did not
        change: the median ratio over a grid of cells (a ball or a hand moves over a few of them, a light that
        dims or flickers, or a camera's exposure that hunts, changes them all)."""
        then = self._background[::GAIN_STEP, ::GAIN_STEP]
        rows, cols = then.shape[:2]
        now = (
            image[: SCALE * GAIN_STEP * rows : SCALE * GAIN_STEP, : SCALE * GAIN_STEP * cols : SCALE * GAIN_STEP]
            .reshape(-1, 3)
            .astype(np.float32)
        )
        then = then.reshape(-1, 3)
        ok = (now > 20) & (now < 250) & (then > 20)
        gain = np.ones(3, np.float32)
        for c in range(3):
            if ok[:, c].sum() > 100:
                gain[c] = np.median(then[ok[:, c], c] / now[ok[:, c], c])
        gain[np.abs(gain - 1.0) < 0.005] = 1.0
        return gain
