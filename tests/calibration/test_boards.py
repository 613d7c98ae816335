import subprocess
import sys

import cv2
import numpy as np
import pytest

from stereotrack.calibration.boards import (
    Board,
    BoardDetector,
    board_from_dict,
    diagnose,
    flipped,
    load_board,
    png_dpi,
    printable,
    write_png_with_dpi,
)
from stereotrack.camera import Camera, Rig, intrinsics_from_fov, look_at
from stereotrack.errors import StereotrackError
from stereotrack.simulation.boards import random_board_poses, render_board

CHESS = Board("chessboard", (9, 7), 0.03)
CHARUCO = Board("charuco", (7, 5), 0.04, 0.03, "DICT_5X5_100")


def small_rig() -> Rig:
    K = intrinsics_from_fov(640, 480, 60)
    cams = []
    for i, eye in enumerate([(-0.06, 0, 0), (0.06, 0, 0)]):
        R, t = look_at(eye, (0, 0, 1.0))
        cams.append(Camera(f"cam{i}", (640, 480), K, np.array([-0.15, 0.05, 0.001, -0.0005, 0.0]), R, t))
    return Rig(tuple(cams))


@pytest.mark.parametrize(
    "data, field, words",
    [
        ({"type": "circles", "squares": [7, 5], "square": 0.03}, "type", "chessboard, charuco"),
        ({"type": "chessboard", "squares": [7], "square": 0.03}, "squares", "count squares"),
        ({"type": "chessboard", "squares": [7, 5], "square": 30}, "square", "metres"),
        (
            {"type": "charuco", "squares": [7, 5], "square": 0.03, "marker": 0.04, "dictionary": "DICT_5X5_100"},
            "marker",
            "smaller than the square",
        ),
        ({"type": "charuco", "squares": [7, 5], "square": 0.03, "marker": 0.02, "dictionary": "DICT_9X9_1"}, "dictionary", "unknown"),
        ({"type": "charuco", "squares": [12, 10], "square": 0.03, "marker": 0.02, "dictionary": "DICT_4X4_50"}, "dictionary", "needs 60"),
    ],
)
def test_board_yaml_errors_name_field(data, field, words):
    with pytest.raises(StereotrackError) as e:
        board_from_dict(data, "b.yaml")
    msg = str(e.value)
    assert msg.startswith(f"b.yaml: field '{field}'") and words in msg and "\n" not in msg


def test_repo_board_yaml_loads_and_missing_file_is_explained(tmp_path):
    b = load_board("calib/board.yaml")
    assert b.type == "charuco" and b.n_corners == (b.squares[0] - 1) * (b.squares[1] - 1)
    with pytest.raises(StereotrackError, match="board file not found"):
        load_board(tmp_path / "nope.yaml")


def test_object_points_match_opencv_charuco():
    ours = CHARUCO.object_points()
    theirs = CHARUCO.opencv_charuco().getChessboardCorners()
    assert np.allclose(ours, theirs, atol=1e-6)


@pytest.mark.parametrize("board", [CHESS, CHARUCO], ids=["chessboard", "charuco"])
def test_printable_board_true_size_dpi_and_redetected(tmp_path, board):
    page = printable(board, dpi=200)
    px_per_m = 200 / 0.0254
    assert abs(page.px_per_square - board.square * px_per_m) <= 0.5
    path = tmp_path / "b.png"
    write_png_with_dpi(path, page.image, 200)
    assert png_dpi(path) == pytest.approx(200, abs=0.01)
    img = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    assert img.shape == page.image.shape
    # the squares area is board.squares * px_per_square: black top-left square at the margin
    det = BoardDetector(board).detect(img)
    assert det is not None and len(det) == board.n_corners
    spacing = np.linalg.norm(np.diff(det.corners.reshape(board.inner[1], board.inner[0], 2), axis=1), axis=2)
    assert np.allclose(spacing, page.px_per_square, atol=0.5)


