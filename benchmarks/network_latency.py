"""The network sink on live simulated cameras: grab-to-send latency per frame, and what sending costs the tracker.

    .venv/bin/python benchmarks/network_latency.py [--seconds 60] [--segment 5] [--frames 90] [--repeats 6]

Part 1, live (as benchmarks/live_latency.py): two simulated 640x480 / 30 fps
cameras filming ``pendulum4`` (pre-rendered, ``loop=2``, so they cost no CPU,
like webcams), tracked exactly as `stereotrack live` does (newest pair first,
older pairs dropped). Within one run the sink is switched on and off every
``--segment`` seconds (on, off, on, ...; the first segment is a warm-up and
not counted), so the shared machine's load hits both alike. The sink sends a
JSON datagram per frame to a receiver in another process (the README's
example, counting instead of printing), which stamps each datagram's arrival.
Per frame: grab-to-send = the datagram's ``sent`` minus the capture time of
the pair's later frame (one monotonic clock for the cameras, the sender and
the receiver); grab-to-receive likewise with the arrival time. Frames/s per
segment = frames tracked / segment length.

Part 2, throughput: live, the cameras cap the tracker at 30 frames/s, which
hides a cost when the tracker is faster. So the tracker also runs as fast as
it can over ``--frames`` pre-decoded pairs, alone, with ``--udp`` and with
``--udp --osc``, runs alternating (as benchmarks/viewer.py; the order rotates
each repeat), frames/s from the medians and the median of the per-repeat
ratios; and the CPU time of the sink's ``write`` (encode + send) and of
the tracker's step are timed on their thread, which other load on the
machine inflates far less than wall time.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from stereotrack.capture.cameras import CameraPairSource  # noqa: E402
from stereotrack.capture.devices import CaptureSettings  # noqa: E402
from stereotrack.commands.live import run_live, simulated_scene  # noqa: E402
from stereotrack.pipeline.run import run_pipeline  # noqa: E402
from stereotrack.pipeline.tracker import Tracker  # noqa: E402
from stereotrack.sinks.network import NetworkSink, parse_destination  # noqa: E402

# A receiver in another process: each datagram's frame, send time and arrival time, written when it is told to stop.
RECEIVER = """
import json, socket, sys, time
sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 8 << 20)
sock.bind(("127.0.0.1", 0))
print(sock.getsockname()[1], flush=True)
rows = []
while True:
    data = sock.recv(65536)
    if data == b"stop":
        break
    arrived = time.monotonic()
    msg = json.loads(data)
    rows.append((msg["frame"], msg["sent"], arrived, len(msg["tracks"])))
with open(sys.argv[1], "w") as f:
    json.dump(rows, f)
"""


class Switched:
    """Passes frames to the sink only in 'on' segments: on, off, on, ... every ``segment`` s from the first frame."""

    def __init__(self, sink: NetworkSink, segment: float):
        self.sink, self.segment = sink, segment
        self.start: float | None = None
        self.frames: list[tuple[int, int, float]] = []  # (frame, segment number, capture time of the later frame)

    def write(self, result) -> None:
        now = time.monotonic()
        if self.start is None:
            self.start = now
        seg = int((now - self.start) / self.segment)
        self.frames.append((result.frame.index, seg, max(result.frame.timestamps)))
        if seg % 2 == 0:
            self.sink.write(result)

    def close(self) -> None:
        self.sink.close()


class CpuTimed:
    """Adds up the CPU time of a sink's write (encode + send, on the tracker's thread) or of a tracker's step."""

    def __init__(self, sink):
        self.sink, self.seconds = sink, 0.0

    def write(self, result) -> None:
        t = time.thread_time()
        self.sink.write(result)
        self.seconds += time.thread_time() - t

    def step(self, pair):
        t = time.thread_time()
        out = self.sink.step(pair)
        self.seconds += time.thread_time() - t
        return out

    def close(self) -> None:
        self.sink.close()


def start_receiver(out: Path) -> tuple[subprocess.Popen, int]:
    proc = subprocess.Popen([sys.executable, "-c", RECEIVER, str(out)], stdout=subprocess.PIPE, text=True)
    return proc, int(proc.stdout.readline())


def stop_receiver(proc: subprocess.Popen, port: int, out: Path) -> list:
    import socket

    time.sleep(0.3)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.sendto(b"stop", ("127.0.0.1", port))
    proc.wait(timeout=30)
    return json.loads(out.read_text())


