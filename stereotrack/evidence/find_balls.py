"""Balls found without help: moving, round blobs of one hue in a recording, grouped by hue into proposed targets.

Per camera a background model (``motion.py``, fed frames scaled to the
first frame's mean colour, so light that drifts or flickers is not motion)
gives each frame's moving pixels. Their coloured pixels (saturated, not dark)
are split into bands around the hues they gather at, so a ball held in a
hand is not one blob with the hand; a blob of a band is a detection when it
could be a ball (``blobs.py`` ``ball_like``: a ball's size at some depth in
range, compact) and fills most of its core. Detections are split into
colours where their hues leave a gap; a detection that recurs at one place
in many frames is dropped (a static object that keeps looking like motion),
and a colour seen in fewer than ``MIN_FRAMES`` frames, one that never leaves
one place (the ghost of a ball that sat where the background started), or
one whose blobs are typically not round and full (hands, arms) is not a
ball. With a calibrated rig the ball's radius is measured: detections of a
colour in two cameras in one frame that triangulate consistently give the
ball's depth, and depth x apparent radius / focal length its size; a colour
no two cameras see consistently is not proposed.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field

import cv2
import numpy as np

from ..camera import Camera, triangulate_points
from ..config import Target, TrackerSettings
from .blobs import ball_like, find_blobs
from .colour import range_of, target_mask, to_hsv
from .learn import BallImage, Learnt, learn
from .motion import BackgroundModel

MIN_SATURATION = 50  # a ball "of one hue" is coloured: greys and whites are not
MIN_VALUE = 50  # a dark pixel's hue is noise
ONE_HUE = 0.7  # share of a blob's core in its hue band
HUE_WIDTH = 10  # half the width of a hue band, hue steps
HUE_GAP = 5  # hue steps with no detection that split two ball colours
GROUP_ROUNDNESS = 0.6  # a ball colour's blobs are, in the median, at least this round (narrow / long axis) ...
GROUP_FILL = 0.8  # ... and fill this much of their ellipse (hands and arms: 0.4-0.55 and 0.78 on the real videos)
WARM_UP = 5  # frames the background model learns before its foreground counts
MIN_FRAMES = 5  # a ball colour is seen moving in at least this many frames
STATIC_SHARE = 0.5  # a detection whose place recurs in this share of the frames looked at is static (a slow ball lingers less)
CORE = 0.7  # the part of a blob (in its narrow radius) whose pixels give its colour
MIN_CORE_PIXELS = 6
MAX_MOVING = 0.25  # share of a frame's pixels: more moving than this, the camera or the light changed


@dataclass(frozen=True, eq=False)
class Detection:
    camera: int
    frame: int
    centre: np.ndarray  # (u, v) pixels
    radius_px: float  # the blob's narrow semi-axis: a ball's apparent radius, also when blurred into a streak
    hue: float
    pixels: np.ndarray  # K x 3 HSV of its core
    roundness: float = 1.0  # narrow / long axis of the blob
    fill: float = 1.0  # share of its moments' ellipse it fills


@dataclass(eq=False)
class HueGroup:
    """The detections of one ball colour."""

    hue: float
    detections: list[Detection] = field(default_factory=list)

    @property
    def frames(self) -> list[int]:
        return sorted({d.frame for d in self.detections})

    def target(self, name: str, radius: float) -> Target:
        return range_of(np.concatenate([d.pixels for d in self.detections]), name, radius)


def _circular_median(hues: np.ndarray) -> float:
    """Median hue on the 180-step circle, measured from the circle's emptiest point."""
    hist = np.bincount(hues.astype(int) % 180, minlength=180)
    cut = int(np.argmin(np.convolve(np.r_[hist[-7:], hist, hist[:7]], np.ones(15), "valid")[:180]))
    return float((np.median((hues.astype(int) - cut) % 180) + cut) % 180)


def _hue_distance(a: np.ndarray | float, b: float) -> np.ndarray:
    d = np.abs(np.asarray(a, float) - b) % 180
    return np.minimum(d, 180 - d)


def _hue_peaks(hues: np.ndarray, min_count: int, most: int = 4) -> list[int]:
    """The hues (up to ``most``) around which many of these pixels' hues gather, most common first."""
    if len(hues) < min_count:
        return []
    hist = np.bincount(hues.astype(int) % 180, minlength=180).astype(float)
    k = HUE_WIDTH
    smooth = np.convolve(np.r_[hist[-k:], hist, hist[:k]], np.ones(2 * k + 1), "valid")
    peaks = []
    while len(peaks) < most:
        peak = int(np.argmax(smooth))
        if smooth[peak] < min_count:
            break
        peaks.append(peak)
        smooth[_hue_distance(np.arange(180), peak) <= 2 * k] = 0
    return peaks