def test_board_command_writes_and_checks(tmp_path):
    out = tmp_path / "board.png"
    r = subprocess.run(
        [sys.executable, "-m", "stereotrack", "board", "calib/board.yaml", "--out", str(out), "--dpi", "150"],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr
    assert "self-check: all 24 corners found" in r.stdout
    assert png_dpi(out) == pytest.approx(150, abs=0.02)
    r = subprocess.run(
        [sys.executable, "-m", "stereotrack", "board", "calib/board.yaml", "--out", str(out), "--dpi", "10"], capture_output=True, text=True
    )
    assert r.returncode == 2 and r.stderr.startswith("error: --dpi") and r.stderr.count("\n") == 1


def test_board_command_says_which_paper_and_refuses_one_too_small(tmp_path):
    def board_cli(yaml_path, *extra):
        return subprocess.run(
            [sys.executable, "-m", "stereotrack", "board", str(yaml_path), "--out", str(tmp_path / "b.png"), "--dpi", "150", *extra],
            capture_output=True,
            text=True,
        )

    # the repository's 7x5 ChArUco of 30 mm squares: 240 x 192 mm with its quiet zone and settings, A4 only turned
    r = board_cli("calib/board.yaml", "--paper", "A4")
    assert r.returncode == 0, r.stderr
    assert "paper: fits on A4 in landscape (turn the page: print landscape)" in r.stdout
    # a 10x7 chessboard of 30 mm squares is 300 mm of squares alone: not on A4 (297 mm, less the printer's margins)
    (tmp_path / "big.yaml").write_text("type: chessboard\nsquares: [10, 7]\nsquare: 0.03\n")
    (tmp_path / "b.png").unlink()
    r = board_cli(tmp_path / "big.yaml", "--paper", "A4")
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and not (tmp_path / "b.png").exists()
    assert "needs a page of 330 x 252 mm, which does not fit on A4 (squares of 23 mm or less do); it fits on A3" in r.stderr
    r = board_cli(tmp_path / "big.yaml")  # no paper asked for: written, with a warning that says what it needs
    assert r.returncode == 0 and "paper: fits on A3 (landscape)" in r.stdout
    assert "does not fit on A4 or letter" in r.stderr
    assert board_cli(tmp_path / "big.yaml", "--paper", "A3").returncode == 0


@pytest.fixture(scope="module")
def rendered():
    rig = small_rig()
    rng = np.random.default_rng(3)
    out = {}
    for board in (CHESS, CHARUCO):
        poses = random_board_poses(rig, board, 3, rng)
        out[board.type] = (rig, board, poses, [[render_board(c, board, p, rng) for c in rig.cameras] for p in poses])
    return out


@pytest.mark.parametrize("kind", ["chessboard", "charuco"])
def test_detected_corners_match_rendered_truth(rendered, kind):
    rig, board, poses, views = rendered[kind]
    det = BoardDetector(board)
    errors = []
    for pose, images in zip(poses, views):
        for cam, img in zip(rig.cameras, images):
            d = det.detect(img)
            assert d is not None
            truth, _ = cam.project(pose.to_world(board.object_points()))
            e = np.linalg.norm(d.corners - truth[d.ids], axis=1)
            if kind == "chessboard":  # a chessboard may be numbered from the other end
                e = min(e, np.linalg.norm(flipped(board, d).corners - truth[flipped(board, d).ids], axis=1), key=np.mean)
            errors.append(e)
    errors = np.concatenate(errors)
    assert errors.mean() < 0.12 and errors.max() < 0.5


def test_flipped_twice_is_identity():
    rng = np.random.default_rng(0)
    from stereotrack.calibration.boards import Detection

    d = Detection(np.arange(CHESS.n_corners), rng.normal(size=(CHESS.n_corners, 2)))
    f = flipped(CHESS, d)
    assert np.allclose(f.corners[0], d.corners[-1]) and np.array_equal(flipped(CHESS, f).ids, d.ids)
    assert np.allclose(flipped(CHESS, f).corners, d.corners)


def test_diagnose_names_what_was_found(rendered):
    _, board, _, views = rendered["chessboard"]
    img = views[0][0]
    wrong_count = Board("chessboard", (8, 7), 0.03)
    assert BoardDetector(wrong_count).detect(img) is None
    msg = diagnose(wrong_count, [img])
    assert "found a chessboard with 9x7 squares (8x6 inner corners)" in msg and "squares: [8, 7]" in msg
    msg = diagnose(CHARUCO, [img])
    assert "plain chessboard with 9x7 squares" in msg and "type: chessboard" in msg
    _, _, _, views = rendered["charuco"]
    img = views[0][0]
    assert "5X5 family" in diagnose(Board("charuco", (7, 5), 0.04, 0.03, "DICT_4X4_50"), [img])
    assert "more squares than board.yaml says" in diagnose(Board("charuco", (5, 4), 0.04, 0.03, "DICT_5X5_100"), [img])
    assert "ChArUco board" in diagnose(CHESS, [img])
    assert diagnose(CHESS, [np.full((480, 640), 128, np.uint8)]) is None
