"""One target's evidence in one camera, built once per frame and read by every later stage.

``CameraEvidence`` holds the camera, the target's mask and its integral
image, the colour blobs and each blob's viewing ray: the population weighs
particles with the integral image and places abductive ones on the rays,
explain-away looks the blobs up, the viewer draws the rays.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property, lru_cache

import cv2
import numpy as np

from ..camera import Camera
from ..config import Target
from .blob_kernels import faint_pixels, pale_cells, streak_candidates
from .blobs import LABEL_SCALE, Blobs, ball_like, find_blobs, streaks
from .colour import integral_image, range_bounds
from .coverage import coverage_centres
from .kernels import evidence_maps, halved_frame, picked_and_halved, row_maxima
from .motion import halved


@dataclass(frozen=True, eq=False)
class Seeds:
    """Where abductive particles start in one camera: blobs that could be a ball, and their viewing rays."""

    centres: np.ndarray  # M x 2 pixels
    radii: np.ndarray  # M apparent radii, pixels (half the blob's larger side)
    origins: np.ndarray  # M x 3
    directions: np.ndarray  # M x 3 unit
    moved: np.ndarray | None = None  # M bool: the blob is (about) a blob of the moving map (None: none is)
    widths: np.ndarray | None = None  # M apparent radii of the one ball each would be (Blobs.ball_radii); None: radii
    # M bool: a solid blob of the moving map that is no blob of the counted map (a ball moving before a wall of its
    # colour, one blob with it in the mask): its rays make crossings too (proposal.RayProposal). None: none is.
    alone: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.centres)


NO_OTHERS = np.zeros((0, 7), np.int64)  # no other coloured target


@dataclass(frozen=True, eq=False)
class Faint:
    """A camera's faint changes (motion.py's ``faint`` map), the frame and the background on that grid (BGR), and
    the target's range (colour.range_bounds): where a streak too pale for the foreground's threshold is looked for;
    ``others``: the other coloured targets' ranges (K x 7), whose balls' edges are no streak (blob_kernels.pale_cells)."""

    cells: np.ndarray
    image: np.ndarray
    behind: np.ndarray
    bounds: np.ndarray
    others: np.ndarray = field(default_factory=lambda: NO_OTHERS)


@dataclass(frozen=True, eq=False)
class CameraEvidence:
    """What one camera's image says about one target this frame."""

    camera: Camera
    mask: np.ndarray  # H x W uint8, 1 where a pixel has the target's colour
    blobs: Blobs
    origins: np.ndarray  # M x 3: each blob's viewing ray starts at the camera centre ...
    directions: np.ndarray  # M x 3: ... and runs along this unit vector through the blob's centroid
    moving: np.ndarray | None = None  # H x W uint8, 1 where a pixel has the colour and moves (evidence/motion.py); None: no motion
    moving_integral: np.ndarray | None = None  # its summed-area table
    seeds: Seeds | None = None  # the blobs abductive particles start from (None: every blob of the mask)
    soft_integral: np.ndarray | None = None  # summed-area table of p(ball | colour) x 255 inside the range (colour_model.py)
    mask_integral: np.ndarray | None = None  # the mask's summed-area table when it was at hand; else made when first asked
    counted: np.ndarray | None = None  # H x W uint8: the mask OR the moving map, the pixels the blobs are of (None: the mask)
    still: np.ndarray | None = None  # M bool: the blobs shaped like a streak that do not move (still_streaks); None: no motion
    faint: Faint | None = None  # the frame and the background on the background's grid (a coloured target, with motion)

    @cached_property
    def integral(self) -> np.ndarray:
        """(H+1) x (W+1) int32 summed-area table of the mask: any window's count in O(1). Made only when a
        stage asks (the ball-shape likelihood reads the soft map's instead)."""
        return self.mask_integral if self.mask_integral is not None else integral_image(self.mask)

    def proposal_seeds(self) -> Seeds:
        """The seeds, or every blob of the mask when none were chosen."""
        if self.seeds is not None:
            return self.seeds
        return Seeds(self.blobs.centres, self.blobs.radii, self.origins, self.directions, widths=self.blobs.ball_radii())

    def streak_centres(self, ids: np.ndarray) -> np.ndarray:
        """Per blob (``ids``), where its ball was over the exposure: the centroid of its change from the background
        (coverage.py), or its mask's centroid where that cannot be measured (no background at hand)."""
        centres = self.blobs.centres[ids]
        if self.faint is None or not len(ids):
            return centres
        measured = coverage_centres(self.blobs, ids, self.faint.image, self.faint.behind)
        return np.where(np.isfinite(measured), measured, centres)

    @property
    def rays(self) -> tuple[np.ndarray, np.ndarray]:
        return self.origins, self.directions

    @classmethod
    def from_mask(
        cls,
        camera: Camera,
        mask: np.ndarray,
        integral: np.ndarray | None = None,
        blob_method: str = "components",
        min_blob_area: int = 6,
        foreground: np.ndarray | None = None,
        ball: tuple[float, float, float] | None = None,
        colour_table: np.ndarray | None = None,
        hsv: np.ndarray | None = None,
        background: np.ndarray | None = None,
        motion_range: Target | None = None,
        streak_range: Target | None = None,
        faint: Faint | None = None,
        things: np.ndarray | None = None,
    ) -> CameraEvidence:
        """Blobs and rays of a mask (0/1, the target's range). With the camera's ``foreground`` (0/1, at the
        image's size or a whole fraction of it: motion.py keeps it at half), the moving part of the mask is a
        second map, and its blobs seed particles too. With ``ball`` (radius, d_min, d_max), only blobs that
        could be such a ball seed particles (``blobs.ball_like``). With the colour model's ``colour_table``
        (p(ball | colour) x 255 per bin, ColourModel.table) and the frame's ``hsv``, the mask keeps the pixels
        likelier on the ball than on the background, and a soft map (the probability inside the range) is
        kept too; the moving map still takes the whole range (a ball moving in front of its own colour), or
        the pixels of ``hsv`` in ``motion_range`` where given (colour.motion_range: a white ball's shaded side); with the
        ``background`` (BGR, on the foreground's grid: motion.BackgroundModel.behind) only the pixels in range at least as likely the
        ball's as what they replaced: where a ball was in the background, its hue's wall behind it does not move;
        with ``things`` (colour_model.ColourModel.moving_things: the colours of things of the room in range, a hand's), a
        pixel of such a colour less likely the ball's than the room's moves only where it replaced a colour of
        the range (a ball before a wall of its hue), not one out of it: a skin-coloured hand before a wall is no
        ball (hands tune seed 7: the moving hands were kept as balls whatever the model said).
        With a ``streak_range`` (colour.streak_range, read from ``hsv``) and no motion range, the moving map takes it too, but its
        pixels out of the range stay only in moving blobs shaped like a streak (a fast ball's, paler than the
        ball); with ``faint`` changes too (motion.py: above a lower threshold, on the foreground's grid), so do the
        pale pixels of faint streaks (a far fast ball's, too thin and pale to pass the threshold; blob_kernels.pale_cells).
        The blobs are those of the mask and the moving map together: what the likelihood counts is what
        explain-away looks up.
        The maps come from one compiled pass over the range (kernels.evidence_maps), their summed-area tables from OpenCV."""
        in_range = mask
        soft_integral = moving = moving_integral = soft = rows = None
        faint_streaks = []
        if colour_table is not None or foreground is not None:
            h, w = in_range.shape
            soft = np.zeros((h, w), in_range.dtype) if colour_table is not None else None
            mask = np.zeros((h, w), in_range.dtype) if colour_table is not None else in_range
            moving = np.zeros((h, w), in_range.dtype) if foreground is not None else None
            streaky = streak_range is not None and motion_range is None and foreground is not None
            motion_range = streak_range if streaky else motion_range
            own = motion_range is not None and foreground is not None
            fg_rows = _nearest(foreground.shape[0], h) if foreground is not None else _NO_INDEX
            # which rows hold any pixel in range, and (``own``) the moving rows too; no map has a pixel outside these rows
            rows = row_maxima(in_range, foreground if own else _NO_TABLE, fg_rows)
            pale = evidence_maps(
                in_range,
                rows,
                hsv if colour_table is not None or own else _NO_HSV,
                colour_table if colour_table is not None else _NO_TABLE,
                foreground if foreground is not None else _NO_TABLE,
                fg_rows,
                _nearest(foreground.shape[1], w) if foreground is not None else _NO_INDEX,
                range_bounds(motion_range) if own else _NO_BOUNDS,
                soft if soft is not None else _NO_TABLE,
                mask if colour_table is not None else _NO_TABLE,
                moving if moving is not None else _NO_TABLE,
                background if background is not None and foreground is not None else _NO_HSV,
                things if things is not None else _NO_TABLE,
                words(in_range),
            )
            if colour_table is not None:
                soft_integral = integral_image(soft)
            if streaky:
                if pale:
                    _streaks_only(moving, in_range, min_blob_area, rows)
                if faint is not None:
                    rows, faint_streaks = _add_faint_streaks(moving, in_range, faint, range_bounds(motion_range), min_blob_area, rows)
            if moving is not None:
                moving_integral = integral_image(moving)
        counted = mask if moving is None else cv2.bitwise_or(mask, moving)
        blobs = _as_streaks(find_blobs(counted, blob_method, min_blob_area, rows), faint_streaks)
        origins, directions = camera.rays(blobs.centres)
        still = still_streaks(blobs, moving) if moving is not None else None
        seeds = None
        if ball is not None or moving is not None:
            seeds = _seeds(
                camera,
                blobs,
                origins,
                directions,
                moving,
                soft if ball is not None else None,
                blob_method,
                min_blob_area,
                ball,
                rows,
                still,
                in_range,
            )
        return cls(camera, mask, blobs, origins, directions, moving, moving_integral, seeds, soft_integral, integral, counted, still, faint)


