import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

from stereotrack.calibration import (
    CalibrationOptions,
    ViewSet,
    calibrate,
    calibrate_intrinsics,
    match_image_files,
    views_from_frames,
    views_from_images,
)
from stereotrack.calibration.boards import Board, Detection, flipped, save_board
from stereotrack.camera import Camera, Rig, intrinsics_from_fov, load_rig, look_at
from stereotrack.errors import StereotrackError
from stereotrack.frames import FramePair
from stereotrack.recording import RecordingWriter
from stereotrack.simulation.boards import (
    calibration_rig,
    lens_rig,
    poses_seen_by_pairs,
    random_board_poses,
    render_views,
    write_image_folders,
)

REAL = Path(__file__).parents[1] / "data" / "opencv-stereo-chessboard"
OPENCV_BOARD = Board("chessboard", (10, 7), 1.0)  # 9 x 6 inner corners, square 1 (OpenCV's test)
CHESS = Board("chessboard", (9, 7), 0.03)
CHARUCO = Board("charuco", (7, 5), 0.04, 0.03, "DICT_5X5_100")


def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "stereotrack", *map(str, args)], capture_output=True, text=True)


# --------------------------------------------------------------------------- real data, published references


@pytest.fixture(scope="module")
def real_views():
    # OpenCV's test refines corners in an 11 x 11 window: half-size 5
    return views_from_images(OPENCV_BOARD, [str(REAL / "left*.jpg"), str(REAL / "right*.jpg")], subpix_window=5, progress=False)


def test_real_images_are_paired_by_name(real_views):
    assert real_views.view_names == ("01", "02", "03", "04", "05", "06", "07", "08", "09", "11", "12", "13", "14")
    assert all(d is not None for row in real_views.detections for d in row)


def test_real_left_camera_rms_matches_opencv_test(real_views):
    left = [row[0] for row in real_views.detections]
    rms, K, dist, per_view, _ = calibrate_intrinsics(OPENCV_BOARD, left, (640, 480), flags=0)
    assert abs(rms - 0.196334638) < 0.01


def test_real_left_focal_with_fixed_aspect_matches_reference():
    # left_intrinsics.yml came from OpenCV's calibration sample: fixed aspect ratio, 23 x 23 refinement window
    views = views_from_images(OPENCV_BOARD, [str(REAL / "left*.jpg"), str(REAL / "right*.jpg")], subpix_window=11, progress=False)
    rms, K, *_ = calibrate_intrinsics(OPENCV_BOARD, [row[0] for row in views.detections], (640, 480), flags=cv2.CALIB_FIX_ASPECT_RATIO)
    assert K[0, 0] == K[1, 1]
    assert abs(K[0, 0] - 535.916) < 3.0
    # our default window (a quarter of the corner spacing) also lands within 3 px, and within 1 px of Caltech's 533.5
    views = views_from_images(OPENCV_BOARD, [str(REAL / "left*.jpg"), str(REAL / "right*.jpg")], progress=False)
    rms_default, K, *_ = calibrate_intrinsics(
        OPENCV_BOARD, [row[0] for row in views.detections], (640, 480), flags=cv2.CALIB_FIX_ASPECT_RATIO
    )
    assert abs(K[0, 0] - 535.916) < 3.0 and abs(K[0, 0] - 533.5) < 1.0
    assert rms_default < rms  # the smaller window fits the corners better


def test_real_stereo_baseline_and_right_focal():
    views = views_from_images(OPENCV_BOARD, [str(REAL / "left*.jpg"), str(REAL / "right*.jpg")], progress=False)
    cal = calibrate(views, OPENCV_BOARD)
    baseline = cal.rig.baseline()  # in square lengths (square = 1)
    # target 3.33-3.35 read to two decimals; Caltech's own T gives 99.81 / 30 = 3.327
    assert 3.325 <= baseline <= 3.35
    right = cal.rig[1].K
    assert abs(right[0, 0] / 536.7 - 1) < 0.015 and abs(right[1, 1] / 536.7 - 1) < 0.015
    # the joint fit lands on Caltech's own calibration of these images: fc, cc within a pixel
    left = cal.rig[0].K
    assert abs(left[0, 0] - 533.5) < 1.0 and abs(left[0, 2] - 341.6) < 1.0 and abs(left[1, 2] - 235.2) < 1.0
    assert abs(right[0, 0] - 536.8) < 1.0 and abs(right[0, 2] - 326.3) < 1.0 and abs(right[1, 2] - 250.1) < 1.0
    r = cal.report
    assert r["verdict"] == "good" and r["pairs"][0]["epipolar_mean_px"] < 0.3
    # the baseline's uncertainty: Caltech's 3.327 is within two standard deviations
    assert 0 < r["pairs"][0]["baseline_sd_m"] < 0.01 and abs(baseline - 3.327) < 2 * r["pairs"][0]["baseline_sd_m"] + 0.001
    assert cal.rig.quality["views_used"] == 13 and set(cal.rig.quality["per_camera_rms_px"]) == {"cam0", "cam1"}


