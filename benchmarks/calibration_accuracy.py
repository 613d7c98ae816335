"""Calibration accuracy against a known rig, and on OpenCV's real stereo pairs: the README's calibration figures.

    .venv/bin/python benchmarks/calibration_accuracy.py [--seeds 200-209] [--write | --rigs | --lenses]

Rendered views: for 2 and for 3 cameras (``calibration_rig``: webcams 640x480
with their own focal lengths, off-centre principal points and barrel
distortion), 24 board poses each seen whole by at least two cameras (9x7
chessboard of 30 mm squares, tilted 15-45 degrees), detected as the command
detects them, then every corner moved by Gaussian noise of 0.3 px RMS (0.21 px
per axis, a webcam's calibration RMS). Each seed is a new rig and new views;
the targets were looked at on seeds 100-104 only, the figures come from the
seeds given here. Each scene is solved three ways, timed in turn:

- pairwise: per-camera ``calibrateCamera``, then each camera's pose by
  ``stereoCalibrate`` along the pairs sharing most views (the old default);
- ``cv2.calibrateMultiview`` (OpenCV 5): its own start, then all poses jointly;
- joint (the default): the pairwise start, then ``bundle.refine`` (every
  intrinsic, camera pose and board pose; Huber loss; exact Jacobian).

Errors are the worst over cameras (focal, principal point) and over camera
pairs (baseline length, relative rotation). Under the table, the information
limit of each scene (Cramer-Rao bound): the chance that any unbiased fit of the
same detected corners meets every target, at the corners' measured error
against the true ones (the detector's own error is about 0.07 px RMS, the
added noise 0.3 px); summed over the scenes, how many rigs even a perfect
solver would be expected to bring within every target. Every lens model on two-camera
renders (``lens_rig``): an ordinary lens that every model can describe, and a
90-degree lens with rational distortion. Real pairs: every lens model on
OpenCV's 13 stereo pairs, baseline in square lengths (Caltech's own: 3.327).
``--write`` puts the tables into README.md between the markers.
"""

from __future__ import annotations

import argparse
import re
import sys
import time
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from stereotrack.calibration import CalibrationOptions, ViewSet, calibrate, views_from_frames, views_from_images  # noqa: E402
from stereotrack.calibration.boards import Board, BoardDetector, Detection  # noqa: E402
from stereotrack.camera import Camera, Rig  # noqa: E402
from stereotrack.frames import FramePair  # noqa: E402
from stereotrack.simulation.boards import BoardPose, calibration_rig, lens_rig, poses_seen_by_pairs, render_views  # noqa: E402

BOARD = Board("chessboard", (9, 7), 0.03)
N_VIEWS = 24
NOISE_RMS_PX = 0.3
TARGETS = {"focal_pct": 0.3, "centre_px": 3.0, "baseline_pct": 0.2, "rotation_deg": 0.25}
REAL = ROOT / "tests" / "data" / "opencv-stereo-chessboard"
MARKERS = ("<!-- begin: benchmarks/calibration_accuracy.py -->", "<!-- end: benchmarks/calibration_accuracy.py -->")


def rendered_images(n_cams: int, seed: int) -> tuple[Rig, list[BoardPose], list[tuple[np.ndarray, ...]], np.random.Generator]:
    """A known rig, the true board poses, their renders, and the generator as it is after rendering."""
    rng = np.random.default_rng(seed)
    rig = calibration_rig(n_cams, rng)
    poses = poses_seen_by_pairs(rig, BOARD, N_VIEWS, rng, min_tilt_deg=15.0, max_tilt_deg=45.0)
    return rig, poses, render_views(rig, BOARD, poses, rng), rng


def rendered_scene(n_cams: int, seed: int) -> tuple[Rig, ViewSet, list[BoardPose]]:
    """A known rig, its detected board views (corners moved by the webcam-like noise) and the true board poses."""
    rig, poses, images, rng = rendered_images(n_cams, seed)
    views = views_from_frames(
        BOARD, [FramePair(i, v, (0.0,) * n_cams) for i, v in enumerate(images)], rig.names, min_new=0.0, progress=False
    )
    return rig, with_corner_noise(views, NOISE_RMS_PX / np.sqrt(2), rng), poses


