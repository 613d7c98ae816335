"""Colour blobs of a mask: connected components (default) or the paper's row/column histogram maxima.

Connected components never invent blobs; the histogram maxima (paper section
III-E) give up to k^2 candidates for k blobs sharing rows or columns, and the
candidates whose window holds no colour are dropped.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from .blob_kernels import component_measures, subsampled, uneven


@dataclass(frozen=True, eq=False)
class Blobs:
    """Colour blobs found in one camera's mask."""

    centres: np.ndarray  # M x 2 pixel centroids (x, y)
    areas: np.ndarray  # M pixel counts
    radii: np.ndarray  # M apparent radii in pixels (half the larger bounding-box side)
    labels: np.ndarray | None = None  # H x W int32 component label image (components only)
    label_blob: np.ndarray | None = None  # component label -> blob index, -1 for background and specks
    label_scale: int = 1  # pixel (u, v) has label labels[v // label_scale, u // label_scale]
    boxes: np.ndarray | None = None  # M x 4 bounding boxes (x0, y0, x1, y1), end exclusive, in label cells (components only)
    sizes: np.ndarray | None = None  # M x 2 width and height of the set pixels, full-resolution pixels (components only)
    axes: np.ndarray | None = None  # M x 2 semi-major and semi-minor axes of the ellipse with the blob's second moments, pixels
    major: np.ndarray | None = None  # M x 2 unit vector (x, y) along that ellipse's major axis (components only)
    widths: np.ndarray | None = None  # M apparent radii of the ball a blob is if it is one: a streak's half width, else ``radii``
    swept: np.ndarray | None = None  # M bool: a streak (``streaks``, away from the edge, as wide all along) (components only)

    def ball_radii(self) -> np.ndarray:
        """Apparent radius of the one ball each blob would be: a streak's half width (half its length would put a fast
        ball at half its depth), else ``radii``. Two balls of one colour overlapping look like a streak too: callers use
        this only for blobs no tracked ball holds."""
        return self.widths if self.widths is not None else self.radii

    def ellipse_fills(self) -> np.ndarray:
        """Per blob (components only): the share of the ellipse with its second moments that its pixels fill (a disc or a
        streak about 1, a ring or a scatter little), its semi-axes read as at least half a pixel."""
        axes = np.maximum(self.axes, 0.5)
        return self.areas / np.maximum(np.pi * axes[:, 0] * axes[:, 1], 1.0)

    def pixel_boxes(self, ids: np.ndarray) -> np.ndarray:
        """Per blob ``ids`` (components only): the box (x0, y0, x1, y1, end exclusive, pixels, not clipped to the image)
        its ``areas`` and moments were measured in: its box of label cells grown by one cell, as the labels are of a
        subsampled copy and its pixels reach up to a cell past them (blob_kernels.mask_moments)."""
        s = self.label_scale
        return self.boxes[ids] * s + np.array([-s, -s, s, s])

    def __len__(self) -> int:
        return len(self.centres)


LABEL_SCALE = 2  # the components are labelled on the mask subsampled this many times (several times cheaper)


