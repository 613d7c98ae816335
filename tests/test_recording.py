import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import yaml

from stereotrack.camera import save_rig
from stereotrack.errors import StereotrackError
from stereotrack.recording import RecordingWriter, open_recording, read_truth, read_truth_and_views
from stereotrack.simulation.spec import RigSpec

SIZE = (160, 120)


def frame_images(index: int, n_cameras: int = 2) -> list[np.ndarray]:
    """Deterministic, hard-to-compress test images for frame ``index``."""
    rng = np.random.default_rng(index)
    return [rng.integers(0, 256, (SIZE[1], SIZE[0], 3), dtype=np.uint8) for _ in range(n_cameras)]


def write_recording(folder: Path, n: int, codec: str = "ffv1", rig=None, n_cameras: int = 2) -> list[list[float]]:
    stamps = []
    names = [f"cam{i}" for i in range(n_cameras)]
    with RecordingWriter(folder, names, SIZE, 30.0, rig=rig, codec=codec, source="test") as w:
        for i in range(n):
            ts = [i / 30 + 0.0004 * c for c in range(n_cameras)]
            w.write(frame_images(i, n_cameras), ts)
            stamps.append(ts)
    return stamps


def small_rig(n_cameras=2, size=SIZE):
    return RigSpec(cameras=n_cameras, width=size[0], height=size[1]).build()


def test_ffv1_round_trip_is_lossless(tmp_path):
    folder = tmp_path / "rec"
    stamps = write_recording(folder, 6, rig=small_rig())
    rec = open_recording(folder)
    assert rec.n_frames == 6 and rec.fps == 30.0 and rec.camera_names == ("cam0", "cam1") and rec.image_size == SIZE
    assert rec.rig is not None and rec.rig.names == ["cam0", "cam1"]
    assert sorted(p.name for p in folder.iterdir()) == ["calib.yaml", "cam0.avi", "cam1.avi", "frames.csv", "meta.yaml"]
    pairs = list(rec.frames())
    assert [p.index for p in pairs] == list(range(6))
    for pair in pairs:
        assert all(np.array_equal(a, b) for a, b in zip(pair.images, frame_images(pair.index)))
        assert pair.timestamps == pytest.approx(stamps[pair.index], abs=1e-6)
    assert np.allclose(rec.timestamps, stamps, atol=1e-6)
    # Reading from the middle.
    tail = list(rec.frames(start=4))
    assert [p.index for p in tail] == [4, 5] and np.array_equal(tail[0].images[1], frame_images(4)[1])


def test_mjpg_option_and_three_cameras(tmp_path):
    folder = tmp_path / "rec"
    write_recording(folder, 4, codec="mjpg", rig=small_rig(3), n_cameras=3)
    meta = yaml.safe_load((folder / "meta.yaml").read_text())
    assert meta["videos"] == {"cam0": "cam0.avi", "cam1": "cam1.avi", "cam2": "cam2.avi"}
    rec = open_recording(folder)
    pairs = list(rec.frames())
    assert len(pairs) == 4 and len(pairs[0].images) == 3
    for pair in pairs:  # lossy but close: JPEG on random noise still keeps the mean
        for got, want in zip(pair.images, frame_images(pair.index, 3)):
            assert got.shape == want.shape
            assert abs(got.astype(float).mean() - want.astype(float).mean()) < 3
            assert not np.array_equal(got, want)