def live_part(a, tmp: Path) -> None:
    settings = CaptureSettings(a.width, a.height, a.fps)
    specs = [f"sim:{a.preset},loop=2"] * 2
    rig, config = simulated_scene(specs, settings)
    received = tmp / "live.json"
    proc, port = start_receiver(received)
    sink = NetworkSink([parse_destination(f"127.0.0.1:{port}")], landing_height=0.0, quiet=True)
    switched = Switched(sink, a.segment)
    source = CameraPairSource(specs, settings=settings, rig=rig, queue_size=1)
    tracker = Tracker(rig, config)
    summary, latency = run_live(source, tracker, [switched], a.seconds, show=False)
    rows = stop_receiver(proc, port, received)
    capture = {f: t for f, _, t in switched.frames}
    segment_of = {f: s for f, s, _ in switched.frames}
    estimate = dict(zip([f for f, _, _ in switched.frames], latency.latencies))
    n_seg = max(segment_of.values()) + 1
    counted = range(1, n_seg - 1)  # not the warm-up, not the last (cut short)
    fps = {s: sum(1 for v in segment_of.values() if v == s) / a.segment for s in counted}
    on_fps = [fps[s] for s in counted if s % 2 == 0]
    off_fps = [fps[s] for s in counted if s % 2 == 1]
    sent = np.array([1000 * (s - capture[f]) for f, s, _, _ in rows if segment_of.get(f) in counted])
    after = np.array([1000 * (s - capture[f] - estimate[f]) for f, s, _, _ in rows if segment_of.get(f) in counted])
    arrived = np.array([1000 * (r - capture[f]) for f, _, r, _ in rows if segment_of.get(f) in counted])
    est_on = np.array([1000 * estimate[f] for f, s in segment_of.items() if s in counted and s % 2 == 0])
    est_off = np.array([1000 * estimate[f] for f, s in segment_of.items() if s in counted and s % 2 == 1])
    frames_on = sum(1 for s in segment_of.values() if s in counted and s % 2 == 0)
    print(
        f"live {a.preset} {a.width}x{a.height} @ {a.fps:g} fps, {a.seconds:g} s in {a.segment:g} s segments (sink on, off, ...): "
        f"tracked {summary.frames} frames, step median {np.median(latency.step_ms):.1f} ms; {source.stats.pairs_dropped} pairs dropped"
    )
    print(
        f"  grab-to-send, sink on ({len(sent)} datagrams of {frames_on} frames): median {np.median(sent):.1f} ms, "
        f"95% {np.percentile(sent, 95):.1f} ms, max {sent.max():.1f} ms; grab-to-receive median {np.median(arrived):.1f} ms"
    )
    print(
        f"  grab-to-estimate median: sink on {np.median(est_on):.1f} ms, off {np.median(est_off):.1f} ms; "
        f"estimate to send, per frame: median {np.median(after):.2f} ms, 95% {np.percentile(after, 95):.2f} ms"
    )
    ratio = statistics.median(on_fps) / statistics.median(off_fps)
    print(
        f"  tracker frames/s per segment: on {' '.join(f'{v:.1f}' for v in on_fps)} | off {' '.join(f'{v:.1f}' for v in off_fps)}; "
        f"median on/off {100 * (ratio - 1):+.1f} %"
    )


def throughput_part(a, tmp: Path) -> None:
    from stereotrack.config import load_config
    from stereotrack.recording import open_recording
    from stereotrack.simulation.presets import make_preset
    from stereotrack.simulation.write import render_scene

    folder = render_scene(make_preset(a.preset, n_frames=a.frames, width=a.width, height=a.height), tmp / "rec", progress=False)
    rec = open_recording(folder)
    config = load_config(rec.targets_path)
    pairs = list(rec.frames())
    received = tmp / "throughput.json"
    proc, port = start_receiver(received)
    osc_port = port + 1 if port < 65535 else port - 1  # nobody listens there: UDP does not mind
    times: dict[str, list[float]] = {"alone": [], "udp": [], "udp+osc": []}
    sink_ms: dict[str, list[float]] = {"udp": [], "udp+osc": []}
    step_ms = []
    modes = list(times)
    for rep in range(a.repeats):
        for mode in modes[rep % 3 :] + modes[: rep % 3]:  # each mode in each position in turn: no order bias
            tracker = CpuTimed(Tracker(rec.rig, config))
            sinks = []
            if mode != "alone":
                where = [parse_destination(f"127.0.0.1:{port}")] + (
                    [parse_destination(f"127.0.0.1:{osc_port}", "osc")] if "osc" in mode else []
                )
                sinks = [CpuTimed(NetworkSink(where, landing_height=0.0, quiet=True))]
            start = time.perf_counter()
            run_pipeline(pairs, tracker, sinks, progress=False)
            times[mode].append(time.perf_counter() - start)
            step_ms.append(1000 * tracker.seconds / len(pairs))
            if sinks:
                sink_ms[mode].append(1000 * sinks[0].seconds / len(pairs))
    rows = stop_receiver(proc, port, received)
    fps = {m: len(pairs) / statistics.median(t) for m, t in times.items()}
    step = statistics.median(step_ms)
    print(
        f"throughput {a.preset}: {len(pairs)} pre-decoded pairs, {a.repeats} alternating runs each (medians); "
        f"{len(rows)} JSON datagrams received of {2 * a.repeats * len(pairs)}"
    )
    print(f"  tracker alone {fps['alone']:.1f} frames/s; tracker step CPU {step:.2f} ms per frame")
    for mode in sink_ms:
        cpu = statistics.median(sink_ms[mode])
        # the ratio within each repeat (the runs of one repeat are seconds apart, so they share the machine's load)
        paired = statistics.median(al / t for al, t in zip(times["alone"], times[mode]))
        print(
            f"  with --{mode.replace('+', ' --')}: {fps[mode]:.1f} frames/s ({100 * (fps[mode] / fps['alone'] - 1):+.1f} %; "
            f"median of the {a.repeats} per-repeat ratios {100 * (paired - 1):+.1f} %); "
            f"sink CPU {1000 * cpu:.0f} us per frame = {100 * cpu / step:.2f} % of the step's CPU"
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seconds", type=float, default=60.0, help="length of the live run (default 60)")
    ap.add_argument("--segment", type=float, default=5.0, help="seconds per on/off segment (default 5)")
    ap.add_argument("--frames", type=int, default=90, help="pairs for the throughput part (default 90)")
    ap.add_argument("--repeats", type=int, default=6, help="alternating runs per mode for the throughput part (default 6)")
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--fps", type=float, default=30.0)
    ap.add_argument("--preset", default="pendulum4")
    ap.add_argument("--skip-throughput", action="store_true")
    a = ap.parse_args()
    print(f"load average at start {os.getloadavg()[0]:.1f} ({os.cpu_count()} cores; the machine is shared)")
    with tempfile.TemporaryDirectory() as tmp:
        live_part(a, Path(tmp))
        if not a.skip_throughput:
            throughput_part(a, Path(tmp))
    print(f"load average at end {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
