"""Calibration views: one image per camera for each moment the board was held still.

Image folders are matched by exact file name (for glob patterns, by the part
the wildcard matched), frames are sampled from a recording, or taken from
live frame pairs; the board is detected in every image. The images are kept
only when asked for (to draw or log what the calibration saw).
"""

from __future__ import annotations

import glob
import math
import os
import re
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from ..console import Progress, quiet_native_stderr, warn
from ..errors import StereotrackError
from .boards import MIN_CORNERS, Board, BoardDetector, Detection, flipped, to_grey

MIN_VIEWS = 5  # fewer views than this cannot pin down focal length, centre and distortion


RECOMMENDED_VIEWS = 15


IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp", ".pgm", ".ppm")


_SAMPLES_KEPT = 3  # images kept per camera to explain a board that is never found


@dataclass(frozen=True, eq=False)
class ViewSet:
    """Board detections per view and camera: ``detections[v][c]`` is a Detection or None."""

    camera_names: tuple[str, ...]
    image_sizes: tuple[tuple[int, int], ...]  # (width, height) per camera
    view_names: tuple[str, ...]
    detections: tuple[tuple[Detection | None, ...], ...]
    samples: tuple[tuple[np.ndarray, ...], ...] = field(default=())  # a few raw images per camera, for diagnosis
    images: tuple[tuple[np.ndarray, ...], ...] = field(default=())  # grey image per view and camera, when kept

    @property
    def n_views(self) -> int:
        return len(self.view_names)

    def seen_by(self, c: int) -> list[int]:
        return [v for v in range(self.n_views) if self.detections[v][c] is not None]

    def without(self, names: Iterable[str]) -> ViewSet:
        drop = set(names)
        keep = [v for v, n in enumerate(self.view_names) if n not in drop]
        return replace(
            self,
            view_names=tuple(self.view_names[v] for v in keep),
            detections=tuple(self.detections[v] for v in keep),
            images=tuple(self.images[v] for v in keep) if self.images else (),
        )


def _list_images(source: str) -> list[Path]:
    p = Path(source)
    if p.is_dir():
        files = sorted(f for f in p.iterdir() if f.suffix.lower() in IMAGE_SUFFIXES)
        where = f"{p}"
    else:
        files = sorted(Path(f) for f in glob.glob(source) if Path(f).suffix.lower() in IMAGE_SUFFIXES)
        where = f"{source}" if not glob.has_magic(source) else f"pattern {source!r}"
    if not files:
        raise StereotrackError(f"{where}: no images found (expected a folder or a glob pattern of .png/.jpg files)")
    return files


def view_name(source: str, path: Path) -> str:
    """The name that pairs an image with the other cameras' images of the same view.

    In a folder it is the file name without its extension (cam0/001.png -> 001);
    for a glob pattern it is the text the wildcards matched (left*.jpg: left01.jpg -> 01).
    """
    if Path(source).is_dir() or not glob.has_magic(source):
        return path.stem
    found = _wildcards(os.path.normpath(source)).match(os.path.normpath(str(path)))
    return "".join(found.groups()) if found else path.stem


def _wildcards(pattern: str) -> re.Pattern:
    """A glob pattern as a regular expression with one group per wildcard (*, ?, [...])."""
    out, i = [], 0
    while i < len(pattern):
        ch = pattern[i]
        end = pattern.find("]", i + 2) if ch == "[" else -1
        if ch == "*":
            out.append("(.*)")
        elif ch == "?":
            out.append("(.)")
        elif end > 0:  # a set such as [0-9] or [!a]
            body = pattern[i + 1 : end]
            out.append("([" + ("^" + body[1:] if body.startswith("!") else body) + "])")
            i = end
        else:
            out.append(re.escape(ch))
        i += 1
    return re.compile("".join(out) + r"\Z")


def match_image_files(sources: Sequence[str]) -> tuple[list[str], list[list[Path]]]:
    """Image files matched across cameras by exact name: (view names, files per view, one per camera).

    Only equal names pair (see ``view_name``): 01.jpg never pairs with r1.jpg.
    Images without a partner are skipped with a warning; no pair at all is an error.
    """
    keyed: list[dict[str, Path]] = []
    for source in sources:
        named: dict[str, Path] = {}
        for f in _list_images(source):
            name = view_name(source, f)
            if name in named:
                raise StereotrackError(
                    f"{source}: {named[name].name} and {f.name} both name view {name!r}; keep one image per view and camera"
                )
            named[name] = f
        keyed.append(named)
    common = sorted(set(keyed[0]).intersection(*keyed[1:]))
    if not common:
        examples = " and ".join(f"{next(iter(k.values())).name} in {s}" for s, k in zip(sources, keyed))
        raise StereotrackError(
            f"no image names match between {' and '.join(sources)} (e.g. {examples}); images of one view must have the same name "
            f"for every camera (cam0/001.png and cam1/001.png), or give glob patterns whose wildcard part matches "
            f"(--images 'shots/left*.jpg' 'shots/right*.jpg' pairs left01.jpg with right01.jpg)"
        )
    for source, k in zip(sources, keyed):
        alone = sorted(set(k) - set(common))
        if alone:
            warn(
                f"{source}: {len(alone)} image(s) have no partner with the same name in the other folders and are skipped (e.g. {k[alone[0]].name})"
            )
    return common, [[k[name] for k in keyed] for name in common]


