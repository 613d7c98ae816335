"""Solving the rig from board views: starts per camera and per pair, then one joint fit of everything.

The start: intrinsics per camera (``cv2.calibrateCamera``), the pose of every
other camera relative to the first through the pairs that share most views
(``cv2.stereoCalibrate`` with the intrinsics fixed), chessboard labels made to
agree between cameras, and every board pose through the first camera that saw
it. Then ``bundle.py`` refines all of it together. The views come from
``views.py``; the report on the result from ``report.py``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import cv2
import numpy as np

from ..camera import Camera, Rig
from ..errors import StereotrackError
from . import bundle
from .boards import MIN_CORNERS, Board, Detection, board_to_dict, diagnose, flipped
from .measures import CalibrationOptions, Intrinsics, ViewFit, _angle_deg, _common, _points, _pose
from .report import _report
from .views import MIN_VIEWS, RECOMMENDED_VIEWS, ViewSet

# --------------------------------------------------------------------------- calibration


@dataclass(frozen=True, eq=False)
class Calibration:
    rig: Rig
    report: dict[str, Any]
    views: ViewSet  # the views used (after any dropped)
    fit: ViewFit  # per view: detections, reprojected corners, board pose


def calibrate_intrinsics(
    board: Board, detections: Sequence[Detection], image_size: tuple[int, int], flags: int = 0
) -> tuple[float, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``cv2.calibrateCamera`` on board detections: (rms, K, dist, per-view RMS, std of [fx, fy, cx, cy, ...])."""
    obj, img = zip(*(_points(board, d) for d in detections))
    K0 = np.eye(3)  # with CALIB_FIX_ASPECT_RATIO this sets fx / fy = 1
    rms, K, dist, _, _, std_in, _, per_view = cv2.calibrateCameraExtended(list(obj), list(img), tuple(image_size), K0, None, flags=flags)
    return float(rms), K, dist.ravel(), per_view.ravel(), std_in.ravel()


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
    start = starting_point(views, board, options)
    dets, intr, relabelled = start.detections, start.intrinsics, start.relabelled

    # Then all of it at once, unless asked for the starts only (to compare).
    fit = bundle.refine(start.corners, n_cams, views.n_views, start.model, *start.x) if options.joint else start.as_result()
    cams = []
    for c in range(n_cams):
        fx, fy, cx, cy = fit.intrinsics[c, :4]
        K = np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])
        R = cv2.Rodrigues(fit.cam_poses[c, :3])[0]
        cams.append(
            Camera(
                names[c], tuple(views.image_sizes[c]), K, fit.intrinsics[c, 4 : 4 + options.lens_model().n_dist], R, fit.cam_poses[c, 3:]
            )
        )
    boards_R = np.array([cv2.Rodrigues(b[:3])[0] for b in fit.board_poses])
    boards_t = fit.board_poses[:, 3:].copy()
    world = names[0]
    if options.world_view is not None:
        cams, boards_R, boards_t = _world_from_view(views, board, dets, cams, boards_R, boards_t, options.world_view)
        world = "custom"
    rig = Rig(tuple(cams), world=world)
    view_fit = _view_fit(board, dets, fit, boards_R, boards_t)
    report = _report(views, board, view_fit, rig, fit, intr, relabelled, options)
    quality = {
        "rms_px": report["rms_px"],
        "per_camera_rms_px": {n: report["cameras"][n]["rms_px"] for n in names},
        "epipolar_rms_px": report["epipolar_rms_px"],
        "views_used": views.n_views,
        "board": board_to_dict(board),
        "verdict": report["verdict"],
        "method": "joint" if options.joint else "pairwise",
        "baselines": [
            {"cameras": p["cameras"], "m": p["baseline_m"], "sd_m": p["baseline_sd_m"]} for p in report["pairs"] if "baseline_sd_m" in p
        ],
    }
    return Calibration(Rig(rig.cameras, world=world, quality=quality), report, views, view_fit)


def _labels_agree_with_poses(board: Board, dets, intr: dict[int, Intrinsics], R_world: dict[int, np.ndarray]) -> int:
    """Chessboards numbered from the opposite end in one camera of a view, also between cameras that
    are not linked directly: the labelling whose board rotation agrees with the view's first camera wins."""
    if board.type != "chessboard":
        return 0
    changed = 0
    for row in dets:
        seen = [c for c, d in enumerate(row) if d is not None]
        if len(seen) < 2:
            continue
        ref = seen[0]
        R_ref = R_world[ref].T @ _pose(board, row[ref], intr[ref].K, intr[ref].dist)[0]  # board -> world
        for c in seen[1:]:
            want = R_world[c] @ R_ref
            as_is = _angle_deg(_pose(board, row[c], intr[c].K, intr[c].dist)[0] @ want.T)
            turned = _angle_deg(_pose(board, flipped(board, row[c]), intr[c].K, intr[c].dist)[0] @ want.T)
            if turned < as_is:
                row[c] = flipped(board, row[c])
                changed += 1
    return changed


@dataclass(frozen=True, eq=False)
class Start:
    """The joint fit's starting point: per-camera intrinsics, chained poses, board poses from one camera each."""

    corners: bundle.Corners
    x: tuple[np.ndarray, np.ndarray, np.ndarray]  # intrinsics (cameras x 12), camera poses, board poses
    model: bundle.LensModel
    detections: list[list[Detection | None]]  # chessboards relabelled to agree between cameras
    intrinsics: dict[int, Intrinsics]  # each camera calibrated alone
    relabelled: int

    def as_result(self) -> bundle.BundleResult:
        """The starts as they are (no joint fit), with their residuals, to compare."""
        problem = bundle.Problem(self.corners, len(self.x[0]), len(self.x[2]), self.model, self.x[0])
        residuals = problem.residuals(problem.pack(*self.x)).reshape(-1, 2)
        return bundle.BundleResult(*self.x, residuals, None, problem)