def with_corner_noise(views: ViewSet, sigma: float, rng: np.random.Generator) -> ViewSet:
    rows = tuple(
        tuple(None if d is None else Detection(d.ids, d.corners + rng.normal(0.0, sigma, d.corners.shape)) for d in row)
        for row in views.detections
    )
    return ViewSet(views.camera_names, views.image_sizes, views.view_names, rows)


def rig_errors(truth: Rig, est: Rig) -> dict[str, float]:
    """Worst focal (%), principal point (px), baseline (%) and relative rotation (degrees)."""
    focal = max(abs(e.K[k, k] / t.K[k, k] - 1) for t, e in zip(truth.cameras, est.cameras) for k in (0, 1))
    centre = max(float(np.abs(e.K[:2, 2] - t.K[:2, 2]).max()) for t, e in zip(truth.cameras, est.cameras))
    base = rot = 0.0
    for i in range(len(truth)):
        for j in range(i + 1, len(truth)):
            base = max(base, abs(est.baseline(i, j) / truth.baseline(i, j) - 1))
            dR = (est[j].R @ est[i].R.T) @ (truth[j].R @ truth[i].R.T).T
            rot = max(rot, float(np.degrees(np.linalg.norm(cv2.Rodrigues(dR)[0]))))
    return {"focal_pct": 100 * focal, "centre_px": centre, "baseline_pct": 100 * base, "rotation_deg": rot}


def true_corners(cam: Camera, pose: BoardPose, det: Detection) -> tuple[np.ndarray, np.ndarray]:
    """Where the detected corners truly are: their board ids and exact pixels. Chessboard labels may run
    from either end of the board, so the numbering nearer the detected corners is taken."""
    obj = BOARD.object_points()
    ids = min((det.ids, BOARD.n_corners - 1 - det.ids), key=lambda i: np.abs(cam.project(pose.to_world(obj[i]))[0] - det.corners).mean())
    return ids, cam.project(pose.to_world(obj[ids]))[0]


