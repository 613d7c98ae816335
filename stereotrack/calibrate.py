"""Rig calibration from board views: collect views, calibrate, judge the result.

1. Views: one image per camera for each moment the board was held still
   (image folders matched by file name, frames sampled from a recording,
   or live frame pairs). The board is detected in every image.
2. Intrinsics per camera (``cv2.calibrateCamera``), then the pose of every
   other camera relative to the first (``cv2.stereoCalibrate`` with the
   intrinsics fixed, optionally a joint refinement). More than two cameras
   are chained pairwise along the pairs that share most views.
3. A report: per-camera and stereo RMS, epipolar error, per-view errors
   with the worst views named, baseline, image coverage, and a verdict
   (good / usable / redo) with the reasons in plain words.
"""

from __future__ import annotations

import glob
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import yaml

from .boards import MIN_CORNERS, Board, BoardDetector, Detection, board_to_dict, diagnose, flipped
from .camera import Camera, Rig
from .console import Progress, warn
from .errors import StereotrackError

MIN_VIEWS = 5  # fewer views than this cannot pin down focal length, centre and distortion
RECOMMENDED_VIEWS = 15
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp", ".pgm", ".ppm")
_SAMPLES_KEPT = 3  # images kept per camera to explain a board that is never found


# --------------------------------------------------------------------------- views


@dataclass(frozen=True, eq=False)
class ViewSet:
    """Board detections per view and camera: ``detections[v][c]`` is a Detection or None."""

    camera_names: tuple[str, ...]
    image_sizes: tuple[tuple[int, int], ...]  # (width, height) per camera
    view_names: tuple[str, ...]
    detections: tuple[tuple[Detection | None, ...], ...]
    samples: tuple[tuple[np.ndarray, ...], ...] = field(default=())  # a few raw images per camera, for diagnosis

    @property
    def n_views(self) -> int:
        return len(self.view_names)

    def seen_by(self, c: int) -> list[int]:
        return [v for v in range(self.n_views) if self.detections[v][c] is not None]

    def without(self, names: Iterable[str]) -> ViewSet:
        drop = set(names)
        keep = [v for v, n in enumerate(self.view_names) if n not in drop]
        return replace(self, view_names=tuple(self.view_names[v] for v in keep), detections=tuple(self.detections[v] for v in keep))


def _view_key(stems: list[str]) -> list[str]:
    """Names with the part common to the whole folder cut off the front (left01 -> 01, right01 -> 01)."""
    if len(stems) < 2:
        return stems
    prefix = stems[0]
    for s in stems[1:]:
        while not s.startswith(prefix):
            prefix = prefix[:-1]
    prefix = prefix.rstrip("0123456789")  # never cut into a number: left01..left09 -> 01..09
    return [s[len(prefix) :] or s for s in stems]


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


def _trailing_number(stems: list[str]) -> list[str]:
    """left01 -> 1, cam1_0007 -> 7 (names without a trailing number keep their stem)."""
    out = []
    for stem in stems:
        digits = len(stem) - len(stem.rstrip("0123456789"))
        out.append(str(int(stem[-digits:])) if digits else stem)
    return out


def match_image_files(sources: Sequence[str]) -> tuple[list[str], list[list[Path]]]:
    """Image files matched across cameras by name: (view names, files per view, one per camera).

    Three ways to match are tried (same name; name without the folder's common
    prefix, left01 <-> right01; same trailing number) and the one that pairs
    the most images wins.
    """
    per_cam = [_list_images(s) for s in sources]
    best: tuple[list[str], list[dict[str, Path]]] | None = None
    for keys_of in (lambda stems: stems, _view_key, _trailing_number):
        keyed = []
        for files in per_cam:
            keys = keys_of([f.stem for f in files])
            keyed.append(dict(zip(keys, files)))
        common = sorted(set(keyed[0]).intersection(*keyed[1:]))
        if best is None or len(common) > len(best[0]):
            best = (common, keyed)
    common, keyed = best
    if not common:
        examples = ", ".join(f"{files[0].name}" for files in per_cam)
        raise StereotrackError(
            f"no image names match between {' and '.join(sources)} (first files: {examples}); "
            f"name the images of one view alike, e.g. cam0/001.png and cam1/001.png, or left01.jpg and right01.jpg"
        )
    for source, k in zip(sources, keyed):
        alone = sorted(set(k) - set(common))
        if alone:
            warn(f"{source}: {len(alone)} image(s) have no partner in the other folders and are skipped (e.g. {k[alone[0]].name})")
    return common, [[k[name] for k in keyed] for name in common]