def test_truth_with_extra_column(tmp_path):
    folder = tmp_path / "rec"
    with RecordingWriter(folder, ["cam0", "cam1"], SIZE, 30.0, source="test", truth_fields=("visible",)) as w:
        w.write(frame_images(0), [0.0, 0.0])
        w.write_truth(0, [(0, 0.1, 1.2, -0.05, 2), (3, -0.2, 2.0, 0.3, 1)])
        with pytest.raises(ValueError, match="visible"):
            w.write_truth(0, [(0, 0.1, 1.2, -0.05)])
    lines = (folder / "truth.csv").read_text().splitlines()
    assert lines[0] == "frame,object_id,x,y,z,visible" and lines[2] == "0,3,-0.200000,2.000000,0.300000,1"
    assert np.allclose(read_truth(folder / "truth.csv"), [[0, 0, 0.1, 1.2, -0.05], [0, 3, -0.2, 2.0, 0.3]])
    assert read_truth_and_views(folder / "truth.csv")[1].tolist() == [2, 1]
    (folder / "truth.csv").write_text("frame,object_id,x,y,z\n0,0,0.1,1.2,-0.05\n")  # an earlier version's file
    assert read_truth_and_views(folder / "truth.csv")[1] is None
    (folder / "truth.csv").write_text("frame,object_id,x,y,z,visible\n0,0,0.1,1.2,-0.05,-1\n")
    with pytest.raises(StereotrackError, match="line 2: 'visible' must be a whole number >= 0"):
        read_truth_and_views(folder / "truth.csv")
    # `clear` (the cameras that show a quarter of the ball or more), after `visible`, is the count read
    (folder / "truth.csv").write_text("frame,object_id,x,y,z,visible,clear\n0,0,0.1,1.2,-0.05,2,1\n0,1,0.1,1.2,-0.05,2,2\n")
    assert read_truth_and_views(folder / "truth.csv")[1].tolist() == [1, 2]
    (folder / "truth.csv").write_text("frame,object_id,x,y,z,visible,clear\n0,0,0.1,1.2,-0.05,2,0.5\n")
    with pytest.raises(StereotrackError, match="line 2: 'clear' must be a whole number >= 0"):
        read_truth_and_views(folder / "truth.csv")


WRITER = """
import sys, numpy as np
sys.path.insert(0, {repo!r})
from stereotrack.recording import RecordingWriter
w = RecordingWriter(sys.argv[1], ["cam0", "cam1"], (160, 120), 30.0, codec="ffv1", source="test")
i = 0
while True:
    rng = np.random.default_rng(i)
    w.write([rng.integers(0, 256, (120, 160, 3), dtype=np.uint8) for _ in range(2)], [i / 30, i / 30 + 0.0004])
    print(i, flush=True)
    i += 1
"""


def test_writer_killed_mid_recording_is_readable_up_to_its_last_complete_pair(tmp_path, capfd):
    folder = tmp_path / "rec"
    repo = str(Path(__file__).resolve().parent.parent)
    proc = subprocess.Popen([sys.executable, "-c", WRITER.format(repo=repo), str(folder)], stdout=subprocess.PIPE, text=True)
    written = -1
    deadline = time.monotonic() + 60
    while written < 60 and time.monotonic() < deadline:
        written = int(proc.stdout.readline())
    os.kill(proc.pid, signal.SIGKILL)  # no chance to close the videos or files
    proc.wait()
    proc.stdout.close()
    assert proc.returncode == -signal.SIGKILL and written >= 60
    rows = len((folder / "frames.csv").read_text().splitlines()) - 1
    assert rows >= written + 1  # every written pair's row reached the disk at once
    rec = open_recording(folder)
    pairs = list(rec.frames())
    # The videos may hold fewer frames than frames.csv: the muxer buffers the last
    # few hundred kB (about 10 small test frames) that a SIGKILL loses. Every pair read is complete and exact.
    assert written + 1 - 20 <= len(pairs) <= rows
    for pair in pairs:
        assert all(np.array_equal(a, b) for a, b in zip(pair.images, frame_images(pair.index)))
        assert pair.timestamps == pytest.approx((pair.index / 30, pair.index / 30 + 0.0004), abs=1e-6)
    if len(pairs) < rows:
        assert "interrupted recording" in capfd.readouterr().err