def _hue_band(hsv: np.ndarray, hue: int) -> np.ndarray:
    """uint8 0/255: pixels within HUE_WIDTH of ``hue`` (on the circle)."""
    lo, hi = (hue - HUE_WIDTH) % 180, (hue + HUE_WIDTH) % 180
    if lo <= hi:
        return cv2.inRange(hsv[..., 0], lo, hi)
    return cv2.inRange(hsv[..., 0], lo, 179) | cv2.inRange(hsv[..., 0], 0, hi)


def _hue_runs(hues: np.ndarray) -> list[set[int]]:
    """The detections' hues split into runs of hue steps with no gap of ``HUE_GAP`` between them (one ball's
    hue drifts with the light; two balls' hues are apart)."""
    if not len(hues):
        return []
    hist = np.bincount(hues.astype(int) % 180, minlength=180)
    k = HUE_GAP // 2
    occupied = np.convolve(np.r_[hist[-k:], hist, hist[:k]], np.ones(2 * k + 1), "valid") > 0
    if occupied.all():
        return [set(range(180))]
    start = int(np.argmin(occupied))  # an empty step: runs never wrap past it
    runs: list[set[int]] = []
    for i in range(start, start + 180):
        if occupied[i % 180]:
            if not runs or (i - 1) % 180 not in runs[-1]:
                runs.append(set())
            runs[-1].add(i % 180)
    return runs


def _travels(dets: list[Detection]) -> bool:
    """Whether the detections, in some camera, lie further than two ball diameters apart: a ball that moves
    goes places; the ghost of one that sat where the background started (the room it hid, now uncovered) stays put."""
    for j in {d.camera for d in dets}:
        centres = np.array([d.centre for d in dets if d.camera == j])
        radius = float(np.median([d.radius_px for d in dets if d.camera == j]))
        if np.hypot(*(centres - np.median(centres, axis=0)).T).max() > 2 * radius:
            return True
    return False