def _read_grey(path: Path) -> np.ndarray:
    img = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    if img is None:
        raise StereotrackError(f"{path}: OpenCV cannot read this image")
    return img


def views_from_images(
    board: Board,
    sources: Sequence[str],
    camera_names: Sequence[str] | None = None,
    subpix_window: int | None = None,
    progress: bool = True,
) -> ViewSet:
    """Detect the board in image folders (or glob patterns), one per camera, matched by file name."""
    if len(sources) < 2:
        raise StereotrackError("give one image folder per camera, at least two (e.g. --images left/ right/)")
    names = list(camera_names) if camera_names else [f"cam{i}" for i in range(len(sources))]
    view_names, files = match_image_files(sources)
    detector = BoardDetector(board, subpix_window)
    sizes: list[tuple[int, int] | None] = [None] * len(sources)
    first_file: list[Path | None] = [None] * len(sources)
    samples: list[list[np.ndarray]] = [[] for _ in sources]
    detections = []
    bar = Progress(len(view_names), "detecting the board", "views", enabled=progress)
    for view in files:
        row = []
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
        detections.append(tuple(row))
        bar.update(1, extra=_seen_summary(names, detections))
    bar.close()
    return ViewSet(tuple(names), tuple(sizes), tuple(view_names), tuple(detections), tuple(tuple(s) for s in samples))


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


def coverage(corners: Iterable[np.ndarray], image_size: tuple[int, int], cells: int = 8) -> float:
    """Share of the image's grid cells (``cells`` across) that hold at least one board corner."""
    w, h = image_size
    nx = cells
    ny = max(1, round(cells * h / w))
    hit = np.zeros((ny, nx), bool)
    for pts in corners:
        if len(pts) == 0:
            continue
        ix = np.clip((pts[:, 0] / w * nx).astype(int), 0, nx - 1)
        iy = np.clip((pts[:, 1] / h * ny).astype(int), 0, ny - 1)
        hit[iy, ix] = True
    return float(hit.mean())


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
) -> ViewSet:
    """Pick views from a stream of FramePairs (a recording or live cameras).

    A frame pair becomes a view when the board is seen by at least two
    cameras and its pose is new: in some camera its corners moved by more
    than ``min_new`` of the image diagonal from every view already taken.
    With ``steady_px`` the next frame pair must show the board within that
    many pixels (mean corner motion), so blurred, moving boards are skipped.
    Only every ``every``-th pair is examined (and the one after it).
    """
    names = tuple(camera_names)
    detector = BoardDetector(board, subpix_window)
    taken: list[tuple[Detection | None, ...]] = []
    taken_names: list[str] = []
    sizes: tuple[tuple[int, int], ...] | None = None
    samples: list[list[np.ndarray]] = [[] for _ in names]
    pending: tuple[int, tuple[Detection | None, ...]] | None = None
    bar = Progress(total, label, "frames", enabled=progress)
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
            idx, cand = pending
            pending = None
            steady = all(a is None or (b is not None and _mean_shift(a, b) <= steady_px) for a, b in zip(cand, dets))
            if steady and _is_new(board, cand, taken, sizes, min_new):
                taken.append(cand)
                taken_names.append(f"frame{idx:06d}")
                bar.update(0, extra=_take_summary(names, taken, sizes))
                if len(taken) >= max_views:
                    break
            if pair.index % every != 0:
                continue
        if sum(d is not None for d in dets) < min(2, len(dets)) or not _is_new(board, dets, taken, sizes, min_new):
            continue
        if steady_px is None:
            taken.append(dets)
            taken_names.append(f"frame{pair.index:06d}")
            bar.update(0, extra=_take_summary(names, taken, sizes))
            if len(taken) >= max_views:
                break
        else:
            pending = (pair.index, dets)
    bar.close()
    if sizes is None:
        raise StereotrackError("the source gave no frames")
    return ViewSet(names, sizes, tuple(taken_names), tuple(taken), tuple(tuple(s) for s in samples))


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