def information_limit(truth: Rig, poses: list[BoardPose], views: ViewSet, seed: int) -> tuple[float, float]:
    """The Cramer-Rao bound: how often any unbiased fit of these very corners would meet every target.

    The joint fit's Jacobian at the true cameras and board poses, for the corners the detector found, and
    the corners' measured error (detector and added noise together, px RMS) give the smallest covariance an
    unbiased estimate can have; draws from it give the chance that the rig meets all four targets at once.
    Returns (that chance, the measured corner error)."""
    from stereotrack.calibration import bundle

    obj, n_cams = BOARD.object_points(), len(truth)
    poses = [poses[int(name.removeprefix("frame"))] for name in views.view_names]  # views_from_frames skips a pose seen by < 2 cameras
    rows, errors = [], []
    for v, row in enumerate(views.detections):
        for c, d in enumerate(row):
            if d is None:
                continue
            ids, px = true_corners(truth[c], poses[v], d)
            rows.append((v, c, ids, px))
            errors.append(d.corners - px)
    sigma = float(np.sqrt(np.mean(np.concatenate(errors) ** 2)))  # per axis
    corners = bundle.Corners(*(np.concatenate(a) for a in ([np.full(len(i), v) for v, _, i, _ in rows],
                             [np.full(len(i), c) for _, c, i, _ in rows], [obj[i] for _, _, i, _ in rows], [p for *_, p in rows])))  # fmt: skip
    # the truth in the fit's terms: camera 0's frame is the world
    intrinsics = np.zeros((n_cams, bundle.N_INTR))
    for c, cam in enumerate(truth.cameras):
        intrinsics[c, :4] = cam.K[0, 0], cam.K[1, 1], cam.K[0, 2], cam.K[1, 2]
        intrinsics[c, 4 : 4 + len(cam.dist)] = cam.dist
    R0, t0 = truth[0].R, truth[0].t
    relative = [(cam.R @ R0.T, cam.t - cam.R @ R0.T @ t0) for cam in truth.cameras]
    cam_poses = np.array([np.r_[cv2.Rodrigues(R)[0].ravel(), t] for R, t in relative])
    board_poses = np.array([np.r_[cv2.Rodrigues(R0 @ p.R)[0].ravel(), R0 @ p.t + t0] for p in poses])
    problem = bundle.Problem(corners, n_cams, views.n_views, bundle.LensModel(), intrinsics)
    x = problem.pack(intrinsics, cam_poses, board_poses)
    pairs = [(i, j) for i in range(n_cams) for j in range(i + 1, n_cams)]

    def target_errors(x: np.ndarray) -> np.ndarray:  # in the targets' units, zero at the truth
        intr, cams, _ = problem.unpack(x)
        Rs = [cv2.Rodrigues(p[:3])[0] for p in cams]
        centres = [-R.T @ p[3:] for R, p in zip(Rs, cams)]
        out = [100 * (intr[:, :2] / intrinsics[:, :2] - 1), intr[:, 2:4] - intrinsics[:, 2:4]]
        for i, j in pairs:
            out.append([100 * (np.linalg.norm(centres[i] - centres[j]) / truth.baseline(i, j) - 1)])
            dR = (Rs[j] @ Rs[i].T) @ (relative[j][0] @ relative[i][0].T).T
            # the rotation vector of dR to first order (cv2.Rodrigues returns zero below 1e-5 rad)
            out.append(np.degrees([dR[2, 1] - dR[1, 2], dR[0, 2] - dR[2, 0], dR[1, 0] - dR[0, 1]]) / 2)
        return np.concatenate([np.ravel(o) for o in out])

    J = problem.jacobian(x)
    covariance = np.linalg.inv(J.T @ J) * sigma**2
    G = np.zeros((len(target_errors(x)), len(x)))
    for k in range(len(x)):
        h = 1e-6 * max(1.0, abs(x[k]))
        dx = np.zeros_like(x)
        dx[k] = h
        G[:, k] = (target_errors(x + dx) - target_errors(x - dx)) / (2 * h)
    draws = np.random.default_rng(seed).multivariate_normal(np.zeros(len(G)), G @ covariance @ G.T, 20000)
    n = 2 * n_cams
    per_pair = draws[:, 2 * n :].reshape(len(draws), len(pairs), 4)
    worst = {
        "focal_pct": np.abs(draws[:, :n]).max(1),
        "centre_px": np.abs(draws[:, n : 2 * n]).max(1),
        "baseline_pct": np.abs(per_pair[:, :, 0]).max(1),
        "rotation_deg": np.linalg.norm(per_pair[:, :, 1:], axis=2).max(1),
    }
    return float(np.mean(np.all([worst[k] <= TARGETS[k] for k in TARGETS], axis=0))), sigma * np.sqrt(2)