LENS_MODELS = {
    "standard": CalibrationOptions(),
    "rational": CalibrationOptions(rational=True),
    "fix-k3": CalibrationOptions(fix_k3=True),
    "zero-tangent": CalibrationOptions(zero_tangent=True),
    "fix-aspect": CalibrationOptions(fix_aspect=True),
}


@pytest.mark.parametrize("model", list(LENS_MODELS))
def test_every_lens_model_on_the_real_pairs(real_views, model):
    # Caltech's own result: 99.81 mm / 30 mm = 3.327 square lengths; the stereo step once ignored
    # the rational model's k4..k6 (baseline 11-18 squares, RMS 77-84 px)
    cal = calibrate(real_views, OPENCV_BOARD, LENS_MODELS[model])
    assert 3.32 <= cal.rig.baseline() <= 3.35, model
    assert cal.report["rms_px"] < 0.3 and cal.report["pairs"][0]["rms_px"] < 0.3
    assert cal.report["verdict"] == "good", cal.report["reasons"]
    assert len(cal.rig[0].dist) == (8 if model == "rational" else 5)
    options = LENS_MODELS[model]
    dist = cal.rig[0].dist
    assert (dist[4] == 0) == options.fix_k3 and (np.all(dist[2:4] == 0)) == options.zero_tangent
    assert (cal.rig[0].K[0, 0] == cal.rig[0].K[1, 1]) == options.fix_aspect


# --------------------------------------------------------------------------- rendered boards, known rig


def truth_rig() -> Rig:
    K0 = intrinsics_from_fov(640, 480, 62)
    K0[0, 2], K0[1, 2] = 325.0, 236.0
    K1 = K0.copy()
    K1[0, 0] *= 1.02
    K1[1, 1] *= 1.02
    K1[0, 2] = 315.0
    dist = np.array([-0.12, 0.04, 0.0008, -0.0005, 0.0])
    cams = []
    for i, (eye, target, K) in enumerate([((-0.06, 0, 0), (0, 0, 1.0), K0), ((0.06, 0.005, 0.01), (0.02, 0, 1.0), K1)]):
        R, t = look_at(eye, target)
        cams.append(Camera(f"cam{i}", (640, 480), K, dist, R, t))
    return Rig(tuple(cams))


def as_pairs(views):
    return [FramePair(i, tuple(cv2.cvtColor(im, cv2.COLOR_GRAY2BGR) for im in v), (i / 30, i / 30)) for i, v in enumerate(views)]


@pytest.fixture(scope="module")
def rendered():
    rig = truth_rig()
    out = {}
    for seed, board in enumerate((CHESS, CHARUCO)):
        rng = np.random.default_rng(10 + seed)
        poses = random_board_poses(rig, board, 20, rng)
        images = render_views(rig, board, poses, rng)
        out[board.type] = (rig, board, images, views_from_frames(board, as_pairs(images), rig.names, min_new=0.0, progress=False))
    return out


def rig_errors(truth: Rig, est: Rig):
    f = [abs(e.K[k, k] / t.K[k, k] - 1) for t, e in zip(truth.cameras, est.cameras) for k in (0, 1)]
    pp = [np.abs(e.K[:2, 2] - t.K[:2, 2]).max() for t, e in zip(truth.cameras, est.cameras)]
    base = abs(est.baseline() / truth.baseline() - 1)
    dR = (est[1].R @ est[0].R.T) @ (truth[1].R @ truth[0].R.T).T
    rot = np.degrees(np.linalg.norm(cv2.Rodrigues(dR)[0]))
    return max(f), max(pp), base, rot