# --------------------------------------------------------------------------- calibration


@dataclass(frozen=True)
class CalibrationOptions:
    fix_aspect: bool = False  # fx / fy fixed at 1 (square pixels)
    zero_tangent: bool = False  # no tangential distortion (p1 = p2 = 0)
    fix_k3: bool = False  # no 6th-order radial term (steadier with few views)
    rational: bool = False  # 8-coefficient rational model (wide-angle lenses)
    refine: bool = False  # after the stereo step, refine intrinsics and extrinsics jointly
    drop_worst: int = 0  # drop this many worst views and calibrate again
    world_view: str | None = None  # name of a view whose board pose is the world (z up); None: first camera

    def flags(self) -> int:
        f = 0
        if self.fix_aspect:
            f |= cv2.CALIB_FIX_ASPECT_RATIO
        if self.zero_tangent:
            f |= cv2.CALIB_ZERO_TANGENT_DIST
        if self.fix_k3:
            f |= cv2.CALIB_FIX_K3
        if self.rational:
            f |= cv2.CALIB_RATIONAL_MODEL
        return f


@dataclass(frozen=True, eq=False)
class Intrinsics:
    K: np.ndarray
    dist: np.ndarray
    rms: float
    std_f: float  # standard deviation of fx from the calibration, pixels
    views: list[int]  # view indices used


@dataclass(frozen=True, eq=False)
class Calibration:
    rig: Rig
    report: dict[str, Any]
    views: ViewSet  # the views used (after any dropped)


def _points(board: Board, det: Detection) -> tuple[np.ndarray, np.ndarray]:
    obj = board.object_points()[det.ids].astype(np.float32).reshape(-1, 1, 3)
    return obj, det.corners.astype(np.float32).reshape(-1, 1, 2)


