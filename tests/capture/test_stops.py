"""Stopping capture and tracking, with real processes and real signals (issue 15).

SIGKILL at random moments (seeded), Ctrl-C/SIGTERM of video-file cameras, files
of uneven length, signals to commands started in the background by a script
(SIGINT inherited ignored) and signals in a command's first moments. The long
versions (20 of each, 60 s soaks) are in benchmarks/recording_soak.py.
"""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import cv2
import numpy as np
import pytest

from stereotrack.recording import open_recording

ROOT = Path(__file__).resolve().parents[2]
SIM = ["--width", "320", "--height", "240", "--fps", "30"]
# A file camera on a machine loaded several times over can get no CPU for the default 2 s stall timeout
# and end the recording as if unplugged; these tests are about stopping, so give it longer.
PATIENT = ["--stall-timeout", "10"]


_STARTED: list[subprocess.Popen] = []


def start(*args, **kwargs) -> subprocess.Popen:
    """``subprocess.Popen``, killed after the test if it still runs then (a failed wait left a live run compiling at full CPU)."""
    proc = subprocess.Popen(*args, **kwargs)
    _STARTED.append(proc)
    return proc


@pytest.fixture(autouse=True)
def _no_process_left():
    yield
    while _STARTED:
        proc = _STARTED.pop()
        if proc.poll() is None:
            proc.kill()
            proc.communicate(timeout=30)


def stereotrack(*args) -> list[str]:
    return [sys.executable, "-m", "stereotrack", *args]


def frames_csv_rows(folder: Path) -> int:
    """Complete rows in frames.csv (a line cut by a kill does not count)."""
    lines = (folder / "frames.csv").read_text().split("\n")
    return sum(1 for line in lines[1:-1] if line.count(",") == lines[0].count(","))


def decodable(video: Path) -> int:
    """Frames of a video that decode, counted independently of the reader: JPEG packets by cv2.imdecode,
    other codecs by OpenCV's decoder."""
    cap = cv2.VideoCapture(str(video))
    jpeg = int(cap.get(cv2.CAP_PROP_FOURCC)).to_bytes(4, "little").upper() == b"MJPG" and cap.set(cv2.CAP_PROP_FORMAT, -1)
    n = 0
    while True:
        ok, data = cap.read()
        if not ok or (jpeg and cv2.imdecode(data.reshape(-1), cv2.IMREAD_COLOR) is None):
            break
        n += 1
    cap.release()
    return n


def wait_for_rows(proc: subprocess.Popen, folder: Path, rows: int, timeout: float = 60.0) -> None:
    deadline = time.monotonic() + timeout
    while True:
        try:
            if frames_csv_rows(folder) >= rows:
                return
        except FileNotFoundError:
            pass
        assert proc.poll() is None, proc.communicate()[1]
        assert time.monotonic() < deadline, "the recording did not start"
        time.sleep(0.02)


def wait_for_handlers(proc: subprocess.Popen, timeout: float = 30.0) -> None:
    """Until the process catches SIGTERM: stereotrack's handlers are in place (the package's first lines).
    Before that the interpreter itself is starting, and Python's own defaults apply."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and proc.poll() is None:
        for line in Path(f"/proc/{proc.pid}/status").read_text().splitlines():
            if line.startswith("SigCgt:") and int(line.split()[1], 16) >> (signal.SIGTERM - 1) & 1:
                return
        time.sleep(0.002)


def in_background() -> None:
    """In a child: SIGINT ignored, as a non-interactive shell starts `cmd &`."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def at_default() -> None:
    signal.signal(signal.SIGINT, signal.SIG_DFL)


# --------------------------------------------------------------------------- SIGKILL


def test_sigkill_at_random_moments_leaves_every_row_with_its_frames(tmp_path):
    """Rows in frames.csv never outrun the videos: each row is written after its frames are in the files."""
    rng = np.random.default_rng(15)
    delays = rng.uniform(0.0, 1.2, 8)
    for k, delay in enumerate(delays):
        out = tmp_path / f"k{k}"
        proc = start(
            stereotrack("record", "--cam0", "sim:dots", "--cam1", "sim:dots", *SIM, "--out", str(out)),
            cwd=ROOT,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )
        wait_for_rows(proc, out, 1)
        time.sleep(delay)
        proc.kill()
        proc.communicate(timeout=30)
        rows = frames_csv_rows(out)
        rec = open_recording(out)  # every folder opens
        counts = [decodable(p) for p in rec.video_paths]
        assert rows <= min(counts) <= rows + 1, (k, delay, rows, counts)  # at most the frame in flight has no row yet
        assert rec.n_frames == rows and len(list(rec.frames())) == rows