@pytest.mark.parametrize("kind", ["chessboard", "charuco"])
def test_rendered_boards_meet_targets(rendered, kind):
    rig, board, _, views = rendered[kind]
    assert views.n_views == 20
    cal = calibrate(views, board)
    f, pp, base, rot = rig_errors(rig, cal.rig)
    assert f < 0.005 and pp < 2.0 and base < 0.005 and rot < 0.2
    assert cal.report["rms_px"] < 0.2 and cal.report["epipolar_mean_px"] < 0.15
    assert cal.rig.world == "cam0" and np.allclose(cal.rig[0].R, np.eye(3)) and np.allclose(cal.rig[0].t, 0)


def test_chessboard_numbered_from_opposite_ends_is_relabelled(rendered):
    rig, board, _, views = rendered["chessboard"]
    dets = [list(row) for row in views.detections]
    turned = [1, 4, 7, 12]
    for v in turned:
        dets[v][1] = flipped(board, dets[v][1])
    cal = calibrate(ViewSet(views.camera_names, views.image_sizes, views.view_names, tuple(map(tuple, dets))), board)
    assert cal.report["views"]["relabelled"] in (len(turned), 20 - len(turned))
    f, pp, base, rot = rig_errors(rig, cal.rig)
    assert base < 0.005 and rot < 0.2


def test_worst_view_is_named_and_can_be_dropped(rendered):
    rig, board, _, views = rendered["charuco"]
    rng = np.random.default_rng(7)
    dets = [list(row) for row in views.detections]
    bad = dets[5][0]
    dets[5][0] = type(bad)(bad.ids, bad.corners + rng.normal(0, 2.0, bad.corners.shape))  # a blurred, jittery view
    noisy = ViewSet(views.camera_names, views.image_sizes, views.view_names, tuple(map(tuple, dets)))
    first = calibrate(noisy, board)
    worst = first.report["views"]["ranked"][0]
    assert worst["view"] == views.view_names[5] and worst["outlier"]
    assert any("--drop-worst 1" in r for r in first.report["reasons"])
    second = calibrate(noisy, board, CalibrationOptions(drop_worst=1))
    assert second.report["views"]["dropped"] == [views.view_names[5]] and second.views.n_views == 19
    assert second.report["rms_px"] < first.report["rms_px"] / 2


def test_world_from_a_board_view_has_z_up(rendered):
    rig, board, _, views = rendered["charuco"]
    name = views.view_names[3]
    cal = calibrate(views, board, CalibrationOptions(world_view=name))
    assert cal.rig.world == "custom"
    # the board corners seen in that view triangulate onto z = 0 and the cameras are above it
    d0, d1 = views.detections[3]
    common, i0, i1 = np.intersect1d(d0.ids, d1.ids, return_indices=True)
    from stereotrack.camera import triangulate_points

    X = triangulate_points(cal.rig.cameras, [d0.corners[i0], d1.corners[i1]])
    assert np.abs(X[:, 2]).max() < 0.002
    assert np.allclose(X[:, :2], board.object_points()[common][:, :2] * [1, -1], atol=0.003)
    assert all(cam.centre[2] > 0.3 for cam in cal.rig.cameras)
    assert abs(cal.rig.baseline() - rig.baseline()) < 0.001
    with pytest.raises(StereotrackError, match="no such view"):
        calibrate(views, board, CalibrationOptions(world_view="nope"))


# --------------------------------------------------------------------------- joint refinement: the targets

# Rendered rigs as in benchmarks/calibration_accuracy.py: 24 board poses, each seen whole by at least two
# cameras, corners moved by 0.3 px RMS of noise (a webcam's). Targets: every focal within 0.3 %, principal
# point within 3 px, every baseline within 0.2 %, every relative rotation within 0.25 degree.
TARGETS = {"focal_pct": 0.3, "centre_px": 3.0, "baseline_pct": 0.2, "rotation_deg": 0.25}
JOINT_SEED = {2: 200, 3: 200}  # the benchmark's first held-out scenes


def noisy(views: ViewSet, rng, rms: float = 0.3) -> ViewSet:
    rows = tuple(
        tuple(None if d is None else Detection(d.ids, d.corners + rng.normal(0, rms / np.sqrt(2), d.corners.shape)) for d in row)
        for row in views.detections
    )
    return ViewSet(views.camera_names, views.image_sizes, views.view_names, rows)


@pytest.fixture(scope="module")
def rigs_seen():
    """Per camera count: (true rig, detected views with corner noise)."""
    out = {}
    for n_cams, seed in JOINT_SEED.items():
        rng = np.random.default_rng(seed)
        rig = calibration_rig(n_cams, rng)
        images = render_views(rig, CHESS, poses_seen_by_pairs(rig, CHESS, 24, rng, min_tilt_deg=15.0, max_tilt_deg=45.0), rng)
        views = views_from_frames(
            CHESS, [FramePair(i, v, (0.0,) * n_cams) for i, v in enumerate(images)], rig.names, min_new=0.0, progress=False
        )
        out[n_cams] = (rig, noisy(views, rng))
    return out


