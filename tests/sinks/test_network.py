"""The network sink as users meet it: `stereotrack track --udp/--osc` in a real subprocess, received on loopback and
checked against tracks.csv; the README's receiver example run as it is (and killed mid-run); bad addresses."""

import contextlib
import json
import queue
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from stereotrack.errors import StereotrackError
from stereotrack.frames import FramePair
from stereotrack.results import FrameResult, Parabola, TrackEstimate
from stereotrack.simulation.presets import make_preset
from stereotrack.simulation.write import render_scene
from stereotrack.sinks import network
from stereotrack.sinks.network import NetworkSink, parse_destination

ROOT = Path(__file__).resolve().parents[2]
N_FRAMES = 60  # throw1: flights of 0.75 s from frames 0 and 27, each ending in a catch


def readme_receiver() -> str:
    """The receiver example, exactly as the README shows it."""
    section = (ROOT / "README.md").read_text().split("<!-- section: network -->")[1].split("<!-- /section: network -->")[0]
    return section.split("```python\n")[1].split("```")[0]


class Receiver:
    """Collects every datagram sent to a loopback port, on a thread."""

    def __init__(self):
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4 << 20)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(0.1)
        self.port = self.sock.getsockname()[1]
        self.got: list[tuple[float, bytes]] = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self):
        while not self._stop.is_set():
            try:
                self.got.append((time.monotonic(), self.sock.recv(65536)))
            except TimeoutError:
                pass

    def stop(self):
        time.sleep(0.3)
        self._stop.set()
        self._thread.join()
        self.sock.close()