def opencv_multiview(views: ViewSet, detections) -> Rig:
    """``cv2.calibrateMultiview`` on the same corners (chessboard labels already made to agree between cameras)."""
    obj = BOARD.object_points().astype(np.float32)
    n_cams = len(views.camera_names)
    mask = np.zeros((n_cams, views.n_views), np.uint8)
    points = [[] for _ in range(n_cams)]
    for v, row in enumerate(detections):
        for c in range(n_cams):
            pts = np.full((len(obj), 2), -1.0, np.float32)  # -1: not seen (OpenCV's convention)
            if row[c] is not None:
                pts[row[c].ids] = row[c].corners
                mask[c, v] = 1
            points[c].append(pts)
    Ks = [np.eye(3) for _ in range(n_cams)]
    dists = [np.zeros((1, 5)) for _ in range(n_cams)]
    Rs = [np.zeros((3, 1)) for _ in range(n_cams)]
    Ts = [np.zeros((3, 1)) for _ in range(n_cams)]
    _, Ks, dists, Rs, Ts = cv2.calibrateMultiview(
        [obj] * views.n_views, points, [tuple(s) for s in views.image_sizes], mask, np.zeros((n_cams, 1), np.uint8), Ks, dists, Rs, Ts
    )
    cams = []
    for c in range(n_cams):
        R = np.asarray(Rs[c])
        R = cv2.Rodrigues(R)[0] if R.size == 3 else R
        cams.append(
            Camera(
                views.camera_names[c], views.image_sizes[c], np.asarray(Ks[c]), np.asarray(dists[c]).ravel(), R, np.asarray(Ts[c]).ravel()
            )
        )
    return Rig(tuple(cams))


def solve_all(truth: Rig, views: ViewSet) -> dict[str, tuple[dict[str, float], float]]:
    out = {}
    t = time.perf_counter()
    pairwise = calibrate(views, BOARD, CalibrationOptions(joint=False))
    out["pairwise"] = (rig_errors(truth, pairwise.rig), time.perf_counter() - t)
    t = time.perf_counter()
    multiview = opencv_multiview(views, pairwise.fit.detections)
    out["calibrateMultiview"] = (rig_errors(truth, multiview), time.perf_counter() - t)
    t = time.perf_counter()
    joint = calibrate(views, BOARD)
    out["joint"] = (rig_errors(truth, joint.rig), time.perf_counter() - t)
    return out, own_uncertainty(joint.report)


def own_uncertainty(report: dict) -> dict[str, float]:
    """The joint fit's own standard deviations (its covariance), worst over cameras / pairs."""
    cams = report["cameras"].values()
    return {
        "focal_pct": max(100 * c["fx_std"] / c["fx"] for c in cams),
        "centre_px": max(c["centre_std"] for c in cams),
        "baseline_pct": max(p["baseline_sd_pct"] for p in report["pairs"]),
    }


def rendered_table(seeds: list[int]) -> str:
    lines = [
        f"| cameras | method | worst focal, % (target {TARGETS['focal_pct']}) | worst centre, px ({TARGETS['centre_px']:g}) "
        f"| worst baseline, % ({TARGETS['baseline_pct']}) | worst rotation, deg ({TARGETS['rotation_deg']}) | scenes meeting all | time, s |",
        "|---:|---|---:|---:|---:|---:|---:|---:|",
    ]
    sds, limits = [], []
    for n_cams in (2, 3):
        results: dict[str, list] = {}
        own, chances, noise = [], [], []
        for seed in seeds:
            truth, views, poses = rendered_scene(n_cams, seed)
            solved, uncertainty = solve_all(truth, views)
            own.append(uncertainty)
            chance, corner_rms = information_limit(truth, poses, views, seed)
            chances.append(chance)
            noise.append(corner_rms)
            for method, (errors, seconds) in solved.items():
                results.setdefault(method, []).append((errors, seconds))
            print(f"  {n_cams} cameras, seed {seed}: " + "; ".join(
                f"{m} " + " ".join(f"{v:.3f}" for v in r[-1][0].values()) for m, r in results.items())
                + f"; corners {corner_rms:.3f} px RMS, chance an unbiased fit meets all {chance:.2f}", file=sys.stderr, flush=True)  # fmt: skip
        for method, rows in results.items():
            errs = {k: np.array([r[0][k] for r in rows]) for k in TARGETS}
            meets = sum(all(r[0][k] <= TARGETS[k] for k in TARGETS) for r in rows)
            cells = [f"{np.median(errs[k]):.3f} / {errs[k].max():.3f}" if k != "centre_px" else f"{np.median(errs[k]):.2f} / {errs[k].max():.2f}"
                     for k in TARGETS]  # fmt: skip
            secs = np.array([r[1] for r in rows])
            lines.append(f"| {n_cams} | {method} | " + " | ".join(cells) + f" | {meets} of {len(rows)} | {np.median(secs):.2f} |")
        sds.append(
            f"{n_cams} cameras: focal {np.median([u['focal_pct'] for u in own]):.3f} %, centre {np.median([u['centre_px'] for u in own]):.2f} px, "
            f"baseline {np.median([u['baseline_pct'] for u in own]):.3f} %"
        )
        limits.append(
            f"{n_cams} cameras: {sum(chances):.1f} of {len(chances)} expected (all {len(chances)}: chance {np.prod(chances):.2f}; "
            f"the least likely rig, seed {seeds[int(np.argmin(chances))]}: {min(chances):.2f}; corner error {np.median(noise):.3f} px RMS)"
        )
    lines.append("")
    lines.append(
        "The joint fit's own standard deviations (from its covariance, worst camera or pair, median over the scenes): "
        + "; ".join(sds)
        + "."
    )
    lines.append("")
    lines.append(
        "The information limit (Cramer-Rao bound: the spread any unbiased fit of the same detected corners has, at their measured "
        "error against the true corners; rigs meeting all targets): " + "; ".join(limits) + "."
    )
    return "\n".join(lines)