def all_errors(truth: Rig, est: Rig) -> dict[str, float]:
    focal = max(abs(e.K[k, k] / t.K[k, k] - 1) for t, e in zip(truth.cameras, est.cameras) for k in (0, 1))
    centre = max(float(np.abs(e.K[:2, 2] - t.K[:2, 2]).max()) for t, e in zip(truth.cameras, est.cameras))
    base = rot = 0.0
    for i in range(len(truth)):
        for j in range(i + 1, len(truth)):
            base = max(base, abs(est.baseline(i, j) / truth.baseline(i, j) - 1))
            dR = (est[j].R @ est[i].R.T) @ (truth[j].R @ truth[i].R.T).T
            rot = max(rot, float(np.degrees(np.linalg.norm(cv2.Rodrigues(dR)[0]))))
    return {"focal_pct": 100 * focal, "centre_px": centre, "baseline_pct": 100 * base, "rotation_deg": rot}


@pytest.mark.parametrize("n_cams", [2, 3])
def test_joint_refinement_meets_the_targets(rigs_seen, n_cams):
    rig, views = rigs_seen[n_cams]
    assert views.n_views == 24 and all(sum(d is not None for d in row) >= 2 for row in views.detections)
    cal = calibrate(views, CHESS)
    errors = all_errors(rig, cal.rig)
    assert all(errors[k] <= TARGETS[k] for k in TARGETS), errors
    assert cal.report["method"] == "joint" and cal.rig.quality["method"] == "joint"
    # every pair reported with the residuals after the fit and its baseline's uncertainty, which covers the true error
    assert len(cal.report["pairs"]) == n_cams * (n_cams - 1) // 2
    for p in cal.report["pairs"]:
        i, j = (rig.names.index(n) for n in p["cameras"])
        assert p["baseline_sd_m"] > 0 and abs(p["baseline_m"] - rig.baseline(i, j)) < 4 * p["baseline_sd_m"]
    assert 0.25 < cal.report["rms_px"] < 0.35  # the corners' own noise: 0.3 px RMS
    # the pairwise starts alone (the old default) are worse on every figure but one at most
    before = all_errors(rig, calibrate(views, CHESS, CalibrationOptions(joint=False)).rig)
    assert sum(before[k] > errors[k] for k in TARGETS) >= 3, (before, errors)


def test_views_seen_by_one_camera_still_count(rigs_seen):
    rig, views = rigs_seen[2]
    # a view only cam1 saw: it adds to cam1's views and residuals, and the fit keeps its corners in place
    extra = ViewSet(
        views.camera_names, views.image_sizes, (*views.view_names, "alone"), (*views.detections, (None, views.detections[3][1]))
    )
    cal = calibrate(extra, CHESS)
    assert cal.report["cameras"]["cam1"]["views"] == 25 and cal.report["cameras"]["cam0"]["views"] == 24
    assert cal.report["views"]["per_view_rms_px"]["alone"]["cam1"] < 0.5
    assert np.linalg.norm(cal.fit.residuals(24, 1), axis=1).max() < 1.5


def test_a_few_bad_corners_do_not_pull_the_fit(rigs_seen):
    rig, views = rigs_seen[3]
    clean = all_errors(rig, calibrate(views, CHESS).rig)
    rows = [list(row) for row in views.detections]
    rng = np.random.default_rng(3)
    moved = []
    for v in (2, 9, 17):  # a corner misplaced by 6 px in three views (a reflection, a smudge)
        c = next(c for c, d in enumerate(rows[v]) if d is not None)
        d = rows[v][c]
        k = int(rng.integers(len(d)))
        corners = d.corners.copy()
        corners[k] += 6.0 * rng.normal(size=2) / np.sqrt(2)
        rows[v][c] = Detection(d.ids, corners)
        moved.append((v, c, k))
    cal = calibrate(ViewSet(views.camera_names, views.image_sizes, views.view_names, tuple(map(tuple, rows))), CHESS)
    errors = all_errors(rig, cal.rig)
    assert all(errors[k] <= TARGETS[k] for k in TARGETS), errors
    assert abs(errors["focal_pct"] - clean["focal_pct"]) < 0.05 and abs(errors["rotation_deg"] - clean["rotation_deg"]) < 0.03
    for v, c, k in moved:  # the fit leaves them out rather than bending to them: their residual is the misplacement
        assert np.linalg.norm(cal.fit.residuals(v, c)[k]) > 2.0