# --------------------------------------------------------------------------- video files as cameras


def write_video(path: Path, n: int, size=(320, 240), fps=30.0) -> None:
    """An FFV1 .mkv, whose frame-threaded decoder is the one that aborted when released mid-grab."""
    w = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"FFV1"), fps, size)
    rng = np.random.default_rng(n)
    base = rng.integers(0, 256, (size[1], size[0], 3), dtype=np.uint8)
    for i in range(n):
        img = base.copy()
        cv2.putText(img, str(i), (10, 60), cv2.FONT_HERSHEY_SIMPLEX, 2, (255, 255, 255), 3)
        w.write(img)
    w.release()


@pytest.fixture(scope="module")
def clips(tmp_path_factory):
    d = tmp_path_factory.mktemp("clips")
    write_video(d / "a.mkv", 90)
    write_video(d / "b.mkv", 90)
    write_video(d / "short.mkv", 40)
    write_video(d / "small.mkv", 20, size=(160, 120))
    return d


def check_complete(out: Path, stderr: str) -> None:
    assert "Assertion" not in stderr and "Traceback" not in stderr, stderr
    rec = open_recording(out)
    rows = frames_csv_rows(out)
    assert rows > 0 and all(decodable(p) == rows for p in rec.video_paths), (rows, [decodable(p) for p in rec.video_paths])


def test_video_file_cameras_stop_cleanly_on_ctrl_c_and_sigterm(tmp_path, clips):
    rng = np.random.default_rng(7)
    for k, sig in enumerate([signal.SIGINT, signal.SIGTERM] * 2):
        out = tmp_path / f"s{k}"
        proc = start(
            stereotrack("record", "--cam0", str(clips / "a.mkv"), "--cam1", str(clips / "b.mkv"), *PATIENT, "--out", str(out)),
            cwd=ROOT,
            stderr=subprocess.PIPE,
            text=True,
            preexec_fn=at_default,
        )
        wait_for_rows(proc, out, 1)
        time.sleep(rng.uniform(0.0, 1.0))
        proc.send_signal(sig)
        _, stderr = proc.communicate(timeout=30)
        assert proc.returncode == 0 and f"stopped by {sig.name}" in stderr, stderr
        check_complete(out, stderr)


def test_video_files_of_uneven_length_end_the_recording_cleanly(tmp_path, clips):
    for k in range(2):
        out = tmp_path / f"u{k}"
        cams = [str(clips / "a.mkv"), str(clips / "short.mkv")][:: 1 if k == 0 else -1]
        res = subprocess.run(
            stereotrack("record", "--cam0", cams[0], "--cam1", cams[1], *PATIENT, "--out", str(out)),
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=60,
        )
        assert res.returncode == 0, res.stderr
        check_complete(out, res.stderr)
        assert frames_csv_rows(out) <= 40


