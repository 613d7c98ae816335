"""Tracker frames/s with and without the rerun sink (saving to an .rrd, default settings).

Renders a pendulum4 scene (or --preset) at 640x480 once, decodes every frame pair into
memory (so video decoding is not counted), then times the tracker's loop over
those frames alone and with a RerunSink writing a file (opening the sink is
not timed: it is a one-off ~0.2 s, mostly importing rerun; closing it, which
flushes the file and writes its footer, is). Runs alternate
(plain, rerun, plain, rerun, ...) so the shared machine's noise hits both
alike; the figure is the ratio of the medians.

Then one more run with the sink's parts timed (CPU time of the thread each
part runs in, so other load on the machine does not inflate them): what the
logging costs per logged frame, on the tracker's thread, in the sink's logging
thread (by part) and in rerun's own threads (encoding and writing the file).

    .venv/bin/python benchmarks/viewer.py [--frames 90] [--repeats 6] [--every N] [--no-images] [--image-scale S] [--preset NAME]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import threading
import time
from collections import defaultdict
from pathlib import Path

from stereotrack.config import load_config
from stereotrack.pipeline.tracker import Tracker, run_pipeline
from stereotrack.recording import open_recording, read_truth
from stereotrack.simulation.presets import make_preset
from stereotrack.simulation.write import render_scene
from stereotrack.sinks.viewer.sink import RerunSink, SeriesBuffer, VizOutputs, VizSettings


class TimedSink:
    """Wraps a sink and adds up the wall time spent in it (write and close)."""

    def __init__(self, sink):
        self.sink, self.seconds = sink, 0.0

    def write(self, result) -> None:
        t = time.perf_counter()
        self.sink.write(result)
        self.seconds += time.perf_counter() - t

    def close(self) -> None:
        t = time.perf_counter()
        self.sink.close()
        self.seconds += time.perf_counter() - t


# The logging thread's parts: (class, method) -> label. _rows (one send_columns) is split by entity below.
PARTS = {
    (RerunSink, "_encode_images"): "images scaled + JPEG-encoded (both cameras)",
    (RerunSink, "_gather"): "gathering a frame (particle subsample, trail views)",
    (RerunSink, "_follow_trails"): "trails follow the tracks",
    (RerunSink, "_log_stats"): "time-series values",
    (RerunSink, "_send"): "batch: arrays built (projections, colours, eigen)",
    (SeriesBuffer, "flush"): "batch: time series sent",
    (RerunSink, "_rows"): "batch: sent",
}
GROUPS = (  # entity path prefix -> label, first match
    ("stats/", "batch: time series sent"),
    ("world/cameras/", "batch: sent, per camera (JPEG blobs, windows, marks)"),
    ("world/tracks", "batch: sent, tracks + covariance + trails"),
    ("world/particles", "batch: sent, particles"),
    ("world/objects", "batch: sent, objects"),
    ("world/truth", "batch: sent, truth"),
)


def timed_parts():
    """Wrap the sink's parts so each adds its thread's CPU time (exclusive of parts inside it) to a total."""
    totals: dict[str, float] = defaultdict(float)
    local = threading.local()
    originals = {}

    def wrap(cls, name, label):
        fn = getattr(cls, name)
        originals[(cls, name)] = fn

        def timed(self, *args, **kwargs):
            key = label
            if name == "_rows":
                key = next((lb for prefix, lb in GROUPS if args[0].startswith(prefix)), label)
            stack = local.__dict__.setdefault("stack", [])
            stack.append(0.0)
            start = time.thread_time()
            try:
                return fn(self, *args, **kwargs)
            finally:
                spent = time.thread_time() - start
                inner = stack.pop()
                totals[key] += spent - inner
                if stack:
                    stack[-1] += spent

        setattr(cls, name, timed)

    for (cls, name), label in PARTS.items():
        wrap(cls, name, label)

    def work(self):  # the whole logging thread's CPU time
        start = time.thread_time()
        try:
            originals[(RerunSink, "_work")](self)
        finally:
            totals["logging thread, all"] += time.thread_time() - start

    originals[(RerunSink, "_work")] = RerunSink._work
    RerunSink._work = work

    def restore():
        for (cls, name), fn in originals.items():
            setattr(cls, name, fn)

    return totals, restore


def breakdown(pairs, rig, config, truth, settings: VizSettings, rrd: Path) -> None:
    """Print the logging's CPU time per logged frame: the tracker's thread, the logging thread by part."""
    totals, restore = timed_parts()
    try:
        sink = RerunSink(rig, config, VizOutputs(rrd=rrd), settings, truth=truth)
        tracker = Tracker(rig, config)
        main = 0.0
        try:
            for pair in pairs:
                result = tracker.step(pair)
                start = time.thread_time()
                sink.write(result)
                main += time.thread_time() - start
        finally:
            start = time.thread_time()
            sink.close()
            main += time.thread_time() - start
    finally:
        restore()
    logged = len(range(0, len(pairs), settings.every))
    worker = totals.pop("logging thread, all")
    print(f"logging cost per logged frame (CPU ms of the thread it runs in, {logged} logged frames):")
    print(f"  on the tracker's thread (write, close):              {1000 * main / logged:5.2f}")
    print(f"  in the logging thread:                               {1000 * worker / logged:5.2f}")
    for label, seconds in sorted(totals.items(), key=lambda kv: -kv[1]):
        print(f"    {label:51s} {1000 * seconds / logged:5.2f}")
    print(f"    {'the rest (queue, loop)':51s} {1000 * (worker - sum(totals.values())) / logged:5.2f}")


def rerun_threads_ms(pairs, rig, config, truth, settings: VizSettings, rrd: Path) -> float:
    """CPU ms per logged frame outside this thread and the logging thread (rerun's own threads), tracker results replayed."""
    tracker = Tracker(rig, config)
    results = [tracker.step(p) for p in pairs]  # replayed: no tracker threads run while this is measured
    worker = {"t": 0.0}
    original = RerunSink._work

    def work(self):
        start = time.thread_time()
        try:
            original(self)
        finally:
            worker["t"] = time.thread_time() - start

    RerunSink._work = work
    try:
        sink = RerunSink(rig, config, VizOutputs(rrd=rrd), settings, truth=truth)
        time.sleep(0.2)  # the recording stream's setup is not counted
        c, t = time.process_time(), time.thread_time()
        for r in results:
            sink.write(r)
        sink.close()
        time.sleep(0.2)
        other = (time.process_time() - c) - (time.thread_time() - t) - worker["t"]
    finally:
        RerunSink._work = original
    return 1000 * other / len(range(0, len(pairs), settings.every))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frames", type=int, default=90)
    ap.add_argument(
        "--preset", default="pendulum4", help="synthetic scene (default pendulum4; static2 tracks faster, clutter has noisy images)"
    )
    ap.add_argument("--repeats", type=int, default=6)
    ap.add_argument("--every", type=int, default=VizSettings.every, help="viewer decimation (default: the default setting)")
    ap.add_argument("--no-images", action="store_true", help="do not log camera images")
    ap.add_argument(
        "--image-scale", type=float, default=VizSettings.image_scale, help="size the images are logged at (default: the default setting)"
    )
    args = ap.parse_args()
    settings = VizSettings(every=args.every, images=not args.no_images, image_scale=args.image_scale)

    with tempfile.TemporaryDirectory() as tmp:
        folder = render_scene(make_preset(args.preset, n_frames=args.frames, width=640, height=480), Path(tmp) / "rec", progress=False)
        rec = open_recording(folder)
        config = load_config(rec.targets_path)
        truth = read_truth(rec.truth_path)
        pairs = list(rec.frames())
        rrd = Path(tmp) / "bench.rrd"
        times: dict[str, list[float]] = {"plain": [], "rerun": []}
        sink_ms: list[float] = []
        for _ in range(args.repeats):
            for mode in ("plain", "rerun"):
                tracker = Tracker(rec.rig, config)
                sinks = []
                if mode == "rerun":
                    sinks = [TimedSink(RerunSink(rec.rig, config, VizOutputs(rrd=rrd), settings, truth=truth))]
                start = (
                    time.perf_counter()
                )  # opening the sink (importing rerun, once per run) is not counted; closing it (flush + footer) is
                run_pipeline(pairs, tracker, sinks, progress=False)
                times[mode].append(time.perf_counter() - start)
                if sinks:
                    sink_ms.append(1000 * sinks[0].seconds / len(pairs))
        size_mb = rrd.stat().st_size / 1e6
        fps = {m: len(pairs) / statistics.median(t) for m, t in times.items()}
        drop = 100 * (1 - fps["rerun"] / fps["plain"])
        print(
            f"{args.preset}: {len(pairs)} frame pairs 640x480, 2 cameras, {args.repeats} alternating runs each (median); viewer "
            f"every {args.every} frame(s), images {'off' if args.no_images else f'at {args.image_scale:g} x their size'}"
        )
        print(f"tracker alone:        {fps['plain']:6.1f} frames/s")
        print(f"tracker + rerun .rrd: {fps['rerun']:6.1f} frames/s  (drop {drop:.1f} %, target <= 25 %)")
        print(
            f"wall time in the sink's write + close, on the tracker's thread: {statistics.median(sink_ms):.2f} "
            f"ms per frame (tracker alone: {1000 / fps['plain']:.1f} ms per frame)"
        )
        print(f".rrd size: {size_mb:.1f} MB ({1000 * size_mb / len(pairs):.0f} kB per frame)")
        breakdown(pairs, rec.rig, config, truth, settings, Path(tmp) / "parts.rrd")
        print(
            "  in other threads (rerun's: chunks encoded, file written): "
            f"{rerun_threads_ms(pairs, rec.rig, config, truth, settings, Path(tmp) / 'threads.rrd'):5.2f}"
        )


if __name__ == "__main__":
    main()