# --------------------------------------------------------------------------- the command, three sources


def test_calibrate_command_from_image_folders(tmp_path, rendered):
    rig, board, images, _ = rendered["chessboard"]
    dirs = write_image_folders(tmp_path / "shots", rig, images[:12])
    cv2.imwrite(str(dirs[1] / "extra.png"), images[12][1])  # no partner in cam0: skipped with a warning
    save_board(board, tmp_path / "board.yaml")
    out = tmp_path / "calib" / "desk.yaml"
    r = run_cli("calibrate", "--board", tmp_path / "board.yaml", "--images", *dirs, "--out", out, "--no-progress")
    assert r.returncode == 0, r.stderr
    assert "verdict:" in r.stdout and "baseline" in r.stdout
    assert "1 image(s) have no partner with the same name in the other folders and are skipped (e.g. extra.png)" in r.stderr
    est = load_rig(out)
    assert est.quality["views_used"] == 12 and est.quality["board"]["type"] == "chessboard"
    assert abs(est.baseline() / rig.baseline() - 1) < 0.01
    report = yaml.safe_load((tmp_path / "calib" / "desk.report.yaml").read_text())
    assert report["verdict"] in ("good", "usable", "redo") and report["reasons"] is not None
    assert len(report["views"]["ranked"]) == 12 and report["pairs"][0]["baseline_m"] == pytest.approx(rig.baseline(), rel=0.01)


def test_calibrate_command_from_recording_samples_new_steady_poses(tmp_path, rendered):
    rig, board, images, _ = rendered["charuco"]
    folder = tmp_path / "rec"
    blank = np.full((480, 640, 3), 120, np.uint8)
    starts = []
    with RecordingWriter(folder, rig.names, (640, 480), 30.0) as w:
        n = 0
        for k, view in enumerate(images[:10]):
            starts.append(n)
            bgr = [cv2.cvtColor(im, cv2.COLOR_GRAY2BGR) for im in view]
            for _ in range(3):  # the board held still for 3 frames: sampled once
                w.write(bgr, [n / 30, n / 30])
                n += 1
            if k % 3 == 0:  # the board out of view of cam1, then of both
                w.write([bgr[0], blank], [n / 30, n / 30])
                w.write([blank, blank], [(n + 1) / 30, (n + 1) / 30])
                n += 2
    save_board(board, tmp_path / "board.yaml")
    out = tmp_path / "rec.yaml"
    r = run_cli("calibrate", "--board", tmp_path / "board.yaml", "--recording", folder, "--out", out, "--no-progress", "--every", "1")
    assert r.returncode == 0, r.stderr
    est = load_rig(out)
    # poses 3 and 8 are within 5% of the image diagonal of pose 1 (mean corner shift 39 and 32 px): not new
    expected = [f"frame{starts[k]:06d}" for k in (0, 1, 2, 4, 5, 6, 7, 9)]
    report = yaml.safe_load((tmp_path / "rec.report.yaml").read_text())
    assert sorted(report["views"]["per_view_rms_px"]) == expected
    assert est.quality["views_used"] == 8
    assert abs(est.baseline() / rig.baseline() - 1) < 0.01


def test_views_from_live_stream_wait_for_a_steady_board(rendered):
    rig, board, images, _ = rendered["charuco"]
    pairs = []
    distinct = [images[k] for k in (0, 1, 2, 4, 5, 6)]  # pose 3 is close to pose 1 (see the recording test)
    for view in distinct:
        moving = [np.roll(im, 6, axis=1) for im in view]  # the board still moving by 6 px a frame: not taken
        pairs += [moving, view, view]
    stream = (FramePair(i, tuple(cv2.cvtColor(im, cv2.COLOR_GRAY2BGR) for im in v), (i / 30, i / 30)) for i, v in enumerate(pairs))
    views = views_from_frames(board, stream, rig.names, steady_px=2.0, progress=False)
    # each pose is taken at its first still frame, whose successor confirms it is steady
    assert views.view_names == tuple(f"frame{3 * k + 1:06d}" for k in range(6))
    again = (FramePair(i, tuple(cv2.cvtColor(im, cv2.COLOR_GRAY2BGR) for im in v), (i / 30, i / 30)) for i, v in enumerate(pairs))
    assert views_from_frames(board, again, rig.names, steady_px=2.0, max_views=4, progress=False).n_views == 4
    with pytest.raises(StereotrackError, match="no frames"):
        views_from_frames(board, iter([]), rig.names, progress=False)