def _sb_detector(flags: int, subpix: bool = False):
    refine = BoardDetector(BOARD)

    def detect(image: np.ndarray) -> Detection | None:
        found, corners = cv2.findChessboardCornersSB(image, BOARD.inner, flags=flags)
        if not found:
            return None
        corners = corners.reshape(-1, 1, 2).astype(np.float32)
        if subpix:
            refine._refine(image, corners)
        return Detection(np.arange(BOARD.n_corners), corners.reshape(-1, 2).astype(np.float64))

    return detect


def detector_table(seeds: list[int]) -> str:
    """Ways to find the chessboard's corners, against the true corners of two-camera renders, and what a perfect
    detector would change: the joint fit from the detected corners and from the true ones, the same noise added."""
    normal = cv2.CALIB_CB_NORMALIZE_IMAGE
    detectors = {
        "findChessboardCorners + cornerSubPix, window 1/4 of the corner spacing (the default)": BoardDetector(BOARD).detect,
        "the same, window 3 px": BoardDetector(BOARD, 3).detect,
        "the same, window 5 px": BoardDetector(BOARD, 5).detect,
        "the same, window 7 px": BoardDetector(BOARD, 7).detect,
        "findChessboardCornersSB": _sb_detector(normal),
        "findChessboardCornersSB, CALIB_CB_ACCURACY": _sb_detector(normal | cv2.CALIB_CB_ACCURACY),
        "findChessboardCornersSB + cornerSubPix as the default": _sb_detector(normal, subpix=True),
    }
    found = dict.fromkeys(detectors, 0)
    errors: dict[str, list] = {k: [] for k in detectors}
    seconds = dict.fromkeys(detectors, 0.0)
    n_images = 0
    fits: dict[str, list] = {"detected corners": [], "true corners": []}
    for seed in seeds:
        rig, poses, images, rng = rendered_images(2, seed)
        n_images += 2 * len(images)
        for name, detect in detectors.items():
            for pose, row in zip(poses, images):
                for cam, image in zip(rig.cameras, row):
                    t = time.perf_counter()
                    d = detect(image)
                    seconds[name] += time.perf_counter() - t
                    if d is not None:
                        found[name] += 1
                        errors[name].append(d.corners - true_corners(cam, pose, d)[1])
        frames = [FramePair(i, v, (0.0, 0.0)) for i, v in enumerate(images)]
        views = views_from_frames(BOARD, frames, rig.names, min_new=0.0, progress=False)
        exact = [[None if d is None else Detection(d.ids, true_corners(cam, poses[int(n[5:])], d)[1]) for d, cam in zip(row, rig.cameras)]
                 for n, row in zip(views.view_names, views.detections)]  # fmt: skip
        state = rng.bit_generator.state  # the same noise on both
        for label, rows in (("detected corners", views.detections), ("true corners", exact)):
            rng.bit_generator.state = state
            noisy = with_corner_noise(ViewSet(views.camera_names, views.image_sizes, views.view_names, tuple(map(tuple, rows))),
                                      NOISE_RMS_PX / np.sqrt(2), rng)  # fmt: skip
            fits[label].append(rig_errors(rig, calibrate(noisy, BOARD).rig))
        print(
            f"  detectors, seed {seed}: " + "; ".join(f"{k} {v[-1]['rotation_deg']:.3f} deg" for k, v in fits.items()),
            file=sys.stderr,
            flush=True,
        )
    lines = [f"| 2 cameras, seeds {seeds[0]}-{seeds[-1]}, {n_images} images | boards found | corner error, px RMS | 99th percentile | worst | ms per image |",
             "|---|---:|---:|---:|---:|---:|"]  # fmt: skip
    for name in detectors:
        r = np.linalg.norm(np.concatenate(errors[name]), axis=1)
        lines.append(f"| {name} | {found[name]} | {np.sqrt(np.mean(r**2)):.3f} | {np.percentile(r, 99):.3f} | {r.max():.2f} "
                     f"| {1000 * seconds[name] / n_images:.0f} |")  # fmt: skip
    lines += ["", "| joint fit, corners noise 0.3 px RMS added | " + " | ".join(f"worst {k}, median / worst" for k in TARGETS) + " | scenes meeting all |",
              "|---|" + "---:|" * (len(TARGETS) + 1)]  # fmt: skip
    for label, rows in fits.items():
        cells = [f"{np.median([r[k] for r in rows]):.3f} / {max(r[k] for r in rows):.3f}" for k in TARGETS]
        meets = sum(all(r[k] <= TARGETS[k] for k in TARGETS) for r in rows)
        lines.append(f"| {label} | " + " | ".join(cells) + f" | {meets} of {len(rows)} |")
    return "\n".join(lines)