def start_readme_receiver(tmp_path: Path, name: str):
    """The README example in its own process, once its port is bound (a bind of ours then fails)."""
    script = tmp_path / f"{name}.py"
    script.write_text(readme_receiver())
    probe = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    probe.bind(("127.0.0.1", 0))
    port = probe.getsockname()[1]
    probe.close()
    proc = subprocess.Popen([sys.executable, str(script), str(port)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline:
        try:
            with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
                s.bind(("127.0.0.1", port))
        except OSError:
            return proc, port
        assert proc.poll() is None, proc.stderr.read()
        time.sleep(0.05)
    proc.kill()
    raise AssertionError("the README receiver did not bind its port in 30 s")


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """One `track` of a thrown ball, sending to two receivers of ours (JSON, OSC) and two README receivers,
    one of which is killed as soon as it has printed a line (mid-run)."""
    tmp = tmp_path_factory.mktemp("net")
    rec = render_scene(make_preset("throw1", n_frames=N_FRAMES), tmp / "throw1", progress=False)
    udp, osc = Receiver(), Receiver()
    stays, stays_port = start_readme_receiver(tmp, "stays")
    leaves, leaves_port = start_readme_receiver(tmp, "leaves")
    out = tmp / "tracks.csv"
    cmd = [sys.executable, "-m", "stereotrack", "track", str(rec), "--out", str(out), "--quiet", "--landing-height", "-0.3"]
    cmd += ["--udp", f"127.0.0.1:{udp.port}", "--osc", f"127.0.0.1:{osc.port}"]
    cmd += ["--udp", f"127.0.0.1:{stays_port}", "--udp", f"localhost:{leaves_port}"]
    track = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    lines = queue.Queue()
    threading.Thread(target=lambda: lines.put(leaves.stdout.readline()), daemon=True).start()
    try:
        first = lines.get(timeout=300)  # the first track it heard of
    except queue.Empty:
        first = ""
    killed_at = time.monotonic()
    leaves.send_signal(signal.SIGTERM)
    leaves.wait(timeout=10)
    stdout, stderr = track.communicate(timeout=300)
    stays.send_signal(signal.SIGINT)
    stays_out, _ = stays.communicate(timeout=10)
    udp.stop()
    osc.stop()
    return {
        "returncode": track.returncode,
        "stderr": stderr,
        "csv": out,
        "udp": udp.got,
        "osc": osc.got,
        "stays": stays_out,
        "leaves_first": first,
        "killed_at": killed_at,
    }


def csv_rows(path: Path) -> list[dict]:
    lines = path.read_text().splitlines()
    head = lines[0].split(",")
    return [dict(zip(head, line.split(","))) for line in lines[1:]]


def test_every_frame_has_its_datagram_with_the_tracks_of_tracks_csv(run):
    assert run["returncode"] == 0, run["stderr"]
    msgs = [json.loads(data) for _, data in run["udp"]]
    assert sorted(m["frame"] for m in msgs) == list(range(N_FRAMES))  # nothing lost on loopback
    assert len({m["frame"] for m in msgs}) == len(msgs)
    by_frame = {m["frame"]: m for m in msgs}
    assert all(m["schema"] == "stereotrack.tracks" and m["version"] == 1 and m["landing_height"] == -0.3 for m in msgs)
    rows = csv_rows(run["csv"])
    assert rows
    first_sent = {}
    for m in sorted(msgs, key=lambda m: m["frame"]):
        for t in m["tracks"]:
            first_sent.setdefault(t["id"], m["frame"])
    hindsight = 0
    for row in rows:
        sent = {t["id"]: t for t in by_frame[int(row["frame"])]["tracks"]}
        if int(row["track_id"]) not in sent:  # a track's tentative frames, written once it was confirmed (live sinks are live)
            assert int(row["frame"]) < first_sent[int(row["track_id"])]
            hindsight += 1
            continue
        t = sent[int(row["track_id"])]
        assert t["target"] == row["target"] and t["state"] in ("confirmed", "coasting")
        assert by_frame[int(row["frame"])]["time"] == pytest.approx(float(row["time"]), abs=1e-6)
        # tracks.csv has the state smoothed with the frames after (tracks.smooth_time); a datagram, the live one
        sd = np.array([float(row[k]) for k in ("sx", "sy", "sz")])
        assert np.all(sd <= np.array(t["sd"]) + 1e-4)
        assert np.all(np.abs(np.array(t["position"]) - [float(row[k]) for k in "xyz"]) <= 3 * np.array(t["sd"]) + 1e-4)
    # and no track is sent that tracks.csv does not have
    assert sum(len(m["tracks"]) for m in msgs) == len(rows) - hindsight


def test_a_thrown_ball_gets_landing_points_near_the_catch(run):
    msgs = [json.loads(data) for _, data in run["udp"]]
    flying = [(m, t) for m in msgs for t in m["tracks"] if t["landing"]]
    assert len(flying) >= 5
    catch = np.array([0.25, 1.6, -0.3])  # throw1's first flight lands in the other hand at 0.75 s
    late = [(m, t) for m, t in flying if 0.35 <= m["time"] < 0.75]
    assert late
    for _m, t in late:
        assert np.linalg.norm(np.array(t["landing"]["position"]) - catch) < 0.05
        assert abs(t["landing"]["time"] - 0.75) < 0.05
        assert t["flying"] and len(t["velocity"]) == 3


def test_osc_bundles_carry_the_same_tracks(run):
    from pythonosc.osc_bundle import OscBundle

    msgs = {m["frame"]: m for m in (json.loads(d) for _, d in run["udp"])}
    assert len(run["osc"]) == len(msgs)
    landings = 0
    for _, data in run["osc"]:
        bundle = OscBundle(data)
        contents = [bundle.content(i) for i in range(bundle.num_contents)]
        head = contents[0]
        assert head.address == "/stereotrack/frame"
        version, frame, t, sent, n = head.params
        ref = msgs[frame]
        assert version == 1 and t == pytest.approx(ref["time"], abs=1e-6) and n == len(ref["tracks"])  # JSON: microseconds
        tracks = {m.params[0]: m.params for m in contents if m.address == "/stereotrack/track"}
        assert len(tracks) == n
        for tr in ref["tracks"]:
            params = tracks[tr["id"]]
            assert params[1] == tr["target"] and params[2] == tr["state"]
            np.testing.assert_allclose(params[3:6], tr["position"], atol=1e-4)
        for m in contents:
            if m.address == "/stereotrack/landing":
                landings += 1
                np.testing.assert_allclose(
                    m.params[1:4], next(t for t in ref["tracks"] if t["id"] == m.params[0])["landing"]["position"], atol=1e-4
                )
    assert landings > 0


def test_the_readme_receiver_prints_every_track(run):
    first_sent = {}
    for _, data in sorted(run["udp"], key=lambda got: json.loads(got[1])["frame"]):
        m = json.loads(data)
        for t in m["tracks"]:
            first_sent.setdefault(t["id"], m["frame"])
    # tracks.csv also holds each track's tentative frames, written once it was confirmed: the network is live
    rows = [row for row in csv_rows(run["csv"]) if int(row["frame"]) >= first_sent[int(row["track_id"])]]
    lines = [line for line in run["stays"].splitlines() if line.startswith("frame ")]
    assert len(lines) == len(rows)
    sent = {(m["frame"], t["id"]): t["position"] for m in map(json.loads, (data for _, data in run["udp"])) for t in m["tracks"]}
    for line, row in zip(lines, rows):  # live positions, as the datagrams carry them (tracks.csv's are smoothed)
        x, y, _ = sent[(int(row["frame"]), int(row["track_id"]))]
        assert line.startswith(f"frame {row['frame']} ball {row['track_id']} at {x:.3f} {y:.3f} ")
    assert any(", lands at " in line for line in lines)


def test_a_receiver_that_goes_away_mid_run_does_not_stop_the_run(run):
    assert run["leaves_first"].startswith("frame ")
    assert run["returncode"] == 0, run["stderr"]
    later = [t for t, _ in run["udp"] if t > run["killed_at"] + 0.05]
    assert later, "no datagram reached the other receivers after one went away (or the run ended before)"
    assert ", 0 failed" in run["stderr"]


# ---------------------------------------------------------------------- addresses


@pytest.mark.parametrize(
    "text, message",
    [
        ("localhost", "expected HOST:PORT"),
        ("::1:9870", "expected HOST:PORT"),
        (":9870", "expected HOST:PORT"),
        ("[::1]9870", "expected HOST:PORT"),
        ("127.0.0.1:port", "whole number"),
        ("127.0.0.1:0", "out of range"),
        ("127.0.0.1:65536", "out of range"),
        ("no-such-host.invalid:9870", "cannot resolve host"),
    ],
)
def test_a_bad_address_is_one_clear_line(text, message):
    with pytest.raises(StereotrackError) as err:
        parse_destination(text, "udp")
    assert message in str(err.value) and repr(text) in str(err.value) and "\n" not in str(err.value)


def test_good_addresses_resolve():
    assert parse_destination("127.0.0.1:9870").address == ("127.0.0.1", 9870)
    assert parse_destination("localhost:9870", "osc").address[1] == 9870
    assert parse_destination("[::1]:9870").family == socket.AF_INET6


def test_the_command_refuses_a_bad_address_before_touching_the_output(tmp_path):
    out = tmp_path / "tracks.csv"
    out.write_text("the previous run's tracks\n")
    for bad in ("127.0.0.1:70000", "no-such-host.invalid:9870", "nonsense"):
        r = subprocess.run(
            [sys.executable, "-m", "stereotrack", "track", str(tmp_path), "--out", str(out), "--udp", "127.0.0.1:9870", "--osc", bad],
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert r.returncode == 2 and r.stderr.count("\n") == 1 and r.stderr.startswith(f"error: --osc {bad!r}"), r.stderr
    assert out.read_text() == "the previous run's tracks\n"


def test_a_missing_python_osc_is_one_line(monkeypatch):
    for name in ("pythonosc", "pythonosc.osc_bundle_builder", "pythonosc.osc_message_builder"):
        monkeypatch.setitem(sys.modules, name, None)
    with pytest.raises(StereotrackError, match=r"--osc needs python-osc: pip install"):
        NetworkSink([parse_destination("127.0.0.1:9870", "osc")])


# ---------------------------------------------------------------------- never blocking


def frame_result(i: int, flying: bool = False) -> FrameResult:
    flight = Parabola(i / 30, np.array([0.0, 1.5, 0.2]), np.array([0.5, 0.0, 1.0]), np.array([0.0, 0.0, -9.81])) if flying else None
    track = TrackEstimate(1, "pink", np.array([0.0, 1.5, 0.2]), np.zeros(3), np.eye(3) * 1e-6, "confirmed", reported=True, flight=flight)
    return FrameResult(FramePair(i, (), (i / 30,)), tracks=(track,))


def test_a_receiver_that_does_not_read_costs_nothing():
    """Its buffer fills and the kernel drops the rest; every write still returns at once (non-blocking sockets)."""
    slow = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    slow.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    slow.bind(("127.0.0.1", 0))
    sink = NetworkSink([parse_destination(f"127.0.0.1:{slow.getsockname()[1]}")], landing_height=0.0, quiet=True)
    assert all(not s.getblocking() for s in sink._sockets.values())
    for i in range(2000):
        sink.write(frame_result(i, flying=True))
    sink.close()
    slow.setblocking(False)
    kept = []
    with contextlib.suppress(BlockingIOError):
        while True:
            kept.append(json.loads(slow.recv(65536)))
    slow.close()
    assert sink.frames == 2000 and sink.sent + sink.dropped == 2000 and sink.failed == 0
    assert 0 < len(kept) < 2000  # the receiver's buffer held a few, the kernel dropped the rest
    assert kept[0]["frame"] == 0 and kept[0]["tracks"][0]["landing"]["position"][2] == pytest.approx(0.0)


def test_a_full_send_buffer_drops_the_datagram_instead_of_waiting():
    sink = NetworkSink([parse_destination("127.0.0.1:9")], quiet=True)

    class Full:
        def sendto(self, data, address):
            raise BlockingIOError(11, "Resource temporarily unavailable")

        def close(self):
            pass

    sink._sockets[socket.AF_INET] = Full()
    for i in range(3):
        sink.write(frame_result(i))
    sink.close()
    assert (sink.frames, sink.sent, sink.dropped, sink.failed) == (3, 0, 3, 0)


def test_a_failing_destination_is_counted_and_the_others_still_get_every_frame(monkeypatch):
    receiver = Receiver()
    good = parse_destination(f"127.0.0.1:{receiver.port}")
    sink = NetworkSink([parse_destination("127.0.0.1:9"), good], quiet=True)
    real = sink._sockets[socket.AF_INET]

    class FailingForPort9:
        def sendto(self, data, address):
            if address[1] == 9:
                raise OSError(101, "Network is unreachable")
            return real.sendto(data, address)

        def close(self):
            real.close()

    warnings = []
    monkeypatch.setattr(network, "warn", warnings.append)
    sink._sockets[socket.AF_INET] = FailingForPort9()
    for i in range(5):
        sink.write(frame_result(i))
    sink.close()
    receiver.stop()
    assert sink.failed == 5 and sink.sent == 5 and sink.dropped == 0 and len(warnings) == 1
    assert [json.loads(d)["frame"] for _, d in receiver.got] == [0, 1, 2, 3, 4]


def test_a_non_finite_number_is_sent_as_null_so_the_json_stays_strict():
    from stereotrack.sinks.datagram import FrameTracks, encode_json, message

    track = TrackEstimate(7, 'a "quoted" name', np.array([np.nan, 1.0, 2.0]), np.zeros(3), np.eye(3), "coasting", reported=True)
    data = encode_json(message(FrameTracks(3, (0.5, 0.5), (track,)), 1.25, None))

    def refuse(name):
        raise ValueError(f"not strict JSON: {name}")

    msg = json.loads(data, parse_constant=refuse)
    assert msg["tracks"][0]["position"] == [None, 1.0, 2.0] and msg["tracks"][0]["target"] == 'a "quoted" name'
    assert (msg["frame"], msg["time"], msg["sent"], msg["landing_height"]) == (3, 0.5, 1.25, None)