# --------------------------------------------------------------------------- bad input: one clear line each


def one_line_error(r):
    assert r.returncode == 2, r.stdout + r.stderr
    assert r.stderr.startswith("error: ") and r.stderr.count("\n") == 1 and "Traceback" not in r.stderr
    return r.stderr


def test_zero_detections_say_what_to_check(tmp_path):
    blank = np.full((480, 640), 128, np.uint8)
    for cam in ("a", "b"):
        (tmp_path / cam).mkdir()
        for i in range(6):
            cv2.imwrite(str(tmp_path / cam / f"{i:03d}.png"), blank)
    save_board(CHESS, tmp_path / "board.yaml")
    r = run_cli(
        "calibrate",
        "--board",
        tmp_path / "board.yaml",
        "--images",
        tmp_path / "a",
        tmp_path / "b",
        "--out",
        tmp_path / "x.yaml",
        "--no-progress",
    )
    msg = one_line_error(r)
    assert "was not found in any of 6 images of cam0" in msg and "squares in board.yaml" in msg


def test_board_settings_mismatch_reports_what_was_found(rendered):
    rig, board, images, _ = rendered["chessboard"]
    wrong = Board("chessboard", (7, 7), 0.03)
    views = views_from_frames(wrong, as_pairs(images[:2]), rig.names, min_new=0.0, progress=False)
    with pytest.raises(StereotrackError) as e:
        calibrate(views, wrong)
    assert "found a chessboard with 9x7 squares (8x6 inner corners) but board.yaml says squares: [7, 7]" in str(e.value)


def test_too_few_views_say_how_many_more(rendered):
    rig, board, images, views = rendered["charuco"]
    few = views.without(views.view_names[3:])
    with pytest.raises(StereotrackError, match=r"found in only 3 of 3 views; need at least 5 \(2 more\)"):
        calibrate(few, board)


def test_cameras_that_never_see_the_board_together(rendered):
    rig, board, images, views = rendered["charuco"]
    rows = [(d0, None) if v < 10 else (None, d1) for v, (d0, d1) in enumerate(views.detections)]
    apart = ViewSet(views.camera_names, views.image_sizes, views.view_names, tuple(rows))
    with pytest.raises(StereotrackError, match="cameras cam0 and cam1 never see the board together"):
        calibrate(apart, board)
    rows = [(d0, d1 if v < 3 else None) if v < 10 else (None, d1) for v, (d0, d1) in enumerate(views.detections)]
    few = ViewSet(views.camera_names, views.image_sizes, views.view_names, tuple(rows))
    with pytest.raises(StereotrackError, match=r"together in only 3 views; need at least 5 \(2 more\)"):
        calibrate(few, board)


def test_images_of_different_sizes_and_unmatched_names(tmp_path, rendered):
    rig, board, images, _ = rendered["charuco"]
    dirs = write_image_folders(tmp_path / "s", rig, images[:3])
    cv2.imwrite(str(dirs[1] / "view002.png"), cv2.resize(images[2][1], (320, 240)))
    save_board(board, tmp_path / "board.yaml")
    r = run_cli("calibrate", "--board", tmp_path / "board.yaml", "--images", *dirs, "--out", tmp_path / "x.yaml", "--no-progress")
    msg = one_line_error(r)
    assert "view002.png: image is 320x240 but view000.png is 640x480" in msg
    (tmp_path / "other").mkdir()
    cv2.imwrite(str(tmp_path / "other" / "zzz.png"), images[0][1])
    with pytest.raises(StereotrackError, match="no image names match"):
        match_image_files([str(dirs[0]), str(tmp_path / "other")])
    r = run_cli("calibrate", "--board", tmp_path / "board.yaml", "--images", dirs[0], "--recording", tmp_path, "--out", tmp_path / "x.yaml")
    assert "exactly one source of views" in one_line_error(r)


def write_views(folder, images, seen):
    """Image folders cam0, cam1 with the rendered view where seen[v][c], a blank grey image elsewhere."""
    blank = np.full((480, 640), 120, np.uint8)
    dirs = [folder / "cam0", folder / "cam1"]
    for d in dirs:
        d.mkdir(parents=True)
    for v, view in enumerate(images):
        for c, d in enumerate(dirs):
            cv2.imwrite(str(d / f"{v:03d}.png"), view[c] if seen[v][c] else blank)
    return dirs


