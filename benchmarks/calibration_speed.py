"""Calibration speed: a full `stereotrack calibrate` from 20 image pairs, and from 3 cameras x 24 views, end to end.

    .venv/bin/python benchmarks/calibration_speed.py

The targets: under 30 s for 20 pairs, and for 3 cameras with 24 views, on the
2-core reference machine. Renders 20 board pairs (640x480, chessboard and
ChArUco) for a known rig, and 24 views for a 3-camera rig
(``calibration_rig``), into PNG folders, then times the real command as a
subprocess (reading the images, detecting the board, calibrating with the
joint refinement, writing the YAML and report), plus the two stages
in-process so their shares can be compared on a noisy machine. Also times
OpenCV's 13 real stereo pairs from tests/data.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from stereotrack.calibration.boards import Board, save_board  # noqa: E402
from stereotrack.calibration.solve import calibrate  # noqa: E402
from stereotrack.calibration.views import views_from_images  # noqa: E402
from stereotrack.camera import Camera, Rig, intrinsics_from_fov, look_at  # noqa: E402
from stereotrack.simulation.boards import (  # noqa: E402
    calibration_rig,
    poses_seen_by_pairs,
    random_board_poses,
    render_views,
    write_image_folders,
)


def rig() -> Rig:
    K = intrinsics_from_fov(640, 480, 62)
    cams = []
    for i, eye in enumerate([(-0.06, 0, 0), (0.06, 0, 0)]):
        R, t = look_at(eye, (0, 0, 1.0))
        cams.append(Camera(f"cam{i}", (640, 480), K, np.array([-0.12, 0.04, 0.0008, -0.0005, 0.0]), R, t))
    return Rig(tuple(cams))


def time_command(board_yaml: Path, sources: list[str], out: Path) -> float:
    start = time.perf_counter()
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "stereotrack",
            "calibrate",
            "--board",
            str(board_yaml),
            "--images",
            *sources,
            "--out",
            str(out),
            "--no-progress",
        ],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    elapsed = time.perf_counter() - start
    if r.returncode != 0:
        raise SystemExit(r.stderr)
    return elapsed


def main() -> None:
    rows = []
    boards = [Board("chessboard", (9, 7), 0.03), Board("charuco", (7, 5), 0.04, 0.03, "DICT_5X5_100")]
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        truth = rig()
        for k, board in enumerate(boards):
            rng = np.random.default_rng(k)
            views = render_views(truth, board, random_board_poses(truth, board, 20, rng), rng)
            dirs = [str(d) for d in write_image_folders(tmp / board.type, truth, views)]
            save_board(board, tmp / f"{board.type}.yaml")
            total = time_command(tmp / f"{board.type}.yaml", dirs, tmp / f"{board.type}-rig.yaml")
            t0 = time.perf_counter()
            vs = views_from_images(board, dirs, progress=False)
            t1 = time.perf_counter()
            calibrate(vs, board)
            t2 = time.perf_counter()
            rows.append((f"rendered {board.type}, 20 pairs", total, t1 - t0, t2 - t1))
        rng = np.random.default_rng(200)
        three = calibration_rig(3, rng)
        board = boards[0]
        views = render_views(three, board, poses_seen_by_pairs(three, board, 24, rng, min_tilt_deg=15.0, max_tilt_deg=45.0), rng)
        dirs = [str(d) for d in write_image_folders(tmp / "three", three, views)]
        total = time_command(tmp / f"{board.type}.yaml", dirs, tmp / "three-rig.yaml")
        t0 = time.perf_counter()
        vs = views_from_images(board, dirs, progress=False)
        t1 = time.perf_counter()
        calibrate(vs, board)
        t2 = time.perf_counter()
        rows.append(("rendered chessboard, 3 cameras x 24 views", total, t1 - t0, t2 - t1))
        real = ROOT / "tests" / "data" / "opencv-stereo-chessboard"
        board = Board("chessboard", (10, 7), 0.025)
        save_board(board, tmp / "real.yaml")
        sources = [str(real / "left*.jpg"), str(real / "right*.jpg")]
        total = time_command(tmp / "real.yaml", sources, tmp / "real-rig.yaml")
        t0 = time.perf_counter()
        vs = views_from_images(board, sources, progress=False)
        t1 = time.perf_counter()
        calibrate(vs, board)
        t2 = time.perf_counter()
        rows.append(("OpenCV real chessboard, 13 pairs", total, t1 - t0, t2 - t1))
    print("| views | `stereotrack calibrate`, s | detection, s | calibration + report, s | calibration / detection |")
    print("|---|---:|---:|---:|---:|")
    for name, total, det, cal in rows:
        print(f"| {name} | {total:.2f} | {det:.2f} | {cal:.2f} | {cal / det:.2f} |")


if __name__ == "__main__":
    main()