LENS_MODELS = {
    "standard": CalibrationOptions(),
    "--rational": CalibrationOptions(rational=True),
    "--fix-k3": CalibrationOptions(fix_k3=True),
    "--zero-tangent": CalibrationOptions(zero_tangent=True),
    "--fix-aspect": CalibrationOptions(fix_aspect=True),
}


def lens_table(seeds: list[int]) -> str:
    """Every lens model on two-camera renders (``lens_rig``): an ordinary lens that every model can describe
    and a 90-degree lens with rational distortion; 20 board poses, the same corner noise."""
    lines = ["| lens | model | worst focal, % | worst centre, px | worst baseline, % | worst rotation, deg | RMS, px | scenes meeting all | time, s |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|"]  # fmt: skip
    for lens in ("ordinary", "wide"):
        results: dict[str, list] = {}
        for seed in seeds:
            rng = np.random.default_rng(seed)
            truth = lens_rig(lens, rng)
            images = render_views(truth, BOARD, poses_seen_by_pairs(truth, BOARD, 20, rng, min_tilt_deg=15.0, max_tilt_deg=45.0), rng)
            frames = [FramePair(i, v, (0.0, 0.0)) for i, v in enumerate(images)]
            views = with_corner_noise(
                views_from_frames(BOARD, frames, truth.names, min_new=0.0, progress=False), NOISE_RMS_PX / np.sqrt(2), rng
            )
            for name, options in LENS_MODELS.items():
                t = time.perf_counter()
                cal = calibrate(views, BOARD, options)
                results.setdefault(name, []).append((rig_errors(truth, cal.rig), cal.report["rms_px"], time.perf_counter() - t))
            print(f"  {lens} lens, seed {seed}: " + "; ".join(
                f"{m} {r[-1][0]['focal_pct']:.3f} %" for m, r in results.items()), file=sys.stderr, flush=True)  # fmt: skip
        for name, rows in results.items():
            errs = {k: np.array([r[0][k] for r in rows]) for k in TARGETS}
            meets = sum(all(r[0][k] <= TARGETS[k] for k in TARGETS) for r in rows)
            cells = [f"{np.median(errs[k]):.3f} / {errs[k].max():.3f}" if k != "centre_px" else f"{np.median(errs[k]):.2f} / {errs[k].max():.2f}"
                     for k in TARGETS]  # fmt: skip
            lines.append(f"| {lens} | {name} | " + " | ".join(cells) + f" | {np.median([r[1] for r in rows]):.3f} "
                         f"| {meets} of {len(rows)} | {np.median([r[2] for r in rows]):.2f} |")  # fmt: skip
    return "\n".join(lines)


