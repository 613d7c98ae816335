"""Learning a target from a ball's pixels: its HSV range, its colour model, and how well that tells ball from room.

The ball's pixels come from regions a user draws (``ball_in_region``: the
saturated, round part of a region; a region with no ball in it is refused)
or from balls found moving in a recording (``evidence/find_balls.py``).
``learn`` pools them over every image: the range holds the ball's pixels
(``colour.range_of``), the colour model is the ball's hue-saturation
histogram against the rest of those images (``colour_model.py``), and the
separation figure is measured on the images the model learnt from and, when
there are two or more, on images it did not learn from (each image scored by
a model learnt from the others).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from ..config import Target
from ..errors import StereotrackError
from .colour import range_of, target_mask
from .colour_model import LEARN_STEP, ColourModel, hs_histogram, separation

MIN_BALL_PIXELS = 10
MIN_SATURATION = 40  # a ball's colour: greys and whites have no hue to learn
HUE_TOLERANCE = 10  # hue steps from the region centre's hue that still count as the ball's colour
SATURATION_SHARE = 0.65  # ... and at least this share of its saturation (a paler patch of the hue beside the ball is not the ball)
CIRCLE_FILL = (
    0.65  # a disc's hull fills its enclosing circle (pixelated: ~0.9, a striped ball in a hand ~0.7); a square's 0.64, a 2:1 box's 0.51
)
WINDOW = 0.5  # the ball is looked for in the region and this share of its size around it
HELD_OUT_FOLDS = 5


@dataclass(frozen=True, eq=False)
class BallImage:
    """One image (HSV) and the pixels of the balls in it (uint8 0/1 mask)."""

    hsv: np.ndarray
    ball: np.ndarray
    where: str  # for messages, e.g. "cam0 frame 10"


def ball_in_region(hsv: np.ndarray, roi: tuple[int, int, int, int], where: str = "") -> np.ndarray:
    """The pixels (uint8 0/1 mask of the image) of the ball a region (x, y, w, h) is drawn on.

    The region's centre gives the ball's colour (a box is drawn on the ball; its corners may hold a hand or
    a wall); the ball is the blob of pixels of that hue, coloured, that holds the centre, looked for in the
    region and half its size around it (a box drawn around a ball, or a little inside it, finds it).
    Refused with one line when the region leaves the image or holds no ball: a grey centre, fewer than 10
    pixels of its colour, a blob that spans the window (a wall), or one that is not a disc (its convex hull fills less than ``CIRCLE_FILL`` of the
    smallest circle around it: a wall, a poster, a box, a ball cut by the image's edge)."""
    x, y, w, h = roi
    H, W = hsv.shape[:2]
    name = f"--region {x},{y},{w},{h}" + (f" ({where})" if where else "")
    if w <= 0 or h <= 0 or x < 0 or y < 0 or x + w > W or y + h > H:
        raise StereotrackError(f"{name}: is not inside the {W}x{H} image (x, y: top-left corner; w, h: size; all in pixels)")
    mx, my = max(int(WINDOW * w), 2), max(int(WINDOW * h), 2)
    x0, y0, x1, y1 = max(x - mx, 0), max(y - my, 0), min(x + w + mx, W), min(y + h + my, H)
    near = hsv[y0:y1, x0:x1]
    yy, xx = np.mgrid[y0:y1, x0:x1]
    centre = (xx - (x + (w - 1) / 2)) ** 2 + (yy - (y + (h - 1) / 2)) ** 2 <= max(min(w, h) / 4, 1.0) ** 2
    middle = near[centre]
    saturation = float(np.median(middle[:, 1]))
    if saturation < MIN_SATURATION:
        raise StereotrackError(
            f"{name}: no ball in it (its centre is grey, saturation {saturation:.0f}); draw the box on one coloured ball"
        )
    hue = int(np.median((middle[:, 0].astype(int) - middle[0, 0] + 90) % 180) + middle[0, 0] - 90) % 180  # median on the circle
    d = np.abs(near[:, :, 0].astype(int) - hue) % 180
    colour = ((np.minimum(d, 180 - d) <= HUE_TOLERANCE) & (near[:, :, 1] >= max(MIN_SATURATION, SATURATION_SHARE * saturation))).astype(
        np.uint8
    )
    _, labels = cv2.connectedComponents(colour, connectivity=8)
    held = labels[centre]
    held = held[held > 0]
    if len(held) < max(1, centre.sum() // 2):
        raise StereotrackError(f"{name}: no ball in it (its centre is not of one colour); draw the box on one ball")
    ball = np.zeros((H, W), np.uint8)
    ball[y0:y1, x0:x1] = labels == np.bincount(held).argmax()
    points = cv2.findNonZero(ball)
    if len(points) < MIN_BALL_PIXELS:
        raise StereotrackError(f"{name}: no ball in it (fewer than {MIN_BALL_PIXELS} pixels of its colour); draw the box on one ball")
    _, radius = cv2.minEnclosingCircle(points)
    circle_fill = cv2.contourArea(cv2.convexHull(points)) / max(
        np.pi * radius**2, 1.0
    )  # the hull: a ball's stripes and highlight do not count
    bx, by, bw, bh = cv2.boundingRect(points)
    if bw >= x1 - x0 or bh >= y1 - y0:  # it spans the window: far larger than the region drawn on it
        raise StereotrackError(
            f"{name}: no ball in it (its colour spans the region and half its size around it: a wall, a poster or a box, "
            "or a box drawn well inside a ball); draw the box around one ball"
        )
    if circle_fill < CIRCLE_FILL:
        raise StereotrackError(
            f"{name}: no ball in it (its colour forms a {bw}x{bh} pixel blob that fills {circle_fill:.2f} of the circle around it, "
            f"a ball's over {CIRCLE_FILL}: a wall, a poster or a box, or a ball cut by the image's edge); draw the box on one ball"
        )
    return ball


@dataclass(frozen=True, eq=False)
class Learnt:
    """A target learnt from ball pixels, its colour model, and how well that separates ball from background."""

    target: Target
    model: ColourModel
    separation: float  # on the images it learnt from (1: perfectly, 0: no better than the range)
    held_out: float | None  # on images it did not learn from; None with one image
    ball_coverage: float  # share of the ball's pixels inside the learnt range
    background_coverage: float  # share of the other pixels inside it
    images: int
    ball_pixels: int


def _model(images: list[BallImage]) -> ColourModel:
    """The ball's colours from every image's ball pixels, the background's from the rest (every 4th pixel)."""
    ball = sum(hs_histogram(im.hsv, im.ball) for im in images)
    step = (slice(None, None, LEARN_STEP), slice(None, None, LEARN_STEP))
    rest = sum(hs_histogram(np.ascontiguousarray(im.hsv[step]), np.ascontiguousarray(1 - im.ball[step])) for im in images)
    return ColourModel(ball / max(float(ball.sum()), 1e-12), rest / max(float(rest.sum()), 1e-12))


def _separation(pairs: list[tuple[ColourModel, BallImage]], target: Target) -> float:
    """One separation figure over several images, each scored by its model."""
    p = np.concatenate([model.probability(im.hsv).ravel() for model, im in pairs])
    ball = np.concatenate([im.ball.ravel() for _, im in pairs])
    in_range = np.concatenate([target_mask(im.hsv, target).ravel() for _, im in pairs])
    return separation(p, ball, in_range)


def learn(images: list[BallImage], name: str, radius: float = Target.radius) -> Learnt:
    """The target (range, radius), its colour model and its separation, from balls marked in ``images``."""
    pixels = np.concatenate([im.hsv[im.ball > 0] for im in images]) if images else np.zeros((0, 3), np.uint8)
    if len(pixels) < MIN_BALL_PIXELS:
        raise StereotrackError(f"too few ball pixels to learn {name!r} from ({len(pixels)})")
    target = range_of(pixels, name, radius)
    model = _model(images)
    inside = _separation([(model, im) for im in images], target)
    held_out = None
    if len(images) >= 2:
        folds = min(HELD_OUT_FOLDS, len(images))
        pairs = []
        for k in range(folds):
            rest = [im for i, im in enumerate(images) if i % folds != k]
            pairs += [(_model(rest), im) for im in images[k::folds]]
        held_out = _separation(pairs, target)
    ball_n = sum(int(im.ball.sum()) for im in images)
    in_ball = sum(int(target_mask(im.hsv, target)[im.ball > 0].sum()) for im in images)
    other_n = sum(im.ball.size for im in images) - ball_n
    in_other = sum(int(target_mask(im.hsv, target).sum()) for im in images) - in_ball
    return Learnt(target, model, inside, held_out, in_ball / max(ball_n, 1), in_other / max(other_n, 1), len(images), ball_n)
