"""See what calibration saw: the .rrd read back with rerun's own reader, the annotated PNGs, live status lines.

A three-camera rig renders 12 chessboard views; `stereotrack calibrate` runs
as a subprocess with --rrd and --save-views, and what it wrote is checked
against the calibration it saved.
"""

import subprocess
import sys

import cv2
import numpy as np
import pytest
import yaml

from stereotrack.calibration import calibrate, views_from_frames
from stereotrack.calibration.boards import Board, save_board
from stereotrack.camera import load_rig
from stereotrack.frames import FramePair
from stereotrack.simulation.boards import calibration_rig, poses_seen_by_pairs, render_views, write_image_folders
from stereotrack.sinks.viewer import VizOutputs, rerun_executable
from stereotrack.sinks.viewer.calibration import CalibrationViewer

BOARD = Board("chessboard", (9, 7), 0.03)
RERUN = rerun_executable()


def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "stereotrack", *map(str, args)], capture_output=True, text=True, timeout=300)


def read_rrd(path):
    """Every logged row by entity path: {'view': step or None (static), 'Archetype:field': value}."""
    import rerun.chunk

    rows: dict[str, list[dict]] = {}
    for chunk in rerun.chunk.RrdReader(path).stream():
        batch = chunk.to_record_batch()
        cols = {name: batch.column(name).to_pylist() for name in batch.schema.names if not name.startswith("rerun.")}
        for i in range(batch.num_rows):
            row = {name: values[i] for name, values in cols.items()}
            row.setdefault("view", None)
            rows.setdefault(chunk.entity_path.lstrip("/"), []).append(row)
    return rows


def at(rows, component, view=None):
    found = [r[component] for r in rows if r.get(component) is not None and r["view"] == view]
    assert found, f"{component} not logged at view {view}"
    return found[-1]