def real_table() -> str:
    board = Board("chessboard", (10, 7), 1.0)  # square 1: lengths in square lengths
    views = views_from_images(board, [str(REAL / "left*.jpg"), str(REAL / "right*.jpg")], progress=False)
    lines = ["| lens model | baseline, squares (Caltech 3.327) | +- (1 sd) | RMS, px | left fx, cx, cy (Caltech 533.5, 341.6, 235.2) | verdict | time, s |",
             "|---|---:|---:|---:|---|---|---:|"]  # fmt: skip
    for name, options in LENS_MODELS.items():
        t = time.perf_counter()
        cal = calibrate(views, board, options)
        seconds = time.perf_counter() - t
        pair = cal.report["pairs"][0]
        K = cal.rig[0].K
        lines.append(
            f"| {name} | {pair['baseline_squares']:.3f} | {pair['baseline_sd_m']:.3f} | {cal.report['rms_px']:.3f} "
            f"| {K[0, 0]:.1f}, {K[0, 2]:.1f}, {K[1, 2]:.1f} | {cal.report['verdict']} | {seconds:.2f} |"
        )
    return "\n".join(lines)


def solver_table(seed: int) -> str:
    """scipy's least_squares set up four ways on one 3-camera scene, from the same pairwise start."""
    from scipy.optimize import least_squares
    from scipy.sparse import lil_matrix
    from threadpoolctl import threadpool_limits

    from stereotrack.calibration import bundle, solve

    truth, views, _ = rendered_scene(3, seed)
    start = solve.starting_point(views, BOARD, CalibrationOptions())  # what the command starts the joint fit from
    corners, n_cams = start.corners, len(views.camera_names)
    problem = bundle.Problem(corners, n_cams, views.n_views, start.model, start.x[0])
    x0 = problem.pack(*start.x)
    scale = bundle.robust_scale(problem.residuals(x0))

    sparsity = lil_matrix((2 * len(corners.view), problem.n_unknowns), dtype=np.int8)  # a corner depends on its camera and view
    for v, c, rows in problem.blocks:
        r = np.column_stack([2 * rows, 2 * rows + 1]).ravel()[:, None]
        sparsity[r, problem.i_views + 6 * v + np.arange(6)] = 1
        sparsity[r, c * problem.n_free + np.arange(problem.n_free)] = 1
        if c > 0:
            sparsity[r, problem.i_cams + 6 * (c - 1) + np.arange(6)] = 1
    common = dict(loss="huber", f_scale=scale, method="trf", x_scale="jac")
    ways = {
        "exact Jacobian, dense trust region, BLAS on 1 thread (the default)": (
            lambda: least_squares(problem.residuals, x0, jac=problem.jacobian, tr_solver="exact", **common), 1),
        "exact Jacobian, dense trust region, BLAS threads as they come": (
            lambda: least_squares(problem.residuals, x0, jac=problem.jacobian, tr_solver="exact", **common), None),
        "finite differences over jac_sparsity, lsmr, at most 300 evaluations": (
            lambda: least_squares(problem.residuals, x0, jac_sparsity=sparsity, tr_solver="lsmr", max_nfev=300, **common), 1),
        "exact Jacobian, Levenberg-Marquardt (no robust loss)": (
            lambda: least_squares(problem.residuals, x0, jac=problem.jacobian, method="lm", x_scale="jac"), 1),
    }  # fmt: skip
    lines = [
        f"| least_squares, 3 cameras, seed {seed}, {len(corners.view)} corners, {problem.n_unknowns} unknowns | time, s | evaluations "
        "| converged | worst focal, % | worst rotation, deg |",
        "|---|---:|---:|---|---:|---:|",
    ]
    for name, (run, threads) in ways.items():
        with threadpool_limits(threads):
            t = time.perf_counter()
            fit = run()
            seconds = time.perf_counter() - t
        intrinsics, cam_poses, _ = problem.unpack(fit.x)
        cams = []
        for c in range(n_cams):
            fx, fy, cx, cy = intrinsics[c, :4]
            K = np.array([[fx, 0, cx], [0, fy, cy], [0, 0, 1.0]])
            cams.append(
                Camera(
                    views.camera_names[c], views.image_sizes[c], K, intrinsics[c, 4:9], cv2.Rodrigues(cam_poses[c, :3])[0], cam_poses[c, 3:]
                )
            )
        errors = rig_errors(truth, Rig(tuple(cams)))
        lines.append(f"| {name} | {seconds:.2f} | {fit.nfev} | {'yes' if fit.status > 0 else 'no'} "
                     f"| {errors['focal_pct']:.3f} | {errors['rotation_deg']:.3f} |")  # fmt: skip
    return "\n".join(lines)