def _components(mask: np.ndarray, min_area: int, scale: int = LABEL_SCALE, rows: np.ndarray | None = None) -> Blobs:
    """Connected components, found on a ``scale``-times subsampled mask (several times cheaper);
    each blob's centroid is then measured on the full-resolution mask inside its bounding box."""
    small, labels, x0, y0, x1, y1 = subsampled(mask, scale, _EVERY_ROW if rows is None else rows)
    # Labels only: OpenCV's per-component statistics cost several times the labelling itself. Labelled inside the
    # box of the set pixels (most of a mask is empty), from an even corner: OpenCV labels 2 x 2 blocks in raster
    # order, so the labels are those of the whole mask. OpenCV writes them into the box of the label image, whose
    # margins alone ``subsampled`` zeroed (the box was written twice, zeroed then copied: six label images a frame).
    n = 1
    if x1:
        box = labels[y0:y1, x0:x1]
        n, written = cv2.connectedComponents(small[y0:y1, x0:x1], labels=box, connectivity=8, ltype=cv2.CV_32S)
        if not np.shares_memory(written, labels):  # an OpenCV that made an array of its own
            box[:] = written
    # Which components are blobs, each blob measured at full resolution (its moments, axes, size), and which are
    # shaped like streaks away from the edge (``streaks``), in one call
    label_blob, boxes, areas, centres, size, second, axes, radii, swept = component_measures(
        mask, labels[y0:y1, x0:x1], n, x0, y0, scale, min_area, small.shape[1], small.shape[0], STREAK_ELONGATION, STREAK_FILL * np.pi
    )
    major = np.column_stack([np.cos(angle := 0.5 * np.arctan2(2.0 * second[:, 2], second[:, 0] - second[:, 1])), np.sin(angle)])
    if swept.any():  # (most masks hold none)
        swept[swept] = ~_uneven(mask, centres[swept], major[swept], axes[swept])
    widths = np.where(swept, axes[:, 1], radii)  # a streak is as wide as its ball, and longer
    return Blobs(centres, areas, radii, labels, label_blob, scale, boxes, size, axes, major.reshape(-1, 2), widths, swept)


def _local_maxima(hist: np.ndarray, min_count: float, min_gap: int = 5) -> np.ndarray:
    """Indices of local maxima of a smoothed 1D histogram, at least ``min_gap`` apart (the highest wins)."""
    k = np.array([1, 4, 6, 4, 1], float) / 16
    s = np.convolve(hist.astype(float), k, "same")
    left = np.r_[-np.inf, s[:-1]]
    right = np.r_[s[1:], -np.inf]
    peaks = np.flatnonzero((s >= left) & (s > right) & (s >= min_count))
    kept: list[int] = []
    for i in peaks[np.argsort(-s[peaks], kind="stable")]:
        if all(abs(i - j) >= min_gap for j in kept):
            kept.append(int(i))
    return np.array(sorted(kept), dtype=int)


def _histogram(mask: np.ndarray, min_area: int) -> Blobs:
    cols = mask.sum(axis=0)
    rows = mask.sum(axis=1)
    min_count = max(1.0, np.sqrt(min_area))
    xs = _local_maxima(cols, min_count)
    ys = _local_maxima(rows, min_count)
    if len(xs) == 0 or len(ys) == 0:
        return Blobs(np.zeros((0, 2)), np.zeros(0), np.zeros(0))
    gx, gy = np.meshgrid(xs, ys)
    cand = np.column_stack([gx.ravel(), gy.ravel()])
    # Keep candidates whose 5x5 neighbourhood holds colour (drops most k^2 ghosts).
    integ = cv2.integral(mask, sdepth=cv2.CV_32S)
    h, w = mask.shape
    x0 = np.clip(cand[:, 0] - 2, 0, w)
    x1 = np.clip(cand[:, 0] + 3, 0, w)
    y0 = np.clip(cand[:, 1] - 2, 0, h)
    y1 = np.clip(cand[:, 1] + 3, 0, h)
    count = integ[y1, x1] - integ[y0, x1] - integ[y1, x0] + integ[y0, x0]
    cand, count = cand[count > 0], count[count > 0]
    # Size of the blob under each candidate: half the longest run of colour through it along
    # its row or its column (a loop over candidates, a handful, vectorised along the lines).
    radii = np.empty(len(cand))
    for i, (x, y) in enumerate(cand):
        runs = []
        for line, at in ((mask[y, :], x), (mask[:, x], y)):
            off = np.flatnonzero(line == 0)
            left = off[off < at]
            right = off[off > at]
            runs.append((right[0] if len(right) else len(line)) - (left[-1] + 1 if len(left) else 0))
        radii[i] = 0.5 * max(runs)
    return Blobs(cand.astype(float), count.astype(float), radii)