def _read_grey(path: Path) -> np.ndarray:
    if not path.is_file():
        raise StereotrackError(f"{path}: not a regular file; expected an image")
    try:
        with quiet_native_stderr():  # libjpeg's own "Premature end of JPEG file" and the like
            img = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    except cv2.error as exc:  # e.g. a header that claims more pixels than OpenCV's limit
        raise StereotrackError(f"{path}: OpenCV cannot read this image ({str(exc).strip().splitlines()[-1][:120]})") from None
    if img is None:
        raise StereotrackError(f"{path}: OpenCV cannot read this image")
    return img


def views_from_images(
    board: Board,
    sources: Sequence[str],
    camera_names: Sequence[str] | None = None,
    subpix_window: int | None = None,
    progress: bool = True,
    keep_images: bool = False,
) -> ViewSet:
    """Detect the board in image folders (or glob patterns), one per camera, matched by file name.

    ``keep_images``: keep the grey images in the ViewSet (to draw or log the views afterwards).
    """
    if len(sources) < 2:
        raise StereotrackError("give one image folder per camera, at least two (e.g. --images left/ right/)")
    names = list(camera_names) if camera_names else [f"cam{i}" for i in range(len(sources))]
    view_names, files = match_image_files(sources)
    detector = BoardDetector(board, subpix_window)
    sizes: list[tuple[int, int] | None] = [None] * len(sources)
    first_file: list[Path | None] = [None] * len(sources)
    samples: list[list[np.ndarray]] = [[] for _ in sources]
    detections, images = [], []
    bar = Progress(len(view_names), "detecting the board", "views", enabled=progress)
    for view in files:
        row, kept = [], []
        for c, path in enumerate(view):
            img = _read_grey(path)
            size = (img.shape[1], img.shape[0])
            if sizes[c] is None:
                sizes[c], first_file[c] = size, path
            elif size != sizes[c]:
                raise StereotrackError(
                    f"{path}: image is {size[0]}x{size[1]} but {first_file[c].name} is {sizes[c][0]}x{sizes[c][1]}: "
                    f"all images of one camera must have the same size (same resolution setting)"
                )
            det = detector.detect(img)
            if det is None and len(samples[c]) < _SAMPLES_KEPT:
                samples[c].append(img)
            row.append(det)
            kept.append(img)
        detections.append(tuple(row))
        if keep_images:
            images.append(tuple(kept))
        bar.update(1, extra=_seen_summary(names, detections))
    bar.close()
    return ViewSet(tuple(names), tuple(sizes), tuple(view_names), tuple(detections), tuple(tuple(s) for s in samples), tuple(images))


def _seen_summary(names: Sequence[str], detections: Sequence[Sequence[Detection | None]]) -> str:
    counts = [sum(row[c] is not None for row in detections) for c in range(len(names))]
    both = sum(all(d is not None for d in row) for row in detections)
    return "board seen: " + " ".join(f"{n} {k}" for n, k in zip(names, counts)) + f", all {both}"


def _mean_shift(a: Detection, b: Detection) -> float:
    """Mean pixel distance between the corners two detections share (inf if they share too few)."""
    common, ia, ib = np.intersect1d(a.ids, b.ids, return_indices=True)
    if len(common) < MIN_CORNERS:
        return math.inf
    return float(np.linalg.norm(a.corners[ia] - b.corners[ib], axis=1).mean())


def coverage_grid(corners: Iterable[np.ndarray], image_size: tuple[int, int], cells: int = 8) -> np.ndarray:
    """How many board corners fell in each cell of a grid over the image (``cells`` across): the coverage heat-map."""
    w, h = image_size
    nx = cells
    ny = max(1, round(cells * h / w))
    counts = np.zeros((ny, nx), int)
    for pts in corners:
        if len(pts) == 0:
            continue
        ix = np.clip((pts[:, 0] / w * nx).astype(int), 0, nx - 1)
        iy = np.clip((pts[:, 1] / h * ny).astype(int), 0, ny - 1)
        np.add.at(counts, (iy, ix), 1)
    return counts