class BallFinder:
    """Looks at a recording's frames in order and collects detections of moving, round balls of one hue."""

    def __init__(self, cameras: Sequence[Camera], settings: TrackerSettings | None = None, radius: float = Target.radius):
        self.settings = s = settings or TrackerSettings()
        self.cameras = list(cameras)
        self.radius = radius
        self.backgrounds = [BackgroundModel(cam, s.background_rate, s.foreground_threshold) for cam in self.cameras]
        self.detections: list[Detection] = []
        self.frames_seen = 0
        self._reference: list[np.ndarray | None] = [None] * len(self.cameras)  # each camera's first frame's mean colour

    def _steady(self, j: int, image: np.ndarray) -> np.ndarray:
        """The image scaled to the first frame's mean colour: lighting that drifts or flickers (the whole image
        brighter or darker) is not motion."""
        mean = np.array(cv2.mean(image)[:3])
        if self._reference[j] is None:
            self._reference[j] = mean
        gain = self._reference[j] / np.maximum(mean, 1.0)
        return cv2.multiply(image, np.array([*gain, 1.0]), dtype=cv2.CV_8U) if np.abs(gain - 1).max() > 0.01 else image

    def look(self, frame: int, images: Sequence[np.ndarray]) -> None:
        s = self.settings
        for j, (bg, image) in enumerate(zip(self.backgrounds, images)):
            moving = bg.foreground(self._steady(j, image))
            if moving.mean() > MAX_MOVING:  # a camera that moved or a light switched: no ball found in this frame
                continue
            if self.frames_seen < WARM_UP:
                continue
            hsv = to_hsv(image)
            coloured = moving & cv2.inRange(hsv, (0, MIN_SATURATION, MIN_VALUE), (179, 255, 255))
            for hue in _hue_peaks(hsv[..., 0][coloured > 0], s.min_blob_area):
                self._detect(j, frame, hsv, coloured & _hue_band(hsv, hue), hue)
        self.frames_seen += 1

    def _detect(self, j: int, frame: int, hsv: np.ndarray, band: np.ndarray, hue: float) -> None:
        """Detections among the blobs of one hue band of the moving pixels: the ones that could be a ball."""
        s, cam = self.settings, self.cameras[j]
        blobs = find_blobs(band, "components", s.min_blob_area)
        if not len(blobs):
            return
        h, w = band.shape
        for i in np.flatnonzero(ball_like(blobs, cam.focal_px, self.radius, s.d_min, s.d_max)):
            (u, v), r = blobs.centres[i], float(blobs.axes[i, 1])
            core = max(CORE * r, 1.0)
            x0, x1 = int(max(u - core, 0)), int(min(u + core + 1, w))
            y0, y1 = int(max(v - core, 0)), int(min(v + core + 1, h))
            yy, xx = np.mgrid[y0:y1, x0:x1]
            disc = (xx - u) ** 2 + (yy - v) ** 2 <= core * core
            inside = disc & (band[y0:y1, x0:x1] > 0)
            if inside.sum() < max(MIN_CORE_PIXELS, ONE_HUE * disc.sum()):  # the core is mostly this hue
                continue
            px = hsv[y0:y1, x0:x1][inside]
            major = max(float(blobs.axes[i, 0]), 0.5)
            fill = float(blobs.areas[i]) / max(np.pi * major * max(r, 0.5), 1.0)
            self.detections.append(Detection(j, frame, np.array([u, v], float), r, _circular_median(px[:, 0]), px, r / major, fill))

    def _moving(self, dets: list[Detection]) -> list[Detection]:
        """Drop detections whose place recurs in many frames: a static object that keeps looking like motion
        (a ghost of a ball that sat there when the background started, a blinking light)."""
        out = []
        for j in {d.camera for d in dets}:
            mine = [d for d in dets if d.camera == j]
            centres = np.array([d.centre for d in mine])
            frames = np.array([d.frame for d in mine])
            for d in mine:
                near = np.hypot(*(centres - d.centre).T) <= max(d.radius_px, 3.0)
                if len(set(frames[near].tolist())) < max(MIN_FRAMES, STATIC_SHARE * (self.frames_seen - WARM_UP)):
                    out.append(d)
        return out

    def groups(self) -> list[HueGroup]:
        """Ball colours, most often seen first: detections split where their hues leave a gap, each part
        kept if it moves (``_moving``, ``_travels``), is seen in ``MIN_FRAMES`` frames or more and its blobs
        are typically round and full (a ball's are; a hand's or an arm's pieces are not)."""
        out = []
        hues = np.array([d.hue for d in self.detections])
        for run in _hue_runs(hues):
            members = self._moving([d for d, h in zip(self.detections, hues) if int(h) % 180 in run])
            if not members:
                continue
            group = HueGroup(_circular_median(np.array([d.hue for d in members])), members)
            round_ = np.median([d.roundness for d in members]) >= GROUP_ROUNDNESS and np.median([d.fill for d in members]) >= GROUP_FILL
            if len(group.frames) >= MIN_FRAMES and round_ and _travels(members):
                out.append(group)
        return sorted(out, key=lambda g: -len(g.detections))


def refine(group: HueGroup, target: Target, frame: int, hsv: Sequence[np.ndarray]) -> list[tuple[int, np.ndarray, float]]:
    """The group's detections in one frame measured again on the learnt range's blobs (the moving pixels lose
    the ball's edge): (camera, centre, apparent radius) per detection whose colour blob is round and sits on it."""
    out = []
    for d in (d for d in group.detections if d.frame == frame):
        blobs = find_blobs(target_mask(hsv[d.camera], target), "components", 6)
        if not len(blobs):
            continue
        dist = np.hypot(*(blobs.centres - d.centre).T)
        i = int(np.argmin(dist))
        if dist[i] <= max(d.radius_px, 2.0):
            out.append((d.camera, blobs.centres[i], float(blobs.axes[i, 1])))
    return out


def ball_images(group: HueGroup, frame: int, hsv: Sequence[np.ndarray], cameras: Sequence[Camera]) -> list[BallImage]:
    """Per camera that saw the group in ``frame``: the image and its ball pixels (in the detections' discs, the
    pixels of the group's hue band that are coloured: the criteria that found them, with no margin yet)."""
    out = []
    for j in sorted({d.camera for d in group.detections if d.frame == frame}):
        disc = np.zeros(hsv[j].shape[:2], np.uint8)
        for d in (d for d in group.detections if d.frame == frame and d.camera == j):
            cv2.circle(disc, (int(round(d.centre[0])), int(round(d.centre[1]))), max(1, int(round(d.radius_px))), 1, -1)
        coloured = cv2.inRange(hsv[j], (0, MIN_SATURATION, MIN_VALUE), (179, 255, 255)) & _hue_band(hsv[j], int(round(group.hue)))
        out.append(BallImage(hsv[j], disc & (coloured > 0), f"{cameras[j].name} frame {frame}"))
    return out