_ALONG = np.linspace(-0.6, 0.6, 7)  # _uneven's places along a blob (semi-major axes) and across it (semi-minor axes)
_ACROSS = np.linspace(-1.2, 1.2, 13)


def _uneven(mask: np.ndarray, centres: np.ndarray, major: np.ndarray, axes: np.ndarray) -> np.ndarray:
    """Per blob: is it wider in some places than others along its major axis, as two balls side by side or one
    partly behind another are (a streak is as wide all along its straight part)? Counts the mask's pixels across
    the blob at 7 places within 0.6 semi-major axes of its centroid (within 1.2 semi-minor axes of the axis):
    the narrowest under 70 % of the widest and 3 pixels narrower (the moving map's 2-pixel cells step a thin streak's
    sides). A check at the centroid alone missed a small ball touching a bigger
    one, whose centroid lies inside the bigger (pendulum4: a ball lost for 4 frames). Compiled (blob_kernels.uneven):
    the numpy version's M x 7 x 13 temporaries cost a hue wall's dozens of streak-shaped stripes 1 ms a frame."""
    if not len(centres):
        return np.zeros(0, bool)
    f = np.ascontiguousarray
    return uneven(mask, f(centres, float), f(major, float), f(axes, float), _ALONG, _ACROSS)


_EVERY_ROW = np.zeros(0, np.uint8)


def find_blobs(mask: np.ndarray, method: str = "components", min_area: int = 6, rows: np.ndarray | None = None) -> Blobs:
    """Colour blobs of a 0/1 mask: ``components`` or the paper's ``histogram`` maxima. ``rows`` (uint8, one per
    mask row): 0 where the caller knows the row is empty (gather.py: most rows hold nothing of a few balls), not read."""
    if method == "components":
        return _components(mask, min_area, rows=rows)
    if method == "histogram":
        return _histogram(mask, min_area)
    raise ValueError(f"unknown blob method {method!r}")


STREAK_ELONGATION = 2.0  # a blob this much longer than wide, ...
STREAK_FILL = 0.8  # ... that fills its moments' ellipse this much, is a ball swept along a line (a capsule fills it 0.9-1.1)


def streaks(areas: np.ndarray, axes: np.ndarray, elongation: float = STREAK_ELONGATION, fill: float = STREAK_FILL) -> np.ndarray:
    """Per blob: a ball smeared into a streak by its motion during the exposure (a filled capsule), whose width, not
    its length, is the ball's. A crescent (a ball partly in range) fills its ellipse about half: not a streak. A ball
    cut by the image's edge is one too (a half disc fills its ellipse): the caller keeps those out."""
    if not len(areas):
        return np.zeros(0, bool)
    b = np.maximum(axes[:, 1], 0.5)
    return (axes[:, 0] >= elongation * b) & (areas >= fill * np.pi * axes[:, 0] * b)


# A moving blob this much longer than wide (and as full and even as a streak) is a short blur. At 1.3 a far fast ball
# blurred to 1.2-1.25 times its width (fast_ball tune seed 28: a ball of 3.7 pixels at 16 m, its blob's box 35 % wider
# than the ball) was neither a clean disc nor a blur, and its object kept the particles' word, 0.3-0.5 m near for 24
# frames. At 1.15, tune seeds 0-39: fast_ball 28 0.093 -> 0.574, 26 0.782 -> 0.836 (with tracker seed 0 and 1 alike),
# sum of MOTA +0.44; hue_wall, static_props, hands within their tracker-seed luck (+0.52, -0.04, +0.02); white_ball
# takes no short blurs; the presets as before.
SHORT_STREAK_ELONGATION = 1.15