@pytest.mark.parametrize(
    "case, expected",
    [
        ("never together", "cameras cam0 and cam1 never see the board together in the same view"),
        ("one camera never", "the board (chessboard 9x7 squares of 30 mm) was not found in any of 12 images of cam1"),
        ("board does not match", "found a chessboard with 9x7 squares (8x6 inner corners) but board.yaml says squares: [7, 7]"),
        ("names do not match", "no image names match between"),
    ],
)
def test_bad_input_is_one_line_and_keeps_the_previous_calibration(tmp_path, rendered, case, expected):
    rig, board, images, _ = rendered["chessboard"]
    images = images[:12]
    seen = {
        "never together": [(v < 6, v >= 6) for v in range(12)],
        "one camera never": [(True, False)] * 12,
    }.get(case, [(True, True)] * 12)
    dirs = write_views(tmp_path, images, seen)
    if case == "names do not match":  # 001.png in cam0, r1.png in cam1: never paired by their trailing numbers
        for f in sorted(dirs[1].iterdir()):
            f.rename(f.with_name(f"r{int(f.stem)}.png"))
    save_board(Board("chessboard", (7, 7), 0.03) if case == "board does not match" else board, tmp_path / "board.yaml")
    out = tmp_path / "calib.yaml"
    out.write_text("cameras: []  # a previous calibration\n")  # an earlier calibration file: err lets --out replace only one
    r = run_cli("calibrate", "--board", tmp_path / "board.yaml", "--images", *dirs, "--out", out, "--no-progress")
    assert expected in one_line_error(r)
    assert out.read_text() == "cameras: []  # a previous calibration\n" and not (tmp_path / "calib.report.yaml").exists()


def test_images_pair_by_exact_name_or_by_what_the_wildcard_matched(tmp_path):
    for name in ("left01.png", "left02.png", "left10.png", "01.png", "r1.png"):
        cv2.imwrite(str(tmp_path / name), np.zeros((4, 4), np.uint8))
    (tmp_path / "right").mkdir()
    for name in ("right01.png", "right2.png", "right10.png"):
        cv2.imwrite(str(tmp_path / "right" / name), np.zeros((4, 4), np.uint8))
    names, files = match_image_files([str(tmp_path / "left*.png"), str(tmp_path / "right" / "right*.png")])
    assert names == ["01", "10"] and [f.name for f in files[0]] == ["left01.png", "right01.png"]  # 02 and 2 are not the same name
    for folder, name in (("a", "01.png"), ("b", "r1.png")):  # in folders the whole name must match
        (tmp_path / folder).mkdir()
        cv2.imwrite(str(tmp_path / folder / name), np.zeros((4, 4), np.uint8))
    with pytest.raises(StereotrackError, match="no image names match"):
        match_image_files([str(tmp_path / "a"), str(tmp_path / "b")])


def test_calibrate_command_from_live_cameras(tmp_path, rendered):
    # Two video files played as cameras, paced at their frame rate by the live capture threads.
    rig, board, images, _ = rendered["charuco"]
    folder = tmp_path / "cams"
    with RecordingWriter(folder, rig.names, (640, 480), 10.0, codec="ffv1") as w:  # lossless board images
        n = 0
        for k in (0, 1, 2, 4, 5, 6):  # distinct poses (3 is close to 1)
            bgr = [cv2.cvtColor(im, cv2.COLOR_GRAY2BGR) for im in images[k]]
            for _ in range(12):  # held still for 1.2 s: time to detect it twice even on a loaded machine
                w.write(bgr, [n / 10, n / 10])
                n += 1
    save_board(board, tmp_path / "board.yaml")
    out = tmp_path / "live.yaml"
    r = run_cli(
        "calibrate",
        "--board",
        tmp_path / "board.yaml",
        "--cam0",
        folder / "cam0.avi",
        "--cam1",
        folder / "cam1.avi",
        "--out",
        out,
        "--stall-timeout",
        "10",  # at load 15 a file camera's thread can get no CPU for the default 2 s
    )
    assert r.returncode == 0, r.stderr
    est = load_rig(out)
    assert 5 <= est.quality["views_used"] <= 6, r.stdout
    assert abs(est.baseline() / rig.baseline() - 1) < 0.01
    # stderr is a pipe here, not a terminal: each view taken is still announced, as a plain line of its own
    taken = [line for line in r.stderr.splitlines() if "views taken" in line]
    assert [line.split("views taken ")[1].split(",")[0] for line in taken] == [str(k) for k in range(1, est.quality["views_used"] + 1)]
    assert all("\r" not in line and "coverage cam0" in line for line in taken)