def ball_radius(measured: list[list[tuple[int, np.ndarray, float]]], cameras: Sequence[Camera]) -> float | None:
    """The ball's radius in metres from detections refined per frame (``refine``), or None: every pair of
    detections in two cameras of one frame that triangulates within a third of a ball radius in both
    reprojections gives depth x apparent radius / focal length in each camera; the median of those."""
    sizes = []
    for dets in measured:
        for a in range(len(dets)):
            for b in range(len(dets)):
                (ja, pa, ra), (jb, pb, rb) = dets[a], dets[b]
                if ja >= jb:
                    continue
                ca, cb = cameras[ja], cameras[jb]
                X = triangulate_points([ca, cb], [pa[None], pb[None]])
                ok = True
                for cam, p, r in ((ca, pa, ra), (cb, pb, rb)):
                    uv, front, depth = cam.view(X)
                    ok &= bool(front[0]) and float(np.hypot(*(uv[0] - p))) <= max(1.5, r / 3)
                if ok:
                    sizes += [r * float(cam.depth(X)[0]) / cam.focal_px for cam, r in ((ca, ra), (cb, rb))]
    return float(np.median(sizes)) if len(sizes) >= 4 else None


LEARN_FRAMES = 24  # frames each proposed target is learnt from
HUE_NAMES = ((8, "red"), (20, "orange"), (34, "yellow"), (80, "green"), (100, "cyan"), (130, "blue"), (145, "purple"), (169, "pink"))


def hue_name(hue: float) -> str:
    return next((name for upto, name in HUE_NAMES if hue <= upto), "red")


@dataclass(frozen=True, eq=False)
class Proposal:
    """A target proposed for one ball colour found moving."""

    name: str
    learnt: Learnt  # range, colour model, separation
    group: HueGroup
    radius: float | None  # metres, measured (None without a calibrated rig)


def propose(
    read: Callable[[Sequence[int]], Iterable[tuple[int, Sequence[np.ndarray]]]],
    n_frames: int,
    cameras: Sequence[Camera],
    calibrated: bool,
    settings: TrackerSettings | None = None,
    max_frames: int = 300,
    name: str | None = None,
    radius: float | None = None,
    tick: Callable[[], None] | None = None,
) -> tuple[list[Proposal], int]:
    """Find the balls in a recording and propose a target per colour: (proposals, frames looked at).

    ``read(indices)`` yields (index, one image per camera) for those frames, in order. Up to ``max_frames``
    frames spread over the recording are looked at; each colour found is learnt (``learn.learn``) from up to
    ``LEARN_FRAMES`` of the frames it was seen in. With a calibrated rig of two or more cameras a colour is
    proposed only if its detections in two cameras triangulate consistently (``ball_radius``). Targets are named by hue, or ``name``, ``name2``, ...;
    ``radius`` (metres) overrides the one measured (calibrated rigs), else 0.035."""
    step = max(1, -(-n_frames // max_frames))
    finder = BallFinder(cameras, settings, radius or Target.radius)
    for index, images in read(range(0, n_frames, step)):
        finder.look(index, images)
        if tick is not None:
            tick()
    used: set[str] = set()
    out = []
    for k, group in enumerate(finder.groups()):
        label = (name if k == 0 else f"{name}{k + 1}") if name else hue_name(group.hue)
        while label in used:
            label += "2"
        used.add(label)
        rough = group.target(label, Target.radius)
        frames = group.frames
        frames = [frames[i] for i in np.unique(np.linspace(0, len(frames) - 1, min(LEARN_FRAMES, len(frames))).round().astype(int))]
        images, measured = [], []
        for index, imgs in read(frames):
            hsv = [to_hsv(im) for im in imgs]
            images += ball_images(group, index, hsv, cameras)
            measured.append(refine(group, rough, index, hsv))
        size = ball_radius(measured, cameras) if calibrated and len(cameras) >= 2 else None
        if calibrated and len(cameras) >= 2 and size is None:
            continue  # never seen at one place by two cameras: not a ball the tracker could follow (a reflection, a flicker)
        learnt = learn(images, label, radius or (round(size, 4) if size else Target.radius))
        out.append(Proposal(label, learnt, group, size))
    return out, finder.frames_seen