def test_video_files_keep_their_timing_by_skipping_late_frames(tmp_path, clips):
    """Two copies of one clip played together: every pair holds the same frame of both, however busy the
    machine (a late camera skips frames instead of drifting behind the other). The deterministic version
    (threads starved on purpose) is test_sources.py's test_video_files_pair_only_frames_of_one_index..."""
    out = tmp_path / "t"
    res = subprocess.run(
        stereotrack("record", "--cam0", str(clips / "a.mkv"), "--cam1", str(clips / "b.mkv"), *PATIENT, "--out", str(out)),
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert res.returncode == 0, res.stderr
    rec = open_recording(out)
    # of 90: nearly all on a quiet machine; a starved one skips frames (lost, as a webcam's would be), never drifts
    assert rec.n_frames >= 1
    # Both files of a source share their start: a pair's frames were due at the same moment, frame k at k / fps.
    t = rec.timestamps
    assert np.array_equal(t[:, 0], t[:, 1]), t
    k = (t[:, 0] - t[0, 0]) * 30.0
    assert np.allclose(k, np.round(k), atol=1e-3) and np.all(np.diff(np.round(k)) >= 1), k
    assert all(np.array_equal(*pair.images) for pair in rec.frames())  # a.mkv and b.mkv are the same clip


def test_video_files_of_different_sizes_are_refused_in_one_line(tmp_path, clips):
    res = subprocess.run(
        stereotrack("record", "--cam0", str(clips / "a.mkv"), "--cam1", str(clips / "small.mkv"), "--out", str(tmp_path / "x")),
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert res.returncode == 2 and res.stderr.count("\n") == 1 and "delivers 160x120 frames but cam0" in res.stderr, res.stderr
    assert not (tmp_path / "x").exists()


# --------------------------------------------------------------------------- signals: background and first moments


def test_commands_started_in_the_background_stop_on_sigint(tmp_path, clips):
    """A script's `cmd &` leaves SIGINT ignored; the commands install their handlers anyway."""
    rec = tmp_path / "rec"
    proc = start(
        stereotrack("record", "--cam0", "sim:dots", "--cam1", "sim:dots", *SIM, "--out", str(rec)),
        cwd=ROOT,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=in_background,
    )
    wait_for_rows(proc, rec, 10)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 0 and "stopped by SIGINT" in err, err
    live = tmp_path / "live"
    proc = start(
        stereotrack("live", "--cam0", "sim:pendulum4", "--cam1", "sim:pendulum4", *SIM, "--quiet", "--record", str(live)),
        cwd=ROOT,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=in_background,
    )
    wait_for_rows(proc, live, 90)  # three seconds at 30 fps, so the paced track below is still running when signalled
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 0 and "stopped by SIGINT" in err and "Traceback" not in err, err
    assert open_recording(live).n_frames == frames_csv_rows(live)
    proc = start(
        stereotrack("track", str(live), "--realtime", "--all-frames", "--out", str(tmp_path / "t.csv")),
        cwd=ROOT,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=in_background,
    )
    # Wait for the first progress line: tracking has started, at the recording's pace. A notice may come first
    # (loading the cached kernels takes over a second on a busy machine, and the compile notice says so).
    before = ""
    while not (line := proc.stderr.readline()).startswith("tracking") and line:
        before += line
    assert line.startswith("tracking"), before + line + proc.communicate()[1]
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 130 and "interrupted by SIGINT" in err and "Traceback" not in err, err


@pytest.mark.parametrize("command", ["record", "live", "track"])
def test_a_signal_in_the_first_moments_stops_cleanly(tmp_path, clips, command):
    """Signals at random moments of the first second (imports, opening cameras, compiling): no traceback,
    no half-written output, an exit status that says what happened."""
    source = tmp_path / "source"
    if command == "track":
        subprocess.run(
            stereotrack("synth", "pendulum4", "--frames", "30", "--width", "320", "--height", "240", "--out", str(source)),
            cwd=ROOT,
            check=True,
            capture_output=True,
            timeout=120,
        )
    rng = np.random.default_rng({"record": 1, "live": 2, "track": 3}[command])
    for k, delay in enumerate(rng.uniform(0.0, 1.2, 4)):
        out = tmp_path / f"{command}{k}"
        args = {
            "record": ["record", "--cam0", "sim:dots", "--cam1", "sim:dots", *SIM, "--out", str(out)],
            "live": ["live", "--cam0", "sim:pendulum4", "--cam1", "sim:pendulum4", *SIM, "--quiet", "--record", str(out)],
            "track": ["track", str(source), "--out", str(tmp_path / f"t{k}.csv")],
        }[command]
        sig = (signal.SIGINT, signal.SIGTERM)[k % 2]
        proc = start(stereotrack(*args), cwd=ROOT, stderr=subprocess.PIPE, text=True, preexec_fn=at_default)
        wait_for_handlers(proc)
        time.sleep(delay)
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=60)
        assert "Traceback" not in err, err
        assert proc.returncode in (0, 2, 128 + sig, -sig), (delay, proc.returncode, err)
        if out.exists() and (out / "meta.yaml").exists():
            open_recording(out)