def coverage(corners: Iterable[np.ndarray], image_size: tuple[int, int], cells: int = 8) -> float:
    """Share of the image's grid cells (``cells`` across) that hold at least one board corner."""
    return float((coverage_grid(corners, image_size, cells) > 0).mean())


def views_from_frames(
    board: Board,
    frames: Iterable[Any],
    camera_names: Sequence[str],
    every: int = 1,
    max_views: int = 30,
    min_new: float = 0.05,
    steady_px: float | None = None,
    total: int | None = None,
    progress: bool = True,
    label: str = "looking for board views",
    subpix_window: int | None = None,
    keep_images: bool = False,
    on_view: Callable[[ViewSet], None] | None = None,
) -> ViewSet:
    """Pick views from a stream of FramePairs (a recording or live cameras).

    A frame pair becomes a view when the board is seen by at least two
    cameras and its pose is new: in some camera its corners moved by more
    than ``min_new`` of the image diagonal from every view already taken.
    With ``steady_px`` the next frame pair must show the board within that
    many pixels (mean corner motion), so blurred, moving boards are skipped.
    Only every ``every``-th pair is examined (and the one after it).
    Each view taken is announced on the progress line (a plain line when
    stderr is not a terminal) and, with ``on_view``, passed on as the views
    so far (a live viewer shows them as they come).
    """
    names = tuple(camera_names)
    detector = BoardDetector(board, subpix_window)
    taken: list[tuple[Detection | None, ...]] = []
    taken_names: list[str] = []
    taken_images: list[tuple[np.ndarray, ...]] = []
    sizes: tuple[tuple[int, int], ...] | None = None
    samples: list[list[np.ndarray]] = [[] for _ in names]
    pending: tuple[int, tuple[Detection | None, ...], tuple[np.ndarray, ...]] | None = None
    bar = Progress(total, label, "frames", enabled=progress)

    def viewset() -> ViewSet:
        return ViewSet(names, sizes, tuple(taken_names), tuple(taken), tuple(tuple(s) for s in samples), tuple(taken_images))

    def take(index: int, dets: tuple[Detection | None, ...], images: tuple[np.ndarray, ...]) -> None:
        taken.append(dets)
        taken_names.append(f"frame{index:06d}")
        if keep_images:
            taken_images.append(tuple(to_grey(img) for img in images))
        bar.say(_take_summary(names, taken, sizes))
        if on_view is not None:
            on_view(viewset())

    for pair in frames:
        bar.update(1)
        if sizes is None:
            sizes = tuple((img.shape[1], img.shape[0]) for img in pair.images)
            if len(sizes) != len(names):
                raise StereotrackError(f"the source has {len(sizes)} cameras but {len(names)} camera names were given")
        look = pair.index % every == 0 or pending is not None
        if not look:
            continue
        dets = tuple(detector.detect(img) for img in pair.images)
        for c, (img, d) in enumerate(zip(pair.images, dets)):
            if d is None and len(samples[c]) < _SAMPLES_KEPT and pair.index % max(1, 10 * every) == 0:
                samples[c].append(img)
        if pending is not None:
            idx, cand, cand_images = pending
            pending = None
            steady = all(a is None or (b is not None and _mean_shift(a, b) <= steady_px) for a, b in zip(cand, dets))
            if steady and _is_new(board, cand, taken, sizes, min_new):
                take(idx, cand, cand_images)
                if len(taken) >= max_views:
                    break
            if pair.index % every != 0:
                continue
        if sum(d is not None for d in dets) < min(2, len(dets)) or not _is_new(board, dets, taken, sizes, min_new):
            continue
        if steady_px is None:
            take(pair.index, dets, pair.images)
            if len(taken) >= max_views:
                break
        else:
            pending = (pair.index, dets, pair.images)
    bar.close()
    if sizes is None:
        raise StereotrackError("the source gave no frames")
    return viewset()


def _is_new(board: Board, dets: Sequence[Detection | None], taken: Sequence[Sequence[Detection | None]], sizes, min_new: float) -> bool:
    for old in taken:
        moved = False
        for c, (a, b) in enumerate(zip(dets, old)):
            if a is None or b is None:
                if (a is None) != (b is None):
                    moved = True  # seen by another set of cameras: counts as new
                continue
            diag = math.hypot(*sizes[c])
            shift = _mean_shift(a, b)
            if board.type == "chessboard":  # the same pose numbered from the other end is not new
                shift = min(shift, _mean_shift(flipped(board, a), b))
            if shift > min_new * diag:
                moved = True
        if not moved:
            return False
    return True


def _take_summary(names, taken, sizes) -> str:
    cov = [coverage([row[c].corners for row in taken if row[c] is not None], sizes[c]) for c in range(len(names))]
    return f"views taken {len(taken)}, coverage " + " ".join(f"{n} {100 * v:.0f}%" for n, v in zip(names, cov))