def _as_streaks(blobs: Blobs, pixels: list) -> Blobs:
    """``blobs`` with those that are a faint streak's pale pixels alone (``pixels``: (ys, xs) per streak, _kept_streaks) as
    streaks: a ragged capsule of the background grid's cells that _ragged_streaks took for one is one wherever it is read
    (its width, not its length, is its ball's), though it fills less of its ellipse than a mask's streak must."""
    if not pixels or blobs.labels is None or blobs.swept is None or blobs.axes is None:
        return blobs
    s, swept, widths = blobs.label_scale, blobs.swept.copy(), np.array(blobs.ball_radii(), float)
    for ys, xs in pixels:
        ks = blobs.label_blob[blobs.labels[ys // s, xs // s]]  # (the label grid reads every s-th pixel: some read none)
        ks = ks[ks >= 0]
        k = int(np.bincount(ks).argmax()) if len(ks) else -1
        if k >= 0 and blobs.areas[k] <= 1.2 * len(ys):  # (not where it joined a blob of the mask or the moving map)
            swept[k], widths[k] = True, blobs.axes[k, 1]
    return replace(blobs, swept=swept, widths=widths)


def on_grid(camera: Camera, scale: int) -> Camera:
    """The camera that sees every ``scale``-th pixel of ``camera``'s images in each direction (``every_nth``):
    focal lengths and principal point / scale. Evidence built on that grid reads with this camera, and every later
    stage follows it."""
    if scale == 1:
        return camera
    K = np.array(camera.K, dtype=float)
    K[:2] /= scale
    return replace(camera, image_size=(camera.width // scale, camera.height // scale), K=K)


def every_nth(image: np.ndarray, scale: int) -> np.ndarray:
    """Every ``scale``-th pixel of the image in each direction (pixel j is the image's pixel scale j). Picked, not
    averaged: each keeps a full-size pixel's colour and noise, which the colour model has learnt (an average is
    less noisy, so a large ball's colours crowd into fewer bins and look like a wall's)."""
    if scale == 1:
        return image
    h, w = image.shape[:2]
    # OpenCV's nearest-neighbour resize by a whole factor picks exactly these pixels, several times faster than numpy's strided copy.
    return cv2.resize(image[: h - h % scale, : w - w % scale], (w // scale, h // scale), interpolation=cv2.INTER_NEAREST)


def every_nth_and_halved(image: np.ndarray, scale: int) -> tuple[np.ndarray, np.ndarray]:
    """``every_nth(image, scale)`` and that image on the background's grid (motion.halved), in one compiled pass over
    a BGR frame picked on a coarser grid (kernels.picked_and_halved: the frame is read once, not the small image again);
    a frame on the evidence grid already is halved by a compiled pass too (kernels.halved_frame)."""
    if image.ndim == 3 and image.shape[2] == 3 and image.dtype == np.uint8 and image.flags.c_contiguous:
        return picked_and_halved(image, scale) if scale > 1 else (image, halved_frame(image))
    small = every_nth(image, scale)
    return small, halved(small)


_NO_HSV = np.zeros((0, 0, 3), np.uint8)  # the compiled pass takes arrays only: empty ones say "none"
_NO_TABLE = np.zeros((0, 0), np.uint8)
_NO_INDEX = np.zeros(0, np.intp)
_NO_ROWS = np.zeros(0, np.uint8)
_NO_WORDS = np.zeros((0, 0), np.uint64)
_NO_BOUNDS = np.zeros(0, np.int64)


@lru_cache(maxsize=16)
def _nearest(small: int, full: int) -> np.ndarray:
    """Which of ``small`` cells each of ``full`` pixels reads, as cv2.resize's INTER_NEAREST picks them."""
    index = np.minimum(np.floor(np.arange(full) * (small / full)).astype(np.intp), small - 1)
    return index


def _streaks_only(moving: np.ndarray, in_range: np.ndarray, min_blob_area: int, rows: np.ndarray | None = None) -> None:
    """Clears, in place, the moving pixels out of the range (in the streak range only) but in moving blobs shaped
    like a streak that are mostly that pale, with fewer pixels in range around them than pale ones: only a ball swept
    over the background during the exposure is that pale. A slower ball's pale rim stays out (a sliver of it in the
    moving map can be streak-shaped, beside the ball in range: pendulum4 lost a ball for 3 frames). ``rows``: as
    find_blobs takes them. Called only when some moving pixel is out of the range (evidence_maps counts them); the
    moving map is labelled only when some blob of it could be mostly that pale (_could_keep: a moving ball's pale rim
    is a small share of its blob; pendulum4 labelled it in every frame to keep nothing)."""
    kept = _kept_streaks(moving, in_range, min_blob_area, rows) if _could_keep(moving, in_range, min_blob_area, rows) else []
    cv2.bitwise_and(moving, in_range, dst=moving)  # every pale pixel out (both maps 0/1), then the streaks' back
    for ys, xs in kept:
        moving[ys, xs] = 1


FRESH_SHARE = 0.5  # a faint streak blob must have changed from the frame before in this share of its pixels at least
KNOWN_SHARE = 0.2  # a faint streak blob with more of its pixels in the moving map or the range than this is no new streak
FAINT_MIN_CELLS = 6  # a faint streak keeps at least this many of the background's cells' worth of pale pixels


def _faint_streaks(in_range, moving, faint: Faint, streak: np.ndarray, rows: np.ndarray, least: int) -> tuple | None:
    """The pixels that could be a faint streak's (blob_kernels.pale_cells on the background's grid, read at the image's size
    as the foreground is) with the ``moving`` map's, the rows that may hold any (``rows`` and theirs), and the cells'
    marks there (2: changed from the frame before) with which cell each pixel's row and column reads; None when too few
    of them are out of the range and the moving map for a streak to keep ``least`` pale pixels (_kept_streaks: a blob
    kept is at most KNOWN_SHARE in the moving map or the range, and of the rest at least ``least``)."""
    if not cv2.countNonZero(faint.cells):
        return None
    cells = np.empty_like(faint.cells)
    pale_cells(faint.cells, faint.image, faint.behind, streak, faint.bounds, faint.others, cells)
    if not cv2.countNonZero(cells):
        return None
    h, w = in_range.shape
    cell_rows, cell_cols = _nearest(cells.shape[0], h), _nearest(cells.shape[1], w)
    pale, pale_rows = moving.copy(), rows.copy()
    new = faint_pixels(cells, cell_rows, cell_cols, in_range, moving, pale, pale_rows)
    if not new or new < (1 - KNOWN_SHARE) * least - 1:  # (less one pixel: the shares are compared in floating point)
        return None
    return pale, pale_rows, (cells, cell_rows, cell_cols)


def _add_faint_streaks(moving, in_range, faint: Faint, streak: np.ndarray, min_blob_area: int, rows: np.ndarray) -> tuple:
    """Adds to ``moving``, in place, the pale pixels of new faint streaks (_faint_streaks, _kept_streaks); returns the
    rows that may hold a pixel of any map now (``rows`` when none was added) and the streaks' pixels (ys, xs) added."""
    h, w = in_range.shape
    least = int(np.ceil(FAINT_MIN_CELLS * w * h / faint.cells.size))  # pixels per cell of the background's grid
    more = _faint_streaks(in_range, moving, faint, streak, rows, least)
    if more is None:
        return rows, []
    pale, pale_rows, marks = more
    if not _could_keep(pale, in_range, min_blob_area, pale_rows, moving, marks, least):
        return rows, []  # (pendulum4: a faint halo around each moving ball, in every frame, none mostly new)
    kept = _kept_streaks(pale, in_range, min_blob_area, pale_rows, cv2.bitwise_or(moving, in_range), marks, least)
    for ys, xs in kept:
        moving[ys, xs] = 1
    return (pale_rows if kept else rows), kept


def words(image: np.ndarray) -> np.ndarray:
    """Each row's first w - w % 8 bytes of a uint8 image as uint64 words (H x w // 8), to test 8 pixels at once: a
    view of a C-contiguous image whose width is a multiple of 8, else a copy."""
    h, w = image.shape
    if w % 8 == 0 and image.flags.c_contiguous:
        return image.view(np.uint64)
    return np.ascontiguousarray(image[:, : w - w % 8]).view(np.uint64)


def _could_keep(moving, in_range, min_blob_area: int, rows, before=None, marks=None, least: int = 0) -> bool:
    """Whether some blob of ``moving`` passes every test of _kept_streaks but its shape's (blob_kernels.streak_candidates,
    without labelling it): False, and _kept_streaks would keep nothing. ``before`` is the faint pass's moving map
    before the faint pixels (``known`` there is it or the range), ``marks`` and ``least`` as _kept_streaks takes them."""
    cells, cell_rows, cell_cols = marks if marks is not None else (_NO_TABLE, _NO_INDEX, _NO_INDEX)
    return streak_candidates(
        moving,
        words(moving),
        _NO_ROWS if rows is None else rows,
        in_range,
        words(in_range),
        _NO_TABLE if before is None else before,
        _NO_WORDS if before is None else words(before),
        cells,
        cell_rows,
        cell_cols,
        LABEL_SCALE,
        min_blob_area,
        least,
        (KNOWN_SHARE, FRESH_SHARE),
    )


def _kept_streaks(
    moving: np.ndarray,
    in_range: np.ndarray,
    min_blob_area: int,
    rows: np.ndarray | None,
    known: np.ndarray | None = None,
    marks: tuple | None = None,
    least: int = 0,
) -> list:
    """The pale pixels (out of the range) of ``moving``'s blobs that are streaks, mostly that pale, with fewer pixels
    in range around them than pale ones (_streaks_only), as (ys, xs) per blob; with ``known`` (0/1), only of blobs
    mostly new there (KNOWN_SHARE): a streak the moving map holds already keeps its width (the faint halo around it
    would widen it, and a streak's width is its ball's depth: fast_ball tune seed 13 a third of a metre near); with
    the faint cells' ``marks`` (the cells, and which cell each pixel's row and column reads: _faint_streaks), only of
    blobs mostly changed from the frame before (FRESH_SHARE), and keeping ``least``
    pale pixels at least (FAINT_MIN_CELLS: the faint streaks of fast_ball tune seeds 14, 17 keep 140-720 pixels, 35 cells
    and more; a pair of faint cells is noise, which seeded a false track in hands tune seed 19)."""
    blobs = find_blobs(moving, "components", min_blob_area, rows)
    s = blobs.label_scale
    kept = []
    shaped = blobs.swept if marks is None or not len(blobs) else _ragged_streaks(blobs)  # (the faint pass's are of cells)
    for k in np.flatnonzero(shaped) if len(blobs) else ():  # only streak-shaped blobs keep pale pixels: look in their boxes
        x0, y0, x1, y1 = (int(c) * s for c in blobs.boxes[k])
        ys, xs = np.nonzero(moving[y0:y1, x0:x1])
        mine = blobs.label_blob[blobs.labels[(ys + y0) // s, (xs + x0) // s]] == k
        ys, xs = ys[mine] + y0, xs[mine] + x0
        if known is not None and np.count_nonzero(known[ys, xs]) > KNOWN_SHARE * len(ys):
            continue
        if marks is not None and np.count_nonzero(marks[0][marks[1][ys], marks[2][xs]] == 2) < FRESH_SHARE * len(ys):
            continue  # mostly where it was the frame before: a ghost (a streak overlaps the one before it a little)
        paler = in_range[ys, xs] == 0
        pale_share = paler.sum() / max(len(ys), 1)
        if pale_share <= 0.5:
            continue
        grow = int(np.ceil(blobs.axes[k, 0]))  # and no more of the ball's colour around it (its length again on every side)
        around = int(in_range[max(y0 - grow, 0) : y1 + grow, max(x0 - grow, 0) : x1 + grow].sum())
        if around < pale_share * blobs.areas[k] and np.count_nonzero(paler) >= least:
            kept.append((ys[paler], xs[paler]))
    return kept


# A faint streak's pale cells fill this much of their moments' ellipse at least (fast_ball tune seed 35: 0.70-0.79 where a
# mask's streak must fill 0.8; a square of cells fills 0.95 of its ellipse but is no longer than wide).
FAINT_FILL = 0.7


def _ragged_streaks(blobs: Blobs) -> np.ndarray:
    """Per blob: shaped like a streak as a faint one's pale pixels are, the background grid's 2 x 2 cells (a ragged
    capsule): as long as a streak, filling FAINT_FILL of its ellipse, away from the edge; no evenness asked."""
    h, w = blobs.labels.shape
    b = blobs.boxes
    inside = (b[:, 0] > 0) & (b[:, 1] > 0) & (b[:, 2] < w) & (b[:, 3] < h)
    return streaks(blobs.areas, blobs.axes, fill=FAINT_FILL) & inside


# A streak-shaped blob under this share of whose pixels move is still: a rod, a stripe (none move). A ball at the end of
# an arm of its hue moved by the hand shows its edges moving (a uniform arm changes at its edges only).
STILL_SHARE = 0.1


def still_streaks(blobs: Blobs, moving: np.ndarray | None) -> np.ndarray:
    """Per blob: shaped like a streak (Blobs.swept: as wide as a ball, and longer) with under STILL_SHARE of its pixels
    in ``moving`` (H x W 0/1; None: no motion, nothing is known still). A ball is smeared into a streak only by its
    motion, so this is a rod, a stripe, the rim of a disc seen edge on, of the ball's colour, which would seed particles
    wherever its width is a ball's, and whose end fills a ball's core with most of its ring empty. Such clutter was
    tracked from the first frames and, kept out of the background by its own track, for ever (static_props tune
    seeds 38, 40: a rod, a plank; hue_wall 39: a wall's stripes; white_ball 15: a shelf's edge). Blobs without shapes
    (the histogram finder) are no streaks."""
    out = np.zeros(len(blobs), bool)
    if moving is None or blobs.swept is None or not blobs.swept.any():
        return out
    s, labels = blobs.label_scale, blobs.labels
    sampled = moving[::s, ::s][: labels.shape[0], : labels.shape[1]]  # the pixels the labels stand for
    moved = np.bincount(labels[sampled > 0], minlength=len(blobs.label_blob)) * (s * s)
    per_blob = np.zeros(len(blobs))
    mine = blobs.label_blob >= 0
    per_blob[blobs.label_blob[mine]] = moved[mine]
    return blobs.swept & (per_blob < STILL_SHARE * blobs.areas)


DUPLICATE_PX = 2.0  # a moving blob whose centroid is this close to a colour blob's, and about its size, is that blob
# A moving blob of its own (no colour blob) makes crossings when it is as solid as a ball's disc: no longer than ALONE_ASPECT
# times its width, filling ALONE_FILL of its ellipse. hue_wall tune seed 115, two balls moving before a curtain of their hue:
# aspect 1.07-1.52, fill 0.65-0.98 (most over 0.8); the moving edges of hands of the ball's colour (hands tune seed 12)
# are ragged, fill 0.5-0.65 mostly, and their crossings had made lasting false balls (0.822 -> 0.189).
ALONE_ASPECT, ALONE_FILL = 1.6, 0.75
# ... or, as round as a ball's disc (no longer than ROUND_ALONE_ASPECT times its width), fills ROUND_ALONE_FILL of it: a ball
# whose middle matches the wall behind it moves at its rim and in specks (hue_wall tune seeds 95, 74: aspect 1.0-1.2, fill
# 0.55-0.72, no crossing, found after 27 and 35 frames), where a hand's moving edge is a band along it, longer than wide.
ROUND_ALONE_ASPECT, ROUND_ALONE_FILL = 1.25, 0.5
# p(ball | colour) x 255 above which a pixel is surely the ball's colour: a ball has p near 1 where a wall, a prop
# or an arm of its hue, which the mask's p > 0.5 merges with it into one blob that is no ball, has p near 0.5.
SURE = 191
# A ball whose colour the model doubts pixel by pixel (a room full of its hue: p near 0.5 on its body) is a speckled disc
# in the mask and nowhere sure; the range's blob of it stands for it when the model leans to the ball over the blob as a
# whole (mean p x 255; hue_wall tune seed 51: 174-185 on the ball, 119-160 on the walls' pieces that pass ball_like) and
# it is round: about as wide as long, filling its ellipse as a disc does, and under the share of its box a rectangle
# fills (a disc fills pi / 4 = 0.79 of it; pieces of a wall between a shelf's boards, which the model may lean to too,
# fill it whole: hue_wall tune seed 86).
LEANS = 160
ROUND_ASPECT, ROUND_FILL, ROUND_BOX = 1.3, 0.85, 0.88


def _round_and_leaning(blobs: Blobs, ids: np.ndarray, soft: np.ndarray, in_range: np.ndarray) -> np.ndarray:
    """Per blob ``ids`` of the range (bool): is it round (ROUND_*) and is the mean of ``soft`` over the range's pixels in
    its box at least LEANS? A handful of blobs a frame pass ball_like and are held by no seed: a loop over the round ones."""
    if blobs.axes is None or blobs.boxes is None:  # the histogram finder measures no shape
        return np.zeros(len(ids), bool)
    boxes = (blobs.boxes[ids] * blobs.label_scale).astype(int)
    box_fills = blobs.areas[ids] / np.maximum((boxes[:, 2] - boxes[:, 0]) * (boxes[:, 3] - boxes[:, 1]), 1)
    semi_major, semi_minor = blobs.axes[ids].T
    out = (semi_major <= ROUND_ASPECT * semi_minor) & (blobs.ellipse_fills()[ids] >= ROUND_FILL) & (box_fills <= ROUND_BOX)
    for k in np.flatnonzero(out):
        x0, y0, x1, y1 = boxes[k]
        ranged = in_range[y0:y1, x0:x1] > 0
        out[k] = ranged.any() and soft[y0:y1, x0:x1][ranged].mean() >= LEANS
    return out


def _seeds(
    camera, blobs, origins, directions, moving, soft, blob_method, min_blob_area, ball, rows=None, still=None, in_range=None
) -> Seeds:
    """Ball-like blobs of the colour mask, then those of its moving part that are not the same blob again
    (a ball moving in front of a wall of its colour is a blob of its own only in the moving part), then, when
    a colour blob was no ball (a ball merged with scenery of its hue: a hand, a prop, a wall), the ball-like
    blobs of the colour that is surely the ball's (``soft`` above SURE; None: no colour model) that no seed holds yet,
    then the round ones of the whole range (``in_range``, the mask before the colour model) that none holds and over
    which the model leans to the ball (_round_and_leaning): where the room has much of the ball's colour, the model
    keeps its body's pixels only here and there, a speckled disc that fills too little of its ellipse (hue_wall tune
    seed 51: no seed in 16 frames of a ball before a pale wall).
    With motion, a streak that does not move (``still``, still_streaks) is no ball."""
    keep = ball_like(blobs, camera.focal_px, *ball) if ball is not None else np.ones(len(blobs), bool)
    mb = find_blobs(moving, blob_method, min_blob_area, rows) if moving is not None else None
    moves = np.zeros(len(blobs), bool)  # a colour blob that is a moving one too moves
    if mb is not None and len(blobs) and len(mb):
        dist = np.linalg.norm(mb.centres[:, None] - blobs.centres[None], axis=2)
        same = (dist < DUPLICATE_PX) & (mb.areas[:, None] > 0.7 * blobs.areas[None])
        moves = same.any(axis=0)
    no_ball = not keep.all()  # a colour blob that is no ball: perhaps a ball merged with scenery (the sure colour, below)
    if ball is not None and still is not None:
        keep &= ~still
    centres, radii, o, d = [blobs.centres[keep]], [blobs.radii[keep]], [origins[keep]], [directions[keep]]
    moved = [moves[keep]]
    widths = [blobs.ball_radii()[keep]]
    alone = [np.zeros(int(keep.sum()), bool)]

    def take(more: Blobs, new: np.ndarray, moving: bool, solid: np.ndarray | None = None) -> None:
        if new.any():
            mo, md = camera.rays(more.centres[new])
            centres.append(more.centres[new])
            radii.append(more.radii[new])
            widths.append(more.ball_radii()[new])
            o.append(mo)
            d.append(md)
            moved.append(np.full(int(new.sum()), moving))
            alone.append(np.zeros(int(new.sum()), bool) if solid is None else solid[new])

    if mb is not None:
        new = ball_like(mb, camera.focal_px, *ball) if ball is not None else np.ones(len(mb), bool)
        if len(blobs) and len(mb):
            new &= ~same.any(axis=1)
        solid = None
        if mb.axes is not None:  # (the histogram finder measures no shape)
            fills, minor = mb.ellipse_fills(), np.maximum(mb.axes[:, 1], 0.5)
            solid = (mb.axes[:, 0] <= ALONE_ASPECT * minor) & (fills >= ALONE_FILL)
            solid |= (mb.axes[:, 0] <= ROUND_ALONE_ASPECT * minor) & (fills >= ROUND_ALONE_FILL)
        take(mb, new, True, solid)
    if soft is not None and no_ball:
        sure = cv2.threshold(soft, SURE, 1, cv2.THRESH_BINARY)[1]  # made only here: most frames every colour blob is a ball
        for more in (sure,) if in_range is None else (sure, in_range):
            sb = find_blobs(more, blob_method, min_blob_area, rows)
            new = ball_like(sb, camera.focal_px, *ball)
            new &= ~still_streaks(sb, moving)
            held_c, held_r = np.vstack(centres).reshape(-1, 2), np.concatenate(radii)
            if len(sb) and len(held_c):
                dist = np.linalg.norm(sb.centres[:, None] - held_c[None], axis=2)
                new &= ~(dist < np.maximum(held_r[None], DUPLICATE_PX)).any(axis=1)
            if more is in_range and new.any():
                new[new] = _round_and_leaning(sb, np.nonzero(new)[0], soft, in_range)
            take(sb, new, False)
    return Seeds(
        np.vstack(centres).reshape(-1, 2),
        np.concatenate(radii),
        np.vstack(o).reshape(-1, 3),
        np.vstack(d).reshape(-1, 3),
        moved=np.concatenate(moved),
        widths=np.concatenate(widths),
        alone=np.concatenate(alone),
    )
