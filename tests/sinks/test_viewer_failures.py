"""Network and viewer failures end in bounded time with one line, and the data goes only to our own viewer.

Real processes, real sockets, real signals: `stereotrack track/live` as a
user runs them, a listener that is not ours, a real rerun gRPC server killed
mid-run. Each case must end within 10 s of the failure (issue 16).
"""

import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from fuzzing import build_fixture, snapshot

LIMIT = 10.0


@pytest.fixture(scope="module")
def fixture(tmp_path_factory):
    folder = build_fixture(tmp_path_factory.mktemp("viewer") / "fixture")
    from stereotrack.simulation.presets import make_preset
    from stereotrack.simulation.write import render_scene

    render_scene(make_preset("pendulum4", n_frames=75, width=96, height=72), folder / "long", progress=False)  # 2.5 s at 30 fps
    return folder


def start(argv, cwd):
    return subprocess.Popen(
        [sys.executable, "-m", "stereotrack", *argv],
        cwd=cwd,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )


def finish(proc, seconds=60):
    try:
        out, err = proc.communicate(timeout=seconds)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, err = proc.communicate()
        pytest.fail(f"still running after {seconds} s: {err[-500:]}")
    return proc.returncode, out, err


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Listener:
    """A program that is not ours listening on a port: it accepts and counts every byte sent to it."""

    def __init__(self):
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(8)
        self.port = self.sock.getsockname()[1]
        self.received = 0
        threading.Thread(target=self._serve, daemon=True).start()

    def _serve(self):
        while True:
            try:
                conn, _ = self.sock.accept()
            except OSError:
                return
            threading.Thread(target=self._drain, args=(conn,), daemon=True).start()

    def _drain(self, conn):
        with conn:
            while data := conn.recv(65536):
                self.received += len(data)

    def close(self):
        self.sock.close()


def one_line_error(rc, err):
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert rc == 2 and len(lines) == 1 and lines[0].startswith("error: ") and "Traceback" not in err, err
    return lines[0]


def test_connect_to_nothing_is_refused_at_once_and_keeps_the_tracks(fixture):
    before = snapshot(fixture)
    t0 = time.monotonic()
    rc, _, err = finish(start(["track", "rec", "--quiet", "--connect", f"rerun+http://127.0.0.1:{free_port()}/proxy"], fixture))
    assert "no viewer listens" in one_line_error(rc, err) and time.monotonic() - t0 < LIMIT
    assert snapshot(fixture) == before


def test_connect_to_a_program_that_is_not_a_viewer_is_refused(fixture):
    other = Listener()
    try:
        t0 = time.monotonic()
        rc, _, err = finish(start(["track", "rec", "--quiet", "--connect", f"127.0.0.1:{other.port}"], fixture))
        assert "not a rerun viewer" in one_line_error(rc, err) and time.monotonic() - t0 < LIMIT
    finally:
        other.close()


@pytest.mark.parametrize("taken", ["--serve-port", "--web-port"])
def test_serve_on_a_taken_port_is_refused_and_sends_nothing_there(fixture, taken):
    other = Listener()
    ports = {"--serve-port": free_port(), "--web-port": free_port(), taken: other.port}
    try:
        t0 = time.monotonic()
        argv = ["track", "rec", "--quiet", "--serve", "--serve-port", str(ports["--serve-port"]), "--web-port", str(ports["--web-port"])]
        rc, _, err = finish(start(argv, fixture))
        assert taken in one_line_error(rc, err) and time.monotonic() - t0 < LIMIT
        assert other.received == 0
    finally:
        other.close()


def test_a_viewer_that_goes_away_mid_run_costs_at_most_ten_seconds(fixture, tmp_path):
    port = free_port()
    rerun = Path(sys.executable).parent / "rerun"
    viewer = subprocess.Popen([str(rerun), "--serve-grpc", "--port", str(port)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline:
            try:
                socket.create_connection(("127.0.0.1", port), timeout=0.2).close()
                break
            except OSError:
                time.sleep(0.1)
        out = tmp_path / "t.csv"
        proc = start(["track", "long", "--quiet", "--realtime", "--out", str(out), "--connect", f"127.0.0.1:{port}"], fixture)
        deadline = time.monotonic() + 60
        while not list(tmp_path.glob(".t.csv.*")) and time.monotonic() < deadline and proc.poll() is None:
            time.sleep(0.05)  # tracking has started once the tracks file is open
        time.sleep(1.0)
        viewer.kill()
        killed = time.monotonic()
        rc, _, err = finish(proc)
        assert time.monotonic() - killed < LIMIT, err
        assert rc in (0, 2) and "Traceback" not in err, err
        if rc == 0:
            assert out.read_text().startswith("frame,time,track_id")
    finally:
        viewer.kill()
        viewer.wait()


def test_live_serve_ends_with_one_ctrl_c(fixture):
    argv = ["live", "--cam0", "sim:pendulum4", "--cam1", "sim:pendulum4", "--width", "96", "--height", "72", "--quiet"]
    proc = start([*argv, "--serve", "--serve-port", str(free_port()), "--web-port", str(free_port())], fixture)
    lines = []
    reader = threading.Thread(target=lambda: lines.extend(proc.stderr), daemon=True)
    reader.start()
    deadline = time.monotonic() + 90
    while not any("web viewer:" in ln for ln in lines) and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.1)
    time.sleep(3.0)  # tracking
    os.killpg(proc.pid, signal.SIGINT)
    stopped = time.monotonic()
    try:
        proc.wait(LIMIT + 5)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        pytest.fail("one Ctrl-C did not end live --serve")
    reader.join(5)
    assert time.monotonic() - stopped < LIMIT and proc.returncode in (0, 130), "".join(lines)


def test_serve_on_every_interface_names_this_machines_address(fixture):
    argv = ["track", "rec", "--quiet", "--serve", "--bind", "0.0.0.0", "--serve-port", str(free_port()), "--web-port", str(free_port())]
    proc = start(argv, fixture)
    lines = []
    reader = threading.Thread(target=lambda: lines.extend(proc.stderr), daemon=True)
    reader.start()
    deadline = time.monotonic() + 60
    while not any("web viewer:" in ln for ln in lines) and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.1)
    os.killpg(proc.pid, signal.SIGINT)
    proc.wait(LIMIT + 5)
    reader.join(5)
    url = next(ln for ln in lines if "web viewer:" in ln)
    assert "http://127.0.0.1:" not in url and "0.0.0.0" not in url, url