def parse_seeds(text: str) -> list[int]:
    a, _, b = text.partition("-")
    return list(range(int(a), int(b or a) + 1))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seeds", default="200-209", help="rendered scenes to measure on (default 200-209)")
    parser.add_argument("--write", action="store_true", help="write the tables into README.md between the markers")
    parser.add_argument("--lenses", action="store_true", help="only the lens-model table (on --seeds)")
    parser.add_argument("--rigs", action="store_true", help="only the 2- and 3-camera rig table (on --seeds)")
    parser.add_argument("--detectors", metavar="SEEDS", help="compare corner detectors on these 2-camera scenes (tune seeds, e.g. 0-9)")
    parser.add_argument("--solvers", type=int, metavar="SEED", help="only compare ways to set up least_squares on this 3-camera scene")
    args = parser.parse_args()
    if args.solvers is not None:
        print(solver_table(args.solvers))
        return
    if args.detectors is not None:
        print(detector_table(parse_seeds(args.detectors)))
        return
    seeds = parse_seeds(args.seeds)
    if args.lenses:
        print(lens_table(seeds))
        return
    if args.rigs:
        print(rendered_table(seeds))
        return
    text = (
        f"Rendered views, seeds {seeds[0]}-{seeds[-1]} ({len(seeds)} rigs per row), {N_VIEWS} board poses, corner noise "
        f"{NOISE_RMS_PX} px RMS; median / worst over the scenes:\n\n{rendered_table(seeds)}\n\n"
        f"Every lens model on rendered pairs, seeds {seeds[0]}-{seeds[-1]}, 20 board poses, the same noise (median / worst):\n\n"
        f"{lens_table(seeds)}\n\n"
        f"OpenCV's 13 real stereo pairs (`tests/data/opencv-stereo-chessboard`), every lens model:\n\n{real_table()}\n"
    )
    print(text)
    if args.write:
        readme = ROOT / "README.md"
        old = readme.read_text()
        pattern = re.escape(MARKERS[0]) + ".*?" + re.escape(MARKERS[1])
        if not re.search(pattern, old, flags=re.S):
            raise SystemExit(f"README.md has no {MARKERS[0]} ... {MARKERS[1]} block")
        readme.write_text(re.sub(pattern, lambda _: f"{MARKERS[0]}\n{text}{MARKERS[1]}", old, flags=re.S))
        print("wrote README.md", file=sys.stderr)


if __name__ == "__main__":
    main()
