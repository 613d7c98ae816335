"""Track the bundled demo recording: four pink pendulum balls seen by two cameras.

The demo recording is rendered into ./recordings/demo on first use (the
synthetic pendulum4 scene, deterministic), then tracked like any recording:
tracks go to out/demo/tracks.csv and the rerun viewer recording to
out/demo/demo.rrd, and the run is scored against the scene's ground truth.
"""

from __future__ import annotations

import argparse
from pathlib import Path

HELP = "track the bundled demo recording (tracks CSV + rerun .rrd)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--out", default="out/demo/tracks.csv", help="tracks CSV (default out/demo/tracks.csv)")
    p.add_argument("--method", choices=["particles", "baseline"], default="particles", help=argparse.SUPPRESS)
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    from ..sinks.network import add_network_arguments
    from ..sinks.viewer.flags import add_viz_arguments

    add_viz_arguments(p)
    add_network_arguments(p)


def run(args) -> int:
    from ..console import info
    from ..files import check_output
    from ..simulation.write import ensure_demo_recording
    from .track import track_recording

    check_output(args.out, "--out", "tracks CSV")  # before the first run spends a minute rendering the recording
    if args.rrd is not None:
        check_output(args.rrd, "--rrd", "rerun recording", [args.out])
    folder = ensure_demo_recording(Path.cwd())
    info(f"demo recording: {folder}")
    args.recording = str(folder)
    args.config = None
    args.calib = None
    args.start = 0
    args.frames = None
    args.realtime = False
    if not any(getattr(args, k, None) for k in ("rrd", "spawn", "connect", "serve")):
        args.rrd = str(Path(args.out).with_name("demo.rrd"))  # the demo always leaves a viewer recording
    return track_recording(args)
