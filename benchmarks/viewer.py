"""Tracker frames/s with and without the rerun sink (saving to an .rrd, default settings).

Renders a pendulum4 scene at 640x480 once, decodes every frame pair into
memory (so video decoding is not counted), then times the tracker's loop over
those frames alone and with a RerunSink writing a file (opening the sink is
not timed: it is a one-off ~0.2 s, mostly importing rerun; closing it, which
flushes the file and writes its footer, is). Runs alternate
(plain, rerun, plain, rerun, ...) so the shared machine's noise hits both
alike; the figure is the ratio of the medians.

    .venv/bin/python benchmarks/viewer.py [--frames 90] [--repeats 6]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

from stereotrack.config import load_config
from stereotrack.pipeline import Tracker, run_pipeline
from stereotrack.recording import open_recording, read_truth
from stereotrack.synth import make_preset, render_scene
from stereotrack.viz import RerunSink, VizOutputs, VizSettings


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


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frames", type=int, default=90)
    ap.add_argument("--repeats", type=int, default=6)
    ap.add_argument("--every", type=int, default=VizSettings.every, help="viewer decimation (default: the default setting)")
    ap.add_argument("--no-images", action="store_true", help="do not log camera images")
    args = ap.parse_args()

    with tempfile.TemporaryDirectory() as tmp:
        folder = render_scene(make_preset("pendulum4", n_frames=args.frames, width=640, height=480), Path(tmp) / "rec", progress=False)
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
                    sinks = [TimedSink(RerunSink(rec.rig, config, VizOutputs(rrd=rrd), VizSettings(every=args.every, images=not args.no_images), truth=truth))]
                start = time.perf_counter()  # opening the sink (importing rerun, once per run) is not counted; closing it (flush + footer) is
                run_pipeline(pairs, tracker, sinks, progress=False)
                times[mode].append(time.perf_counter() - start)
                if sinks:
                    sink_ms.append(1000 * sinks[0].seconds / len(pairs))
        size_mb = rrd.stat().st_size / 1e6
    fps = {m: len(pairs) / statistics.median(t) for m, t in times.items()}
    drop = 100 * (1 - fps["rerun"] / fps["plain"])
    print(f"{len(pairs)} frame pairs 640x480, 2 cameras, {args.repeats} alternating runs each (median); viewer every {args.every} frame(s), images {'off' if args.no_images else 'on'}")
    print(f"tracker alone:        {fps['plain']:6.1f} frames/s")
    print(f"tracker + rerun .rrd: {fps['rerun']:6.1f} frames/s  (drop {drop:.1f} %, target <= 25 %)")
    print(f"time in the rerun sink: {statistics.median(sink_ms):.1f} ms per frame (tracker alone: {1000 / fps['plain']:.1f} ms per frame)")
    print(f".rrd size: {size_mb:.1f} MB ({1000 * size_mb / len(pairs):.0f} kB per frame)")


if __name__ == "__main__":
    main()