def calibrate_intrinsics(
    board: Board, detections: Sequence[Detection], image_size: tuple[int, int], flags: int = 0
) -> tuple[float, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``cv2.calibrateCamera`` on board detections: (rms, K, dist, per-view RMS, std of [fx, fy, cx, cy, ...])."""
    obj, img = zip(*(_points(board, d) for d in detections))
    K0 = np.eye(3)  # with CALIB_FIX_ASPECT_RATIO this sets fx / fy = 1
    rms, K, dist, _, _, std_in, _, per_view = cv2.calibrateCameraExtended(list(obj), list(img), tuple(image_size), K0, None, flags=flags)
    return float(rms), K, dist.ravel(), per_view.ravel(), std_in.ravel()


def _pose(board: Board, det: Detection, K: np.ndarray, dist: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Board -> camera (R, t) from one detection."""
    obj, img = _points(board, det)
    ok, rvec, tvec = cv2.solvePnP(obj, img, K, dist, flags=cv2.SOLVEPNP_ITERATIVE)
    return cv2.Rodrigues(rvec)[0], tvec.ravel()


def _reprojection(board: Board, det: Detection, K, dist) -> np.ndarray:
    """Per-corner reprojection error (pixels) with the board pose fitted to this view."""
    obj, img = _points(board, det)
    ok, rvec, tvec = cv2.solvePnP(obj, img, K, dist, flags=cv2.SOLVEPNP_ITERATIVE)
    proj, _ = cv2.projectPoints(obj, rvec, tvec, K, dist)
    return np.linalg.norm(proj.reshape(-1, 2) - img.reshape(-1, 2), axis=1)


def _angle_deg(R: np.ndarray) -> float:
    return math.degrees(math.acos(np.clip((np.trace(R) - 1) / 2, -1.0, 1.0)))


def _common(a: Detection, b: Detection) -> tuple[Detection, Detection] | None:
    common, ia, ib = np.intersect1d(a.ids, b.ids, return_indices=True)
    if len(common) < MIN_CORNERS:
        return None
    return Detection(common, a.corners[ia]), Detection(common, b.corners[ib])


def _shared_views(views: ViewSet, board: Board, i: int, j: int) -> list[int]:
    out = []
    for v in range(views.n_views):
        a, b = views.detections[v][i], views.detections[v][j]
        if a is None or b is None:
            continue
        common = np.intersect1d(a.ids, b.ids)
        r, c = np.divmod(common, board.inner[0])
        if len(common) >= MIN_CORNERS and len(np.unique(r)) > 1 and len(np.unique(c)) > 1:
            out.append(v)
    return out


def _make_labels_consistent(
    board: Board, views: list[list[Detection | None]], shared: list[int], i: int, j: int, intr: dict[int, Intrinsics]
) -> int:
    """Relabel camera j's chessboards that are numbered from the opposite end to camera i's.

    A chessboard can be found turned by half a turn in one camera and not the
    other; then that view's relative pose is off by 180 degrees. Each view
    proposes a relative rotation for both labellings; the labelling that
    agrees with most other views wins. Returns how many views were relabelled.
    """
    if board.type != "chessboard" or len(shared) < 2:
        return 0
    cand = []
    for v in shared:
        Ri, _ = _pose(board, views[v][i], intr[i].K, intr[i].dist)
        Rj, _ = _pose(board, views[v][j], intr[j].K, intr[j].dist)
        Rjf, _ = _pose(board, flipped(board, views[v][j]), intr[j].K, intr[j].dist)
        cand.append((Rj @ Ri.T, Rjf @ Ri.T))
    support = []
    for a in range(len(shared)):
        for option in (0, 1):
            ref = cand[a][option]
            support.append((sum(min(_angle_deg(c[0] @ ref.T), _angle_deg(c[1] @ ref.T)) < 10 for c in cand), a, option))
    _, a, option = max(support)
    ref = cand[a][option]
    changed = 0
    for k, v in enumerate(shared):
        if _angle_deg(cand[k][1] @ ref.T) < _angle_deg(cand[k][0] @ ref.T):
            views[v][j] = flipped(board, views[v][j])
            changed += 1
    return changed


def _spanning_tree(n_cams: int, shared: dict[tuple[int, int], list[int]], names: Sequence[str]) -> list[tuple[int, int]]:
    """Edges (parent, child) linking every camera to the first along the pairs sharing most views."""
    reached = {0}
    edges = []
    while len(reached) < n_cams:
        best = None
        for (a, b), vs in shared.items():
            for p, c in ((a, b), (b, a)):
                if p in reached and c not in reached and len(vs) >= MIN_VIEWS and (best is None or len(vs) > best[2]):
                    best = (p, c, len(vs))
        if best is None:
            lost = [c for c in range(n_cams) if c not in reached]
            c = lost[0]
            counts = {names[p]: len(shared.get((min(p, c), max(p, c)), [])) for p in reached}
            p_name, k = max(counts.items(), key=lambda kv: kv[1])
            if k == 0:
                raise StereotrackError(
                    f"cameras {p_name} and {names[c]} never see the board together in the same view: hold the board where "
                    f"both cameras see all of it and take at least {MIN_VIEWS} such views ({RECOMMENDED_VIEWS}-25 recommended)"
                )
            raise StereotrackError(
                f"cameras {p_name} and {names[c]} see the board together in only {k} views; need at least {MIN_VIEWS} "
                f"({MIN_VIEWS - k} more), {RECOMMENDED_VIEWS}-25 recommended: take more views where both cameras see the board"
            )
        reached.add(best[1])
        edges.append((best[0], best[1]))
    return edges


def _stereo(board: Board, views, shared: list[int], i: int, j: int, intr: dict[int, Intrinsics], sizes, flags: int, R0=None, T0=None):
    """``cv2.stereoCalibrate`` on the corners both cameras see: camera i -> camera j (R, T) and per-view RMS."""
    obj, img_i, img_j = [], [], []
    for v in shared:
        a, b = _common(views[v][i], views[v][j])
        o, pi = _points(board, a)
        _, pj = _points(board, b)
        obj.append(o)
        img_i.append(pi)
        img_j.append(pj)
    result = cv2.stereoCalibrateExtended(
        obj,
        img_i,
        img_j,
        intr[i].K.copy(),
        intr[i].dist.copy(),
        intr[j].K.copy(),
        intr[j].dist.copy(),
        tuple(sizes[i]),
        np.eye(3) if R0 is None else R0.copy(),
        np.zeros((3, 1)) if T0 is None else T0.reshape(3, 1).copy(),
        flags=flags,
    )
    rms, Ki, di, Kj, dj, R, T = result[:7]
    per_view = result[-1]
    return float(rms), Ki, di.ravel(), Kj, dj.ravel(), R, T.ravel(), np.asarray(per_view).reshape(len(shared), -1)


def epipolar_errors(cam_i: Camera, cam_j: Camera, px_i: np.ndarray, px_j: np.ndarray) -> np.ndarray:
    """Symmetric distance (pixels) of matched points to each other's epipolar lines, after undistortion."""
    R = cam_j.R @ cam_i.R.T
    T = cam_j.t - R @ cam_i.t
    Tx = np.array([[0, -T[2], T[1]], [T[2], 0, -T[0]], [-T[1], T[0], 0]])
    E = Tx @ R
    xi = np.column_stack([cam_i.undistort_pixels(px_i), np.ones(len(px_i))])
    xj = np.column_stack([cam_j.undistort_pixels(px_j), np.ones(len(px_j))])
    F = np.linalg.inv(cam_j.K).T @ E @ np.linalg.inv(cam_i.K)
    ui = xi @ cam_i.K.T  # undistorted pixel coordinates
    uj = xj @ cam_j.K.T
    lj = ui @ F.T  # lines in image j
    li = uj @ F  # lines in image i
    dj = np.abs(np.sum(lj * uj, axis=1)) / np.hypot(lj[:, 0], lj[:, 1])
    di = np.abs(np.sum(li * ui, axis=1)) / np.hypot(li[:, 0], li[:, 1])
    return (di + dj) / 2


def calibrate(views: ViewSet, board: Board, options: CalibrationOptions = CalibrationOptions()) -> Calibration:
    """Calibrate a rig from board views; with ``drop_worst`` the worst views are dropped and it runs again."""
    first = _calibrate_once(views, board, options)
    if options.drop_worst <= 0:
        return first
    worst = [w["view"] for w in first.report["views"]["ranked"][: options.drop_worst]]
    second = _calibrate_once(views.without(worst), board, options)
    second.report["views"]["dropped"] = worst
    second.report["views"]["before_dropping"] = {"rms_px": first.report["rms_px"], "verdict": first.report["verdict"]}
    return second


def _check_detections(views: ViewSet, board: Board) -> None:
    counts = [len(views.seen_by(c)) for c in range(len(views.camera_names))]
    for c, k in enumerate(counts):
        name = views.camera_names[c]
        if k == 0:
            why = diagnose(board, list(views.samples[c])) if c < len(views.samples) and views.samples[c] else None
            what = f"the board ({board.describe()}) was not found in any of {views.n_views} images of {name}"
            if why:
                raise StereotrackError(f"{what}: {why}")
            hint = "the whole board must be in view" if board.type == "chessboard" else "at least a few markers must be in view"
            raise StereotrackError(f"{what}: check type and squares in board.yaml against the print, focus and light ({hint})")
        if k < MIN_VIEWS:
            raise StereotrackError(
                f"{name}: the board was found in only {k} of {views.n_views} views; need at least {MIN_VIEWS} "
                f"({MIN_VIEWS - k} more), {RECOMMENDED_VIEWS}-25 recommended: take more views at different distances and angles"
            )


def _calibrate_once(views: ViewSet, board: Board, options: CalibrationOptions) -> Calibration:
    names = views.camera_names
    n_cams = len(names)
    if n_cams < 2:
        raise StereotrackError("calibration needs at least 2 cameras")
    _check_detections(views, board)
    flags = options.flags()
    dets = [list(row) for row in views.detections]  # working copy: chessboard labels may be flipped

    intr: dict[int, Intrinsics] = {}
    for c in range(n_cams):
        vs = views.seen_by(c)
        rms, K, dist, _, std = calibrate_intrinsics(board, [dets[v][c] for v in vs], views.image_sizes[c], flags)
        intr[c] = Intrinsics(K, dist, rms, float(max(std[0], std[1])), vs)  # with a fixed aspect ratio only fy is free

    shared = {}
    for i in range(n_cams):
        for j in range(i + 1, n_cams):
            shared[(i, j)] = _shared_views(views, board, i, j)
    edges = _spanning_tree(n_cams, shared, names)

    R_world = {0: np.eye(3)}
    t_world = {0: np.zeros(3)}
    pairs = []
    refine = options.refine and n_cams == 2
    if options.refine and not refine:
        warn("--refine is done for two cameras only; with more, each pair keeps the per-camera intrinsics")
    for p, c in edges:
        vs = shared[(min(p, c), max(p, c))]
        relabelled = _make_labels_consistent(board, dets, vs, p, c, intr)
        rms, Kp, dp, Kc, dc, R, T, per_view = _stereo(board, dets, vs, p, c, intr, views.image_sizes, cv2.CALIB_FIX_INTRINSIC)
        if refine:
            f = cv2.CALIB_USE_INTRINSIC_GUESS | cv2.CALIB_USE_EXTRINSIC_GUESS | flags
            rms, Kp, dp, Kc, dc, R, T, per_view = _stereo(board, dets, vs, p, c, intr, views.image_sizes, f, R, T)
            intr[p] = replace(intr[p], K=Kp, dist=dp)
            intr[c] = replace(intr[c], K=Kc, dist=dc)
        R_world[c] = R @ R_world[p]
        t_world[c] = R @ t_world[p] + T
        pairs.append({"p": p, "c": c, "views": vs, "rms": rms, "per_view": per_view.max(axis=1), "relabelled": relabelled})

    cams = [Camera(names[c], tuple(views.image_sizes[c]), intr[c].K, intr[c].dist, R_world[c], t_world[c]) for c in range(n_cams)]
    world = names[0]
    if options.world_view is not None:
        cams = _world_from_view(views, board, dets, cams, options.world_view)
        world = "custom"
    rig = Rig(tuple(cams), world=world)
    report = _report(views, board, dets, rig, intr, pairs, options)
    quality = {
        "rms_px": report["rms_px"],
        "per_camera_rms_px": {n: report["cameras"][n]["rms_px"] for n in names},
        "epipolar_rms_px": report["epipolar_rms_px"],
        "views_used": views.n_views,
        "board": board_to_dict(board),
        "verdict": report["verdict"],
    }
    return Calibration(Rig(rig.cameras, world=world, quality=quality), report, views)


def _world_from_view(views: ViewSet, board: Board, dets, cams: list[Camera], view_name: str) -> list[Camera]:
    """Re-express the rig in the frame of the board as seen in one view: origin at the board's
    outer corner, x along its rows, z up out of the printed face (towards the cameras)."""
    if view_name not in views.view_names:
        raise StereotrackError(
            f"--world-view {view_name!r}: no such view (views: {', '.join(views.view_names[:8])}{', ...' if views.n_views > 8 else ''})"
        )
    v = views.view_names.index(view_name)
    seen = [c for c in range(len(cams)) if dets[v][c] is not None]
    if len(seen) < 2:
        both = [views.view_names[k] for k in range(views.n_views) if sum(d is not None for d in dets[k]) >= 2]
        raise StereotrackError(
            f"--world-view {view_name!r}: the board is seen by {len(seen)} camera(s) in that view; choose a view seen by two or more"
            + (f", e.g. {', '.join(both[:5])}" if both else "")
        )
    c0 = seen[0]  # the first camera that sees the board in that view
    Rb, tb = _pose(board, dets[v][c0], cams[c0].K, cams[c0].dist)  # board -> camera c0
    flip = np.diag([1.0, -1.0, -1.0])  # board z points into the print; the world's z points out of it
    R_bw = cams[c0].R.T @ Rb @ flip  # world' -> old world rotation
    t_bw = cams[c0].R.T @ (tb - cams[c0].t)  # world' origin in the old world
    out = []
    for cam in cams:
        R = cam.R @ R_bw
        t = cam.R @ t_bw + cam.t
        out.append(replace(cam, R=R, t=t))
    return out


# --------------------------------------------------------------------------- report


def _verdict(report: dict[str, Any]) -> tuple[str, list[str]]:
    redo, usable = [], []
    for name, cam in report["cameras"].items():
        if cam["rms_px"] > 1.0:
            redo.append(
                f"{name}: reprojection error {cam['rms_px']:.2f} px is high (blurred or moving board, board not flat, or wrong board settings)"
            )
        elif cam["rms_px"] > 0.5:
            usable.append(f"{name}: reprojection error {cam['rms_px']:.2f} px (under 0.5 px is good)")
        if cam["coverage"] < 0.35:
            redo.append(
                f"{name}: board corners cover only {100 * cam['coverage']:.0f}% of the image: move the board into the corners and edges"
            )
        elif cam["coverage"] < 0.6:
            usable.append(
                f"{name}: board corners cover {100 * cam['coverage']:.0f}% of the image (60% or more is good): add views near the edges"
            )
    for pair in report["pairs"]:
        label = "-".join(pair["cameras"])
        if pair["epipolar_mean_px"] > 1.0:
            redo.append(
                f"{label}: epipolar error {pair['epipolar_mean_px']:.2f} px is high (unsynchronised pairs, or the rig moved while capturing)"
            )
        elif pair["epipolar_mean_px"] > 0.5:
            usable.append(f"{label}: epipolar error {pair['epipolar_mean_px']:.2f} px (under 0.5 px is good)")
        if pair["views"] < 10:
            usable.append(f"{label}: only {pair['views']} views seen by both cameras ({RECOMMENDED_VIEWS}-25 give steadier results)")
    outliers = [w for w in report["views"]["ranked"] if w["outlier"]]
    if outliers:
        usable.append(
            f"{len(outliers)} view(s) fit much worse than the rest ({', '.join(w['view'] for w in outliers[:3])}): "
            f"try --drop-worst {len(outliers)}"
        )
    verdict = "redo" if redo else "usable" if usable else "good"
    return verdict, redo + usable


def _report(
    views: ViewSet, board: Board, dets, rig: Rig, intr: dict[int, Intrinsics], pairs: list[dict], options: CalibrationOptions
) -> dict[str, Any]:
    per_view: dict[int, dict[str, float]] = {v: {} for v in range(views.n_views)}
    cameras: dict[str, Any] = {}
    all_sq = []
    for c, cam in enumerate(rig.cameras):
        sq = []
        for v in intr[c].views:
            e = _reprojection(board, dets[v][c], cam.K, cam.dist)
            per_view[v][cam.name] = round(float(np.sqrt(np.mean(e**2))), 4)
            sq.append(e**2)
        sq = np.concatenate(sq)
        all_sq.append(sq)
        cov = coverage([dets[v][c].corners for v in intr[c].views], cam.image_size)
        cameras[cam.name] = {
            "rms_px": round(float(np.sqrt(sq.mean())), 4),
            "views": len(intr[c].views),
            "coverage": round(cov, 3),
            "fx": round(float(cam.K[0, 0]), 3),
            "fy": round(float(cam.K[1, 1]), 3),
            "fx_std": round(intr[c].std_f, 3),
            "cx": round(float(cam.K[0, 2]), 3),
            "cy": round(float(cam.K[1, 2]), 3),
            "dist": [round(float(x), 6) for x in cam.dist],
            "image_size": list(cam.image_size),
        }
    pair_reports = []
    epi_all = []
    for pr in pairs:
        ci, cj = rig.cameras[pr["p"]], rig.cameras[pr["c"]]
        epi = []
        for v, err in zip(pr["views"], pr["per_view"]):
            a, b = _common(dets[v][pr["p"]], dets[v][pr["c"]])
            epi.append(epipolar_errors(ci, cj, a.corners, b.corners))
            per_view[v][f"stereo {ci.name}-{cj.name}"] = round(float(err), 4)
        epi = np.concatenate(epi)
        epi_all.append(epi)
        R = cj.R @ ci.R.T
        baseline = float(np.linalg.norm(ci.centre - cj.centre))
        pair_reports.append(
            {
                "cameras": [ci.name, cj.name],
                "views": len(pr["views"]),
                "rms_px": round(pr["rms"], 4),
                "epipolar_mean_px": round(float(epi.mean()), 4),
                "epipolar_rms_px": round(float(np.sqrt(np.mean(epi**2))), 4),
                "baseline_m": round(baseline, 5),
                "baseline_squares": round(baseline / board.square, 4),
                "rotation_deg": round(_angle_deg(R), 3),
                "relabelled_views": pr["relabelled"],
            }
        )
    scores = {v: max(errs.values()) for v, errs in per_view.items() if errs}
    median = float(np.median(list(scores.values())))
    ranked = sorted(scores, key=lambda v: -scores[v])
    epi_all = np.concatenate(epi_all)
    report: dict[str, Any] = {
        "board": board_to_dict(board),
        "cameras": cameras,
        "pairs": pair_reports,
        "rms_px": round(float(np.sqrt(np.concatenate(all_sq).mean())), 4),
        "epipolar_mean_px": round(float(epi_all.mean()), 4),
        "epipolar_rms_px": round(float(np.sqrt(np.mean(epi_all**2))), 4),
        "world": rig.world if options.world_view is None else f"custom (board in view {options.world_view}, z up)",
        "views": {
            "used": views.n_views,
            "ranked": [
                {
                    "view": views.view_names[v],
                    "error_px": round(scores[v], 4),
                    "outlier": bool(scores[v] > max(2.5 * median, median + 0.25)),
                }
                for v in ranked
            ],
            "per_view_rms_px": {views.view_names[v]: per_view[v] for v in range(views.n_views)},
        },
    }
    verdict, reasons = _verdict(report)
    report["verdict"] = verdict
    report["reasons"] = reasons
    return report


def format_report(report: dict[str, Any]) -> str:
    """The report as a few readable lines for the console."""
    lines = []
    for name, cam in report["cameras"].items():
        lines.append(
            f"{name}: RMS {cam['rms_px']:.3f} px over {cam['views']} views, fx {cam['fx']:.1f} (+-{cam['fx_std']:.1f}) fy {cam['fy']:.1f}, "
            f"centre ({cam['cx']:.1f}, {cam['cy']:.1f}), coverage {100 * cam['coverage']:.0f}%"
        )
    for p in report["pairs"]:
        lines.append(
            f"{p['cameras'][0]}-{p['cameras'][1]}: stereo RMS {p['rms_px']:.3f} px over "
            f"{p['views']} views, epipolar error mean {p['epipolar_mean_px']:.3f} px, "
            f"baseline {1000 * p['baseline_m']:.1f} mm ({p['baseline_squares']:.2f} squares), rotation {p['rotation_deg']:.2f} deg"
        )
    worst = report["views"]["ranked"][:3]
    lines.append("worst views: " + ", ".join(f"{w['view']} {w['error_px']:.3f} px{' (outlier)' if w['outlier'] else ''}" for w in worst))
    if report["views"].get("dropped"):
        lines.append("dropped views: " + ", ".join(report["views"]["dropped"]))
    lines.append(f"world frame: {report['world']}")
    verdict = report["verdict"]
    lines.append(f"verdict: {verdict}" + (": " + "; ".join(report["reasons"]) if report["reasons"] else ""))
    if verdict == "redo":
        lines.append("what to do: see 'Calibrating two webcams' in the README (steady board, flat print, all of the image covered)")
    return "\n".join(lines)


def save_report(report: dict[str, Any], path: str | Path) -> None:
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    Path(path).write_text(yaml.safe_dump(report, sort_keys=False, default_flow_style=None, width=120))


def report_path(calib_path: str | Path) -> Path:
    """calib/rig.yaml -> calib/rig.report.yaml"""
    p = Path(calib_path)
    return p.with_name(p.stem + ".report.yaml")