def test_reader_warns_and_stops_when_frames_csv_and_videos_disagree(tmp_path, capfd):
    folder = tmp_path / "rec"
    write_recording(folder, 5)
    with open(folder / "frames.csv", "a") as f:  # rows for pairs the videos never got, and a half-written line
        f.write("5,0.166667,0.167067\n6,0.200000,0.200400\n7,0.2333")
    capfd.readouterr()
    rec = open_recording(folder)
    pairs = list(rec.frames())
    assert len(pairs) == 5 and np.array_equal(pairs[-1].images[0], frame_images(4)[0])
    err = capfd.readouterr().err
    assert "warning:" in err and "interrupted recording" in err
    # The other way round: frames.csv cut short (its last row lost) -> only the pairs it lists.
    lines = (folder / "frames.csv").read_text().splitlines()[:4]
    (folder / "frames.csv").write_text("\n".join(lines) + "\n")
    rec = open_recording(folder)
    assert rec.n_frames == 3 and len(list(rec.frames())) == 3
    assert "interrupted recording" in capfd.readouterr().err


def test_reader_refuses_a_missing_video(tmp_path):
    folder = tmp_path / "rec"
    write_recording(folder, 2)
    (folder / "cam1.avi").unlink()
    with pytest.raises(StereotrackError, match=r"cam1\.avi: video for camera 'cam1' is missing"):
        open_recording(folder)


def test_reader_refuses_a_calibration_of_another_image_size(tmp_path):
    folder = tmp_path / "rec"
    write_recording(folder, 2, rig=small_rig())
    save_rig(small_rig(size=(640, 480)), folder / "calib.yaml")
    with pytest.raises(StereotrackError, match="calibrated for 640x480 but the recording's videos are 160x120"):
        open_recording(folder)
    other = tmp_path / "other.yaml"  # the same check for --calib FILE
    save_rig(small_rig(size=(320, 240)), other)
    with pytest.raises(StereotrackError, match="calibrated for 320x240"):
        open_recording(folder, calib=other)
    save_rig(small_rig(3), other)
    with pytest.raises(StereotrackError, match="has 3 cameras but the recording has 2"):
        open_recording(folder, calib=other)


@pytest.mark.parametrize("name", ["meta.yaml", "calib.yaml"])
def test_reader_refuses_unreadable_yaml(tmp_path, name):
    folder = tmp_path / "rec"
    write_recording(folder, 2, rig=small_rig())
    (folder / name).write_text("cameras: [cam0, cam1\nvideos: {")
    with pytest.raises(StereotrackError, match=rf"{name}: not valid YAML"):
        open_recording(folder)


def test_reader_refuses_what_is_not_a_recording(tmp_path):
    with pytest.raises(StereotrackError, match="recording folder not found"):
        open_recording(tmp_path / "nothing")
    (tmp_path / "empty").mkdir()
    with pytest.raises(StereotrackError, match="meta.yaml is missing"):
        open_recording(tmp_path / "empty")


def test_writer_refuses_to_overwrite_and_wrong_frame_sizes(tmp_path):
    folder = tmp_path / "rec"
    write_recording(folder, 1)
    with pytest.raises(StereotrackError, match="folder exists and is not empty"):
        RecordingWriter(folder, ["cam0", "cam1"], SIZE, 30.0)
    with RecordingWriter(folder, ["cam0", "cam1"], SIZE, 30.0, overwrite=True) as w:
        with pytest.raises(StereotrackError, match="does not match the recording's 160x120"):
            w.write([np.zeros((240, 320, 3), np.uint8)] * 2, [0.0, 0.0])
    with pytest.raises(StereotrackError, match="unknown codec"):
        RecordingWriter(tmp_path / "x", ["cam0", "cam1"], SIZE, 30.0, codec="h264")


def test_error_is_one_line_from_the_command_line(tmp_path):
    folder = tmp_path / "rec"
    write_recording(folder, 2)
    (folder / "meta.yaml").write_text("cameras: [cam0\n")
    out = subprocess.run(
        [sys.executable, "-m", "stereotrack", "track", str(folder)],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        env=dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parent.parent)),
    )
    assert out.returncode == 2
    assert out.stderr.strip().count("\n") == 0 and out.stderr.startswith("error: ") and "not valid YAML" in out.stderr