def short_streaks(b: Blobs, mask: np.ndarray) -> np.ndarray:
    """Per blob of ``mask`` (``b``, from find_blobs): a ball blurred along its path to 1.15-2 times its width (a big
    ball's short blur; ``streaks`` asks for 2): as full as a streak, away from the image's edge and as wide all along.
    Its width is still the ball's (its length is not: the particles judge its larger side and start 10-15 % too near:
    fast_ball tune seed 5). The caller (objects/explain.py) counts only blobs that are also mostly moving: a half-lit
    ball at rest is as elongated."""
    h, w = mask.shape
    s = b.label_scale
    inside = (b.boxes[:, 0] > 0) & (b.boxes[:, 1] > 0) & (b.boxes[:, 2] * s < w) & (b.boxes[:, 3] * s < h)
    short = streaks(b.areas, b.axes, SHORT_STREAK_ELONGATION) & inside
    if short.any() and b.major is not None:
        short[short] = ~_uneven(mask, b.centres[short], b.major[short], b.axes[short])
    return short


def minor_skew(b: Blobs, mask: np.ndarray, ids: np.ndarray) -> np.ndarray:
    """Per blob ``ids`` of ``mask`` (``b``, from find_blobs): the skewness of its pixels across its major axis (absolute,
    0 for a blob mirror-symmetric about that axis). A ball swept along its path (a streak, a short blur) is a capsule,
    as wide on either side of its path: about 0. A ball cut straight by something in front of it or by the image's edge
    has its flat side on one side of the axis and its curved one on the other: a half disc 0.2-0.35, as elongated as
    a short blur (1.8x) and as full. Measured in the box the blob's moments were (the box grown by one label cell)."""
    out = np.zeros(len(ids))
    if b.boxes is None or b.major is None:
        return out
    h, w = mask.shape
    ids = np.asarray(ids, int)
    for n, (k, (x0, y0, x1, y1)) in enumerate(zip(ids.tolist(), b.pixel_boxes(ids).tolist())):
        x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, w), min(y1, h)
        ys, xs = np.nonzero(mask[y0:y1, x0:x1])
        if len(xs) < 3:
            continue
        across = (xs + x0 - b.centres[k, 0]) * -b.major[k, 1] + (ys + y0 - b.centres[k, 1]) * b.major[k, 0]
        var = float(np.mean(across**2))
        out[n] = abs(float(np.mean(across**3))) / max(var, 1e-9) ** 1.5
    return out


# A blob must fill this much of its moments' ellipse: a disc, a cut disc or a streak do, a ring or a scatter do not.
# A ball only partly in the range (its lit side, its stripes, fingers over it) is a crescent, which fills about
# half of it: 0.39-0.59 on the real ball videos (benchmarks/real_footage.py), where 0.6 lost 15 of 88 ball frames.
FILL = 0.5
DEPTH_SLACK = 1.6  # a blob may look this much larger or smaller than a ball at the nearest or farthest depth


def ball_like(blobs: Blobs, focal_px: float, radius: float, d_min: float, d_max: float) -> np.ndarray:
    """Per blob (M bool): could it be a ball of ``radius`` metres at some depth in [d_min, d_max]? Its
    narrow axis must be a ball's radius there (a streak of a fast ball is long but a ball wide), and it
    must be compact (it fills its ellipse): a wall, a speck or a scatter of pixels is not a ball. The
    ball-shape likelihood judges the rest (corners of a box, a ring around it). Blobs without moments
    (the histogram finder) pass."""
    if blobs.axes is None or not len(blobs):
        return np.ones(len(blobs), bool)
    semi_minor = np.maximum(blobs.axes[:, 1], 0.5)
    # apparent radii at d_min and at d_max; d_min 0 (from the camera on) allows any size up close
    near, far = (focal_px * radius / d_min if d_min > 0 else np.inf), focal_px * radius / d_max
    sized = (semi_minor <= near * DEPTH_SLACK) & (semi_minor >= far / DEPTH_SLACK)
    return sized & (blobs.ellipse_fills() >= FILL)