def starting_point(views: ViewSet, board: Board, options: CalibrationOptions) -> Start:
    """Each camera alone (``calibrateCamera``), then each camera's pose through the pairs that share most
    views (``stereoCalibrate``, intrinsics fixed), then every board pose through the first camera that saw it."""
    names = views.camera_names
    n_cams = len(names)
    if n_cams < 2:
        raise StereotrackError("calibration needs at least 2 cameras")
    _check_detections(views, board)
    # The rational model starts from the standard one (k4..k6 = 0): fitted from scratch, its numerator and
    # denominator grow together along a nearly flat valley (k's in the thousands; at the limit the focal
    # length trades with k1 / k4), and the joint fit then wandered for minutes to focal lengths 58 % off.
    flags = options.flags() & ~cv2.CALIB_RATIONAL_MODEL
    dets = [list(row) for row in views.detections]  # working copy: chessboard labels may be flipped
    intr: dict[int, Intrinsics] = {}
    for c in range(n_cams):
        vs = views.seen_by(c)
        rms, K, dist, _, std = calibrate_intrinsics(board, [dets[v][c] for v in vs], views.image_sizes[c], flags)
        intr[c] = Intrinsics(K, dist, rms, float(max(std[0], std[1])), vs)  # with a fixed aspect ratio only fy is free
    shared = {(i, j): _shared_views(views, board, i, j) for i in range(n_cams) for j in range(i + 1, n_cams)}
    R_world = {0: np.eye(3)}
    t_world = {0: np.zeros(3)}
    relabelled = 0
    for p, c in _spanning_tree(n_cams, shared, names):
        vs = shared[(min(p, c), max(p, c))]
        relabelled += _make_labels_consistent(board, dets, vs, p, c, intr)
        _, _, _, _, _, R, T, _ = _stereo(board, dets, vs, p, c, intr, views.image_sizes, cv2.CALIB_FIX_INTRINSIC | flags)
        R_world[c] = R @ R_world[p]
        t_world[c] = R @ t_world[p] + T
    relabelled += _labels_agree_with_poses(board, dets, intr, R_world)
    corners, x = _starting_unknowns(board, dets, intr, R_world, t_world)
    return Start(corners, x, options.lens_model(), dets, intr, relabelled)


def _starting_unknowns(board: Board, dets, intr: dict[int, Intrinsics], R_world, t_world):
    n_cams = len(intr)
    intrinsics = np.zeros((n_cams, bundle.N_INTR))
    for c in range(n_cams):
        K, d = intr[c].K, intr[c].dist
        intrinsics[c, :4] = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
        intrinsics[c, 4 : 4 + min(8, len(d))] = d[:8]  # k1 k2 p1 p2 k3 (k4 k5 k6)
    cam_poses = np.array([np.concatenate([cv2.Rodrigues(R_world[c])[0].ravel(), t_world[c]]) for c in range(n_cams)])
    board_poses, view, cam, obj, px = [], [], [], [], []
    points = board.object_points()
    for v, row in enumerate(dets):
        ref = next(c for c, d in enumerate(row) if d is not None)  # board -> world through the first camera that saw it
        Rb, tb = _pose(board, row[ref], intr[ref].K, intr[ref].dist)
        R = R_world[ref].T @ Rb
        board_poses.append(np.concatenate([cv2.Rodrigues(R)[0].ravel(), R_world[ref].T @ (tb - t_world[ref])]))
        for c, d in enumerate(row):
            if d is not None:
                view.append(np.full(len(d), v))
                cam.append(np.full(len(d), c))
                obj.append(points[d.ids])
                px.append(d.corners)
    corners = bundle.Corners(np.concatenate(view), np.concatenate(cam), np.concatenate(obj), np.concatenate(px))
    return corners, (intrinsics, cam_poses, np.array(board_poses))


def _view_fit(board: Board, dets, fit: bundle.BundleResult, boards_R: np.ndarray, boards_t: np.ndarray) -> ViewFit:
    corners = fit.problem.corners
    reprojected = [[None] * len(row) for row in dets]
    for v, c, rows in fit.problem.blocks:
        reprojected[v][c] = corners.px[rows] + fit.residuals[rows]
    return ViewFit(tuple(map(tuple, dets)), tuple(map(tuple, reprojected)), boards_R, boards_t)


def _world_from_view(
    views: ViewSet, board: Board, dets, cams: list[Camera], boards_R: np.ndarray, boards_t: np.ndarray, view_name: str
) -> tuple[list[Camera], np.ndarray, np.ndarray]:
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
    flip = np.diag([1.0, -1.0, -1.0])  # board z points into the print; the world's z points out of it
    R_bw = boards_R[v] @ flip  # world' -> old world rotation: the fitted board pose of that view
    t_bw = boards_t[v]  # world' origin in the old world
    out = [replace(cam, R=cam.R @ R_bw, t=cam.R @ t_bw + cam.t) for cam in cams]
    return out, np.einsum("ji,vjk->vik", R_bw, boards_R), (boards_t - t_bw) @ R_bw
