"""Live tracking on two simulated 640x480 / 30 fps cameras: grab-to-estimate latency and tracker frames/s.

    .venv/bin/python benchmarks/live_latency.py [--seconds 30] [--width 640 --height 480]

The cameras pre-render two seconds of `pendulum4` and loop them (``loop=2``), so
they cost no CPU, like real webcams; the tracker then runs exactly as in
`stereotrack live` (newest pair first, older pairs dropped). Latency = time of
the estimate minus the capture time of the pair's later frame. "No growing
latency" is checked by comparing the medians of the first and last thirds.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from stereotrack.capture.cameras import CameraPairSource  # noqa: E402
from stereotrack.capture.devices import CaptureSettings  # noqa: E402
from stereotrack.commands.live import run_live, simulated_scene  # noqa: E402
from stereotrack.pipeline.tracker import Tracker  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seconds", type=float, default=30.0)
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--fps", type=float, default=30.0)
    ap.add_argument("--preset", default="pendulum4")
    a = ap.parse_args()
    settings = CaptureSettings(a.width, a.height, a.fps)
    specs = [f"sim:{a.preset},loop=2"] * 2
    rig, config = simulated_scene(specs, settings)
    source = CameraPairSource(specs, settings=settings, rig=rig, queue_size=1)
    tracker = Tracker(rig, config)
    summary, latency = run_live(source, tracker, [], a.seconds, show=False)
    lat = np.asarray(latency.latencies) * 1000
    third = max(1, len(lat) // 3)
    stats = source.stats
    print(
        f"live {a.preset} {a.width}x{a.height} @ {a.fps:g} fps, {a.seconds:g} s: tracked {summary.frames} frames, "
        f"tracker {summary.fps:.1f} frames/s (step median {np.median(latency.step_ms):.1f} ms)"
    )
    print(
        f"grab-to-estimate latency: median {np.median(lat):.1f} ms, 95% {np.percentile(lat, 95):.1f} ms, max {lat.max():.1f} ms; "
        f"median first third {np.median(lat[:third]):.1f} ms, last third {np.median(lat[-third:]):.1f} ms"
    )
    print(f"cameras: {stats.line()}")


if __name__ == "__main__":
    main()