def test_three_cameras_linked_through_the_views_they_share():
    K = intrinsics_from_fov(640, 480, 62)
    dist = np.array([-0.1, 0.03, 0.0, 0.0, 0.0])
    cams = []
    for i, x in enumerate((-0.1, 0.0, 0.12)):
        R, t = look_at((x, 0.01 * i, 0.0), (0.0, 0.0, 1.0))
        cams.append(Camera(f"cam{i}", (640, 480), K, dist, R, t))
    rig = Rig(tuple(cams))
    rng = np.random.default_rng(21)
    images = render_views(rig, CHARUCO, random_board_poses(rig, CHARUCO, 16, rng), rng)
    # cam0 sees views 0-11, cam2 views 4-15, cam1 all: cam0-cam2 share 8 views, cam1-cam2 share 12,
    # so cam2 is linked through cam1
    seen = [range(0, 12), range(0, 16), range(4, 16)]
    blank = np.full((480, 640, 3), 120, np.uint8)
    pairs = [
        FramePair(i, tuple(cv2.cvtColor(im, cv2.COLOR_GRAY2BGR) if i in seen[c] else blank for c, im in enumerate(v)), (0.0,) * 3)
        for i, v in enumerate(images)
    ]
    views = views_from_frames(CHARUCO, pairs, rig.names, min_new=0.0, progress=False)
    cal = calibrate(views, CHARUCO)
    assert [(p["cameras"], p["views"]) for p in cal.report["pairs"]] == [
        (["cam0", "cam1"], 12),
        (["cam0", "cam2"], 8),
        (["cam1", "cam2"], 12),
    ]
    for j in (1, 2):
        assert abs(cal.rig.baseline(0, j) / rig.baseline(0, j) - 1) < 0.01
        dR = (cal.rig[j].R @ cal.rig[0].R.T) @ (rig[j].R @ rig[0].R.T).T
        assert np.degrees(np.linalg.norm(cv2.Rodrigues(dR)[0])) < 0.3


# --------------------------------------------------------------------------- every lens model on renders


@pytest.fixture(scope="module")
def lens_scenes():
    """An ordinary lens that every model can describe (fx = fy, radial k1 k2 only) and a 90-degree lens
    with rational distortion (k4 0.7-1.0); 16 poses each, corners with 0.3 px of noise."""
    out = {}
    for kind, seed in (("ordinary", 40), ("wide", 41)):
        rng = np.random.default_rng(seed)
        rig = lens_rig(kind, rng)
        images = render_views(rig, CHESS, poses_seen_by_pairs(rig, CHESS, 16, rng, min_tilt_deg=15.0, max_tilt_deg=45.0), rng)
        views = views_from_frames(
            CHESS, [FramePair(i, v, (0.0, 0.0)) for i, v in enumerate(images)], rig.names, min_new=0.0, progress=False
        )
        out[kind] = (rig, noisy(views, rng))
    return out


@pytest.mark.parametrize("model", list(LENS_MODELS))
def test_every_lens_model_on_renders_of_a_lens_it_can_describe(lens_scenes, model):
    rig, views = lens_scenes["ordinary"]
    cal = calibrate(views, CHESS, LENS_MODELS[model])
    errors = all_errors(rig, cal.rig)
    assert all(errors[k] <= TARGETS[k] for k in TARGETS), errors
    assert cal.report["rms_px"] < 0.33  # the corners' own noise: 0.3 px RMS
    if model == "rational":  # k4..k6 stay near zero: fitted from scratch they once grew to thousands and the focal length
        assert np.abs(cal.rig[0].dist[5:]).max() < 0.5  # drifted 58 % off along the flat valley they open (6 minutes)


def test_rational_model_on_a_wide_lens(lens_scenes):
    rig, views = lens_scenes["wide"]
    cal = calibrate(views, CHESS, LENS_MODELS["rational"])
    errors = all_errors(rig, cal.rig)
    assert all(errors[k] <= TARGETS[k] for k in TARGETS), errors
    assert cal.report["rms_px"] < 0.33  # its coefficients are not pinned one by one (numerator and denominator trade)