@pytest.fixture(scope="module")
def three_cameras(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("calib")
    rng = np.random.default_rng(31)
    rig = calibration_rig(3, rng)
    images = render_views(rig, BOARD, poses_seen_by_pairs(rig, BOARD, 12, rng, min_tilt_deg=15.0, max_tilt_deg=45.0), rng)
    dirs = write_image_folders(tmp / "shots", rig, images)
    save_board(BOARD, tmp / "board.yaml")
    r = run_cli(
        "calibrate", "--board", tmp / "board.yaml", "--images", *dirs, "--out", tmp / "rig.yaml",
        "--rrd", tmp / "calib.rrd", "--save-views", tmp / "seen", "--no-progress",
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    report = yaml.safe_load((tmp / "rig.report.yaml").read_text())
    return tmp, rig, dirs, r, report


def test_rrd_verifies_and_holds_every_view_camera_and_board(three_cameras):
    tmp, rig, dirs, r, report = three_cameras
    path = tmp / "calib.rrd"
    assert f"rerun {path}" in r.stdout
    out = subprocess.run([RERUN, "rrd", "verify", str(path)], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    rows = read_rrd(path)
    views = list(report["views"]["per_view_rms_px"])
    expected = {"report", *(f"world/boards/{v}" for v in views)}
    for cam in rig.names:
        expected |= {f"views/{cam}/{e}" for e in ("image", "detected", "reprojected", "residuals")}
        expected |= {f"coverage/{cam}", f"world/cameras/{cam}", f"stats/view_rms_px/{cam}"}
    assert expected <= set(rows), sorted(expected - set(rows))
    assert "verdict:" in at(rows["report"], "TextDocument:text")[0]


def test_rrd_corners_residuals_and_board_poses_agree_with_the_saved_calibration(three_cameras):
    tmp, rig, dirs, r, report = three_cameras
    rows = read_rrd(tmp / "calib.rrd")
    est = load_rig(tmp / "rig.yaml")
    per_view = report["views"]["per_view_rms_px"]
    checked = 0
    for step, name in enumerate(per_view):
        R = np.array(at(rows[f"world/boards/{name}"], "Transform3D:mat3x3")).reshape(3, 3).T  # rerun stores column-major
        t = np.array(at(rows[f"world/boards/{name}"], "Transform3D:translation"))
        corners = BOARD.object_points() @ R.T + t  # the fitted board pose, in the world of the saved calibration
        for cam in est.cameras:
            if cam.name not in per_view[name]:
                continue
            detected = np.array(at(rows[f"views/{cam.name}/detected"], "Points2D:positions", step))
            fitted = np.array(at(rows[f"views/{cam.name}/reprojected"], "Points2D:positions", step))
            ids = np.array(at(rows[f"views/{cam.name}/detected"], "Points2D:class_ids", step))
            residual = np.array(at(rows[f"views/{cam.name}/reprojected"], "residual_px", step))
            uv, _ = cam.project(corners[ids])
            assert np.abs(uv - fitted).max() < 0.01  # the 3D board projects onto the fitted corners
            assert np.allclose(residual, np.linalg.norm(fitted - detected, axis=1), atol=1e-4)
            rms = at(rows[f"stats/view_rms_px/{cam.name}"], "Scalars:scalars", step)
            assert rms[0] == pytest.approx(per_view[name][cam.name], abs=1e-3)
            checked += 1
    assert checked == sum(len([k for k in v if not k.startswith("stereo")]) for v in per_view.values())
    coverage = np.array(at(rows["coverage/cam0"], "Image:buffer")[0], dtype=np.uint8)
    assert coverage.size == 640 * 480 * 3


def test_annotated_pngs_show_each_view_and_the_coverage(three_cameras):
    tmp, rig, dirs, r, report = three_cameras
    seen = tmp / "seen"
    per_view = report["views"]["per_view_rms_px"]
    expected = {f"{v}_{c}.png" for v, errs in per_view.items() for c in errs if not c.startswith("stereo")}
    expected |= {f"coverage_{c}.png" for c in rig.names}
    assert {p.name for p in seen.iterdir()} == expected
    assert f"wrote {len(expected)} annotated images" in r.stdout
    name = next(iter(per_view))
    original = cv2.imread(str(dirs[0] / f"{name}.png"))
    drawn = cv2.imread(str(seen / f"{name}_cam0.png"))
    assert drawn.shape == original.shape
    changed = np.any(drawn != original, axis=2)
    assert changed[60:].sum() > 48 * 10  # marks at every corner, below the caption
    assert changed[:30].mean() > 0.5  # the caption band
    for path in dirs:  # the inputs are untouched and no output went next to them
        assert sorted(p.name for p in path.iterdir()) == sorted(f"{v}.png" for v in [f"view{i:03d}" for i in range(12)])


def test_save_views_refuses_an_input_folder_and_a_bad_rrd_name(three_cameras):
    tmp, rig, dirs, r, report = three_cameras
    base = ["calibrate", "--board", tmp / "board.yaml", "--images", *dirs, "--out", tmp / "again.yaml", "--no-progress"]
    for extra, words in (
        (["--save-views", dirs[1]], "that folder holds input images"),
        (["--rrd", tmp / "calib.txt"], "--rrd must be a .rrd file"),
        (["--save-views", tmp / "rig.yaml"], "is a file; give a folder"),
    ):
        out = run_cli(*base, *extra)
        assert out.returncode == 2 and out.stderr.startswith("error: ") and out.stderr.count("\n") == 1, out.stderr
        assert words in out.stderr
    assert not (tmp / "again.yaml").exists()


def test_outputs_that_are_not_ours_are_refused_before_the_fit(three_cameras):
    """--rrd over a file that is not a rerun recording, --save-views over a same-named file that is not a PNG:
    one line, before any work, and the user's files stay as they were."""
    tmp, rig, dirs, r, report = three_cameras
    notes = tmp / "notes.rrd"
    notes.write_text("a user's notes\n")
    clash = tmp / "clash"
    clash.mkdir()
    (clash / "coverage_cam0.png").write_text("not an image\n")
    base = ["calibrate", "--board", tmp / "board.yaml", "--images", *dirs, "--out", tmp / "again.yaml", "--no-progress"]
    for extra, words in (
        (["--rrd", notes], "exists and is not a rerun recording"),
        (["--rrd", dirs[0] / "view000.png.rrd", "--save-views", clash], "exists and is not a PNG image"),
    ):
        out = run_cli(*base, *extra)
        assert out.returncode == 2 and out.stderr.startswith("error: ") and out.stderr.count("\n") == 1, out.stderr
        assert words in out.stderr
    assert notes.read_text() == "a user's notes\n" and (clash / "coverage_cam0.png").read_text() == "not an image\n"
    assert sorted(p.name for p in clash.iterdir()) == ["coverage_cam0.png"]
    assert not (tmp / "again.yaml").exists() and not (dirs[0] / "view000.png.rrd").exists()


def test_a_failed_calibration_keeps_the_previous_rrd(tmp_path, three_cameras):
    """The viewer's .rrd is written under a temporary name: a run that fails leaves the earlier file as it was."""
    tmp, rig, dirs, r, report = three_cameras
    path = tmp_path / "calib.rrd"
    previous = (tmp / "calib.rrd").read_bytes()
    path.write_bytes(previous)
    with pytest.raises(RuntimeError, match="the fit failed"):
        with CalibrationViewer(VizOutputs(rrd=path), BOARD, rig.names):
            raise RuntimeError("the fit failed")
    assert path.read_bytes() == previous and sorted(p.name for p in tmp_path.iterdir()) == ["calib.rrd"]


def test_live_viewer_logs_each_view_as_it_is_taken(tmp_path):
    rng = np.random.default_rng(32)
    rig = calibration_rig(2, rng)
    images = render_views(rig, BOARD, poses_seen_by_pairs(rig, BOARD, 8, rng), rng)
    path = tmp_path / "live.rrd"
    logged = []
    with CalibrationViewer(VizOutputs(rrd=path), BOARD, rig.names) as viewer:

        def on_view(views):
            viewer.log_views(views)
            logged.append(views.n_views)

        pairs = (FramePair(i, v, (i / 30, i / 30)) for i, v in enumerate(images))
        views = views_from_frames(BOARD, pairs, rig.names, min_new=0.0, progress=False, keep_images=True, on_view=on_view)
        viewer.log_fit(calibrate(views, BOARD))
    assert logged == list(range(1, 9))  # one call per view taken, with the views so far
    rows = read_rrd(path)
    steps = sorted({r["view"] for r in rows["views/cam1/image"]})
    assert steps == list(range(8))
    assert len(at(rows["views/cam1/reprojected"], "Points2D:positions", 7)) == BOARD.n_corners
