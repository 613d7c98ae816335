"""A target's colour against the background's: a per-pixel probability that a colour is the ball's, not just in/out of a box.

Two hue-saturation histograms per target and camera (white balance differs
between cameras): the ball's colours and the rest of the image's. Their
ratio, read back per pixel (OpenCV's back-projection), is

    p(ball | colour) = t(colour) / (t(colour) + b(colour)),

with t and b normalised (equal priors). Inside the user's HSV range a
colour that covers much of the room (a wall, a curtain, skin) gets a low p,
a colour that is rare in the room (the ball) a high one. The ball's
histogram starts uniform over the range's hues and saturations, or from a
model learnt by ``stereotrack colour learn`` (a file the config names), and
both are refined online: the ball's from the pixels under the confirmed
tracks' discs, the background's from every other pixel, each as a slow
running average.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
import yaml

from ..config import Target
from ..errors import StereotrackError
from ..files import load_yaml, write_text_atomic
from .kernels import HUE_STEP, SAT_STEP, blended, colour_table, hs_histograms, refuse_moving_things

H_BINS, S_BINS = 180 // HUE_STEP, 256 // SAT_STEP  # 45 x 32: a pixel's bin is (hue // HUE_STEP, saturation // SAT_STEP)
_RANGES = [0, 180, 0, 256]
VERSION = 1
_NO_DISCS = np.zeros((0, 0), np.uint8)
LEARN_STEP = 4  # histograms are learnt from every 4th pixel in each direction: colours, not positions, matter
CORE = 0.7  # the part of a tracked ball's disc (in its radius) whose pixels teach the ball's colours
# A ball of every hue (white, grey) is told from a white wall by its hue and saturation hardly at all: learnt, its
# histogram comes close to the wall's, p hovers about 0.5 there and the mask (p > 0.5) was speckle over a quarter
# of the image, splitting the particles and filling the ring of every ball-shape test. As its histogram is learnt,
# such a ball's colour must become up to WHITE_ODDS times likelier on the ball than in the room (before, the range's
# box: a still ball is found by its colour alone). white_ball tune seeds 0-9, worst 0.252 -> 0.300 (seed 2 -> 0.637).
# Three was too few: a white room holds things of a white close to the ball's (a door, a shelf of white books) over a
# few per cent of the view, and noise spreads both over the same bins; at three such a thing was kept as a ball that
# never moved. white_ball tune seeds 0-19 at 3 / 6 / 8 / 10 / 20: median 0.826 / 0.833 / 0.837 / 0.844 / 0.806, worst
# 0.007 / 0.274 / 0.226 / 0.252 / 0.330 (at 20 a still ball's colour no longer counts: seed 9 0.944 -> 0.794).
WHITE_ODDS = 8.0
# A colour the room holds more than SPREAD times as often as the tracked balls' cores (every other pixel against
# the cores, this frame) is not taught as the ball's: it is a hand's, a face's, a wall's. A ball held in a hand, or
# a track that stayed on the hand it was thrown from, has skin in its core; taught, skin became the ball's and every
# hand a ball (hands tune seed 7: the ball's histogram was 60 per cent skin after 25 frames). Props of the ball's hue
# spread its own colour over the room, and it is then taught less: at 4 static_props tune seed 6 lost its ball
# (0.963 -> -0.048); at 10 it holds (0.956), hands tune 7 / 12 / 19 0.967 / 0.833 / 0.900; at 20 hands seed 12 0.400.
# Only the colours of things that move (MOVED: hands, arms): a still prop of the ball's own colour is no hand, and
# refusing its colour kept the ball from learning its own (static_props tune seed 49: 0.944 -> -0.289). Not for a
# ball of every hue: a white ball's colour is the room's by nature (WHITE_ODDS).
SPREAD = 10.0
# But a colour over more than WALL of the view (this frame's pixels off the cores) is a wall's, not a thing's: where
# a wall (a curtain, a poster) of the ball's hue is, the ball's colour is the wall's too. Refused, the ball never
# learnt its own colour (its histogram went to its rim's blend with the room) and was not seen at rest (hue_wall
# tune seed 20: its curtain 19 per cent of the view, 330 times the cores; 0.658 -> -0.283 with SPREAD alone).
# Hands hold at most 4 per cent of the view in range (hands tune seeds 0-39), a hand's skin per bin 1 per cent.
WALL = 0.02
# ... unless its pixels move as a thing's do: more than THING_MOVES of them, on average. A juggler near the camera holds
# 2-3 per cent of the view in one skin colour (face, arms), and it moves at 0.28-0.30 of its pixels; taken for a wall's,
# it was taught from the held ball's core until it was a quarter of the ball's histogram, and the face and arms were
# balls (hands tune seed 110: -0.29; 0.93 with it). A wall of the ball's hue moves at 0.01-0.09 (what passes before it).
# Hands tune seeds 0-159: +1.53 (110, and 116 0.61 -> 0.92); hue_wall, static_props and fast_ball 0-159 and five more
# categories 0-39 as before, to the digit.
THING_MOVES = 0.15
# The colours of things of the room that move (hands, arms), what evidence_maps (evidence/kernels.py) takes a hand's
# colour for: those more than MOVED of whose pixels in the room move, on average (the running share of the view, off
# the balls' discs at OFF_BALL radii: a ball's rim and blur are its own), over at least THING of the view (rarer
# colours are a ball's blend with what it passes: the clutter preset lost 0.005 with them), but a wall's (WALL).
# A static prop of the ball's colour is none: the ball is not taught that colour (SPREAD), and its pixels of it moving
# before the wall were lost while every colour less likely the ball's counted (static_props tune seed 28: 0.967 ->
# 0.644). Skin moves at 0.19-0.79 of its pixels, each colour of it over 0.0007-0.012 of the view (hands tune seed
# 7); a wall of the ball's hue at 0.01-0.09 (hue_wall tune seed 20). MOVED (without THING) at 0.05: hands seed 38
# 0.574, hue_wall 20 0.589; at 0.15 hands seed 12 -0.367; at 0.02 (with THING) 0.822 / 0.667 / 0.789.
MOVED = 0.02
OFF_BALL = 1.5
THING = 0.0005
# The first histogram (the range's box) gives every colour in range the benefit of the doubt: a colour rarer in the room
# than the box's share of a bin is taken for the ball's. Skin's colours spread thin over many bins, and an empty hand was
# a speckle of them that a ball-sized disc took for a ball (hands tune seeds 5, 7, 12: a second track on the juggler's
# empty hand for 20-40 frames). A colour of a moving thing (moving_things) that the balls' cores showed, but that was
# refused as a hand's when they were last taught it (ELSEWHERE), loses that doubt: its p is read from what the cores
# taught alone. Not before the cores have taught a tenth of the histogram (prior under UNSEEN): until then not every
# ball is tracked, the untracked balls move off the tracks' discs, and their colours are things, refused too (withdrawn
# for every moving thing's colour from the first frame, hands tune seed 30, three balls: 0.993 -> 0.019; refused ones
# from the first frame, seed 17, two balls held: 0.872 -> 0.383). Later is too late for a track on the empty hand: at
# 0.8 / 0.7 seeds 5, 17 1.000 / 0.689, 0.872 / 0.606.
UNSEEN = 0.9
# ELSEWHERE: SPREAD refuses to teach a ball's own colour too (its shading's, its rim's) wherever the room holds ten times
# the cores' of it and it moves, and withdrawn, the ball lost it (the clutter preset: a shading colour on one sample of
# the cores a frame, 0.991 -> 0.990; hue_wall tune seed 22, a wall of the balls' hue: 100 bin-frames withdrawn in 90
# frames, the balls' own shading colours moving off the discs on balls not yet tracked). A hand's colour moves away from
# the balls (the empty hand, the arms), a ball's moves with a ball: refused is a hand's only where more of its pixels
# moved off the balls' discs than lie on their cores, and more than of the balls' own main colour (the most of the
# cores' colours that is not a moving thing's by SPREAD's and MOVED's tests: skin over WALL of the view is taught, hands
# tune seed 17), which an untracked ball carries more of than of any other of its colours. Clutter 0.991 as without
# the withdrawal, hue_wall seed 22 withdraws 7 bin-frames, the hands seeds as many as before (seed 12: 700 / 659).

# A tracked ball's core teaches its colours, but a ball held deep in a hand has fingers on its core, and where the room
# holds too little of their skin for SPREAD (the shadowed skin between the fingers: 0.07 per cent of the view, hands
# tune seed 59) it was taught: a third of the ball's histogram was skin, and the empty hand was a ball (false tracks).
# A colour of a moving thing (moving_things) that is as dense in a ring around the tracked balls (HOLDER_RING radii,
# off their rims) as HOLDER times its density on their cores is what holds them, and is not taught this frame. A ball's
# own colours are dense on its core and hardly in its ring. Hands tune seeds 0-159 against without it (MOTA summed):
# at HOLDER 0.15 / 0.05, +4.25 / +4.27 (seeds under 0.85: 14 -> 9 / 9; worst -0.70 -> 0.23 / 0.53; tried before SPREAD's
# test instead of after it, at 0.5 +0.87); hue_wall and static_props 0-79, fast_ball 400-459 and five more categories
# 0-19 within +0.05 of it at 0.15.
# Every colour but a wall's, in place of the moving things', lost hue_wall 0-79 0.91 at 0.15 (4 -> 7 seeds under 0.85):
# a still prop or a wall's stripe of the ball's colour beside a ball at rest is not a holder.
HOLDER = 0.15
HOLDER_RING = (1.15, 1.6)
_RING_AREA = HOLDER_RING[1] ** 2 - HOLDER_RING[0] ** 2  # in squared radii, as the core's CORE ** 2


def _normalised(hist: np.ndarray) -> np.ndarray:
    total = float(hist.sum())
    return (hist / total).astype(np.float32) if total > 0 else np.full(hist.shape, 1.0 / hist.size, np.float32)


def box_histogram(target: Target) -> np.ndarray:
    """Uniform over the hue and saturation bins the target's HSV range covers: the ball's colours before any is seen."""
    hue = np.arange(H_BINS) * 180 // H_BINS + 180 // H_BINS // 2
    sat = np.arange(S_BINS) * 256 // S_BINS + 256 // S_BINS // 2
    lo, hi = target.hsv_min, target.hsv_max
    in_hue = (hue >= lo[0]) | (hue <= hi[0]) if target.wraps else (hue >= lo[0]) & (hue <= hi[0])
    in_sat = (sat >= lo[1]) & (sat <= hi[1])
    hist = (in_hue[:, None] & in_sat[None, :]).astype(np.float32)
    if not hist.any():  # a range narrower than a bin: the nearest bin
        hist[min(int(lo[0]) * H_BINS // 180, H_BINS - 1), min(int(lo[1]) * S_BINS // 256, S_BINS - 1)] = 1.0
    return _normalised(hist)


def hs_histogram(hsv: np.ndarray, mask: np.ndarray | None = None) -> np.ndarray:
    """Hue-saturation histogram (counts) of the pixels of ``hsv`` where ``mask`` is set (every pixel without one)."""
    return cv2.calcHist([hsv], [0, 1], mask, [H_BINS, S_BINS], _RANGES)


@dataclass
class ColourModel:
    """One target's colour model in one camera."""

    ball: np.ndarray  # H_BINS x S_BINS, normalised
    background: np.ndarray | None = None  # H_BINS x S_BINS, normalised; None until the first frame
    rate: float = 0.05  # weight of each frame in the running averages
    odds: float = 1.0  # a colour is the ball's when it is this many times likelier on the ball than in the background
    prior: float = 1.0  # the share of the ball's histogram that is still its first one (the range's box, or a file's)
    spread: float = 0.0  # a colour the room holds this many times as often as the balls' cores is not taught (0: every one is)
    moving: np.ndarray | None = None  # H_BINS x S_BINS, with ``spread``: the share of the view the room's moving pixels of each colour are
    first: np.ndarray | None = None  # the ball's first histogram (``prior`` of ``ball`` is still it); None: ``ball`` as given
    refused: np.ndarray | None = None  # H_BINS x S_BINS bool: the cores showed it, last refused as a hand's (ELSEWHERE)

    def __post_init__(self):
        # float32, as OpenCV's histograms are: ``learn``'s compiled passes take them so (and compute as numpy did on them)
        for name in ("ball", "background", "moving", "first"):
            value = getattr(self, name)
            if value is not None and value.dtype != np.float32:
                setattr(self, name, np.asarray(value, np.float32))

    @classmethod
    def for_target(cls, target: Target, learnt: np.ndarray | None = None, rate: float = 0.05) -> ColourModel:
        odds, spread = (WHITE_ODDS, 0.0) if target.any_hue else (1.0, SPREAD)
        first = _normalised(learnt) if learnt is not None else box_histogram(target)
        return cls(first.copy(), None, rate, odds, spread=spread, first=first)

    @classmethod
    def from_region(cls, target: Target, hsv: np.ndarray, ball: np.ndarray) -> ColourModel:
        """Learnt from one image: the ball's colours under ``ball`` (uint8 mask), the background's everywhere else."""
        ball = (ball > 0).astype(np.uint8)
        return cls(_normalised(hs_histogram(hsv, ball)), _normalised(hs_histogram(hsv, 1 - ball)))

    def table(self, hsv: np.ndarray) -> np.ndarray:
        """p(ball | colour) x 255 per hue-saturation bin (H_BINS x S_BINS uint8): what a pixel of that colour
        gets; a moving thing's colour the cores were refused, from what they taught alone (UNSEEN). The background's
        histogram starts from ``hsv`` when nothing was learnt yet."""
        return self.table_and_things(hsv)[0]

    def table_and_things(self, hsv: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """``table(hsv)`` and ``moving_things()``, the moving things found once for both (the tracker needs both
        every frame)."""
        if self.background is None:
            self.background = _normalised(hs_histogram(hsv[::LEARN_STEP, ::LEARN_STEP]))
        odds = 1.0 + (self.odds - 1.0) * (1.0 - self.prior)  # the learnt share takes the odds
        ball = self.ball
        things = self.moving_things()
        if things is not None and self.first is not None and self.refused is not None and self.prior < UNSEEN:  # UNSEEN
            unseen = (things > 0) & self.refused
            if unseen.any():
                ball = np.where(unseen, np.maximum(ball - self.prior * self.first, 0.0), ball).astype(np.float32)
        return colour_table(ball, self.background, odds), things  # ball and background both float32 (_normalised, running averages)

    def moving_things(self) -> np.ndarray | None:
        """The colours of things of the room that move, as learnt so far (H_BINS x S_BINS uint8, 1: more than MOVED of
        the room's pixels of it move, over THING and under WALL of the view): what evidence_maps takes a hand's colour
        for. None without ``spread`` (a ball of every hue) or before anything was learnt to move."""
        moves = self._moves()
        if moves is None:
            return None
        wall = (self.background >= WALL) & ~(self.moving > THING_MOVES * self.background)
        return (moves & (self.background >= THING) & ~wall).astype(np.uint8)

    def _moves(self) -> np.ndarray | None:
        """Per colour bin: more than MOVED of the room's pixels of it move (None without ``spread`` or before anything
        was learnt to move)."""
        if not self.spread or self.moving is None or self.background is None:
            return None
        return self.moving > MOVED * self.background

    def probability(self, hsv: np.ndarray) -> np.ndarray:
        """p(ball | colour) per pixel, 0..255 (uint8): the table read back per pixel. (The tracker reads the
        table inside its one pass over the range instead, evidence/gather.py.)"""
        return cv2.calcBackProject([hsv], [0, 1], self.table(hsv).astype(np.float32), _RANGES, 1)

    def learn(
        self,
        hsv: np.ndarray,
        in_range: np.ndarray,
        centres_uv: np.ndarray | None = None,
        radii_px: np.ndarray | None = None,
        foreground: np.ndarray | None = None,
        things: np.ndarray | None = None,
    ) -> None:
        """Learn this frame: the ball's colours from the pixels in range under the discs of the tracked balls
        (pixel centres and apparent radii; their cores) but those the room holds far more of (``spread``), the
        background's from every other pixel; with ``spread`` and the ``foreground`` (0/1, any grid the image's size
        divides), the colours of what moved off the balls (``moving``). ``things``: ``moving_things()`` as
        ``table_and_things`` found them this frame (found again without)."""
        h, w = hsv.shape[:2]
        discs = off_ball = ring = _NO_DISCS
        if centres_uv is not None and len(centres_uv):
            grid = (-(-h // LEARN_STEP), -(-w // LEARN_STEP))  # the subsampled grid the histograms count on
            centres, radii = np.asarray(centres_uv) / LEARN_STEP, np.asarray(radii_px) / LEARN_STEP
            discs = disc_mask(grid, centres, radii)
        learn_moving = bool(self.spread) and foreground is not None  # MOVED
        if learn_moving and discs.shape[0]:
            off_ball = disc_mask(grid, centres, radii, OFF_BALL)
            things = self.moving_things() if things is None else things
            if things is not None and things.any():  # HOLDER: the ring around the balls, off their rims
                ring = disc_mask(grid, centres, radii, HOLDER_RING[1], HOLDER_RING[0])
        on_ball, rest, moved, around = hs_histograms(
            hsv, LEARN_STEP, in_range, discs, foreground if learn_moving else _NO_DISCS, off_ball, ring
        )
        room = rest.sum()  # (numpy's float32 sum, as every use of it below had it)
        # Compiled passes over the float32 histograms (kernels.refuse_moving_things, blended): the numpy version made a
        # dozen temporaries of 45 x 32 bins for these few lines, a tenth of a millisecond a frame.
        if self.spread and self.moving is not None and self.background is not None:  # SPREAD and ELSEWHERE (_moves)
            if self.refused is None:
                self.refused = np.zeros(on_ball.shape, bool)
            refuse_moving_things(
                on_ball, rest, moved, self.moving, self.background, self.spread, MOVED, WALL * room, THING_MOVES, self.refused
            )
        if ring.shape[0]:  # HOLDER, densities per squared radius
            on_ball[(things > 0) & (around / _RING_AREA >= HOLDER * on_ball / CORE**2)] = 0.0
        if on_ball.any():
            self.ball = blended(self.ball, on_ball, float(on_ball.sum()), self.rate)
            self.prior *= 1 - self.rate
        if self.background is None:
            self.background = _normalised(rest)
        elif room > 0:
            self.background = blended(self.background, rest, float(room), self.rate)
        else:  # an empty view: the uniform histogram
            self.background = (1 - self.rate) * self.background + self.rate * _normalised(rest)
        if learn_moving:
            divisor = max(float(room), 1.0)
            self.moving = moved / divisor if self.moving is None else blended(self.moving, moved, divisor, self.rate)

    # ----------------------------------------------------------------- file

    def save(self, path: str | Path, target: Target, separation: float) -> None:
        data = {
            "version": VERSION,
            "kind": "stereotrack colour model",
            "target": target.name,
            "bins": [H_BINS, S_BINS],
            "separation": round(float(separation), 4),
            "ball": np.round(self.ball, 6).tolist(),
        }
        write_text_atomic(path, yaml.safe_dump(data, default_flow_style=None, sort_keys=False))


def load_colour_model(path: str | Path) -> np.ndarray:
    """The ball histogram of a colour model file written by ``stereotrack colour learn``; one clear error for
    a missing, truncated or foreign file, or one of another version."""
    path = Path(path)
    try:
        data = load_yaml(path, "colour model file not found (learn it again: stereotrack colour learn)", "colour model file")
    except StereotrackError as exc:
        if "not found" in str(exc):
            raise
        detail = str(exc).removeprefix(f"{path}: ")
        raise StereotrackError(
            f"{path}: not a readable colour model ({detail}; truncated?); learn it again with stereotrack colour learn"
        ) from None
    if not isinstance(data, dict) or data.get("kind") != "stereotrack colour model":
        raise StereotrackError(f"{path}: not a stereotrack colour model file")
    if data.get("version") != VERSION:
        raise StereotrackError(
            f"{path}: colour model version {data.get('version')!r}, this stereotrack reads version {VERSION}; learn it again"
        )
    try:
        ball = np.asarray(data["ball"], dtype=np.float32)
    except (KeyError, TypeError, ValueError):
        raise StereotrackError(f"{path}: field 'ball' missing or not numbers (truncated file?); learn it again") from None
    if ball.shape != (H_BINS, S_BINS) or not np.all(np.isfinite(ball)) or (ball < 0).any() or ball.sum() <= 0:
        raise StereotrackError(f"{path}: field 'ball' must be {H_BINS}x{S_BINS} non-negative numbers (truncated file?); learn it again")
    return ball


def disc_mask(shape: tuple[int, int], centres_uv: np.ndarray, radii_px: np.ndarray, scale: float = CORE, hole: float = 0.0) -> np.ndarray:
    """uint8 H x W, 255 inside the discs (radius x ``scale``) drawn at these pixel centres; with a ``hole``, 0 inside
    every disc of radius x ``hole`` (rings: HOLDER's)."""
    h, w = shape
    out = np.zeros((h, w), np.uint8)
    # as Python floats (the callers' float64 values): numpy scalars cost a microsecond a test
    balls = [
        ((int(round(u)), int(round(v))), r)
        for (u, v), r in zip(np.asarray(centres_uv).tolist(), np.asarray(radii_px).tolist())
        if math.isfinite(u) and math.isfinite(v) and -w < u < 2 * w and -h < v < 2 * h and 0 < r < w
    ]
    for size, value in ((scale, 255), (hole, 0)) if hole else ((scale, 255),):
        for centre, r in balls:
            cv2.circle(out, centre, max(1, int(r * size)), value, -1)
    return out


def separation(probability: np.ndarray, ball: np.ndarray, in_range: np.ndarray) -> float:
    """How well the model tells ball from background: the mean p(ball) on the ball's pixels minus that on the
    other pixels in range (1: perfect, 0: no better than the range)."""
    on = probability[ball > 0]
    off = probability[(ball == 0) & (in_range > 0)]
    if not len(on):
        return 0.0
    return float(on.mean() / 255.0 - (off.mean() / 255.0 if len(off) else 0.0))
