"""Track balls live from two or more cameras.

Frames are paired by capture time as in `stereotrack record`; the tracker always
takes the newest pair (pairs it had no time for are dropped and counted, so the
delay never grows). One status line on stderr shows the tracker's frames/s, the
grab-to-estimate latency and the cameras' frames/s; the summary at the end gives
the latency's median and 95th percentile.

--record DIR also records every pair the cameras delivered (not only those the tracker
had time for) and notes which ones it tracked (tracked.csv): `stereotrack track DIR`
then replays exactly the live run's frames and gives the same tracks.

Simulated cameras (sim:PRESET on every camera) need neither --calib nor --config:
the scene's rig and targets are used.

examples:
  stereotrack live --cam0 0 --cam1 2 --calib calib/desk.yaml --config pink.yaml --spawn
  stereotrack live --cam0 0 --cam1 2 --calib calib/desk.yaml --config pink.yaml --record recordings/s1 --out s1.csv
  stereotrack live --cam0 sim:pendulum4 --cam1 sim:pendulum4 --seconds 20 --rrd live.rrd
"""

from __future__ import annotations

import argparse

from ._capture_args import DEVICE_HELP, add_camera_arguments, camera_specs, capture_settings

HELP = "track live from two or more cameras (optionally recording them)"
__doc__ = __doc__ + "\n" + DEVICE_HELP


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from ..argtypes import number

    parser.add_argument("--calib", metavar="FILE", help="calibration YAML of the cameras (required unless every camera is sim:)")
    parser.add_argument("--config", metavar="FILE", help="target/tracker config YAML (required unless every camera is sim:)")
    parser.add_argument("--out", metavar="CSV", help="write the tracks to this CSV (formats.md section 3)")
    parser.add_argument("--record", metavar="DIR", help="also record the frame pairs the tracker saw into this recording folder")
    parser.add_argument(
        "--codec", choices=("mjpg", "ffv1"), default="mjpg", help="video codec for --record (see `stereotrack record --help`)"
    )
    parser.add_argument("--seconds", type=number(above=0), default=None, help="stop after this many seconds (default: until Ctrl-C)")
    parser.add_argument("--quiet", action="store_true", help="no status line")
    add_camera_arguments(parser)
    from ..sinks.network import add_network_arguments
    from ..sinks.viewer.flags import add_viz_arguments  # viz imports rerun only when a viewer flag is used

    add_viz_arguments(parser)
    add_network_arguments(parser)


def simulated_scene(specs: list[str], settings):
    """(rig, config) of the scene that every sim: camera films, or None if not all cameras are simulated."""
    from ..errors import StereotrackError

    if not all(s.startswith("sim:") for s in specs):
        return None
    presets = {s[4:].split(",")[0] for s in specs}
    if len(presets) != 1:
        raise StereotrackError(f"the simulated cameras film different scenes ({', '.join(sorted(presets))}); give --calib and --config")
    preset = presets.pop()
    if preset == "dots":
        raise StereotrackError(
            "sim:dots is a test pattern without a calibration; use a scene preset (e.g. sim:pendulum4) or give --calib and --config"
        )
    from dataclasses import replace

    from ..simulation.presets import make_preset
    from ..simulation.spec import WORLD_UP

    spec = make_preset(preset, width=settings.width or 640, height=settings.height or 480, fps=settings.fps or 30.0)
    config = spec.config()  # with the scene's up axis, as `track` takes it from a rendered recording: gravity for flights
    return spec.rig.build(), replace(config, tracks=replace(config.tracks, up=WORLD_UP))


class LatencySink:
    """Grab-to-estimate latency of every frame (called right after the tracker step) and the status line."""

    def __init__(self, source, clock, show: bool = True):
        from ..console import Progress

        self.source = source
        self.clock = clock
        self.latencies: list[float] = []
        self.step_ms: list[float] = []
        self.tracks = 0
        self.progress = Progress(None, "live", "frames", enabled=show)

    def write(self, result) -> None:
        self.latencies.append(self.clock() - max(result.frame.timestamps))
        self.step_ms.append(result.timings_ms.get("step", 0.0))
        recent = self.latencies[-30:]
        self.tracks = len(result.confirmed)
        self.progress.update(
            1, extra=f"latency {1000 * sorted(recent)[len(recent) // 2]:.0f} ms | {self.tracks} tracks | {self.source.stats.line()}"
        )

    def close(self) -> None:
        self.progress.close()


def run_live(source, tracker, sinks, seconds: float | None = None, show: bool = True, recorder=None):
    """Track ``source`` until it ends, Ctrl-C/SIGTERM, or ``seconds``; returns (RunSummary, latency sink).

    The source stops before ``recorder`` (fed by the source, not the tracker) is finalised.
    """
    import time

    from ..capture.signals import StopOnSignals
    from ..pipeline.run import run_pipeline

    latency = LatencySink(source, time.monotonic, show)

    def frames():
        start = time.monotonic()
        for pair in source:
            yield pair
            if seconds is not None and time.monotonic() - start >= seconds:
                return

    try:
        with StopOnSignals(source.request_stop):
            summary = run_pipeline(frames(), tracker, [latency, *sinks], progress=False)
    finally:
        source.close()
        if recorder is not None:
            recorder.close()
    if recorder is not None:
        recorder.check()
    return summary, latency


def run(args: argparse.Namespace) -> int:
    import numpy as np

    from ..camera import load_rig
    from ..config import load_config
    from ..console import info
    from ..errors import StereotrackError
    from ..sinks.network import check_network_flags

    check_network_flags(args)
    specs = camera_specs(args)
    settings = capture_settings(args)
    scene = simulated_scene(specs, settings) if not (args.calib and args.config) else None
    if args.calib:
        rig = load_rig(args.calib)
    elif scene:
        rig = scene[0]
    else:
        raise StereotrackError("live tracking needs the cameras' calibration: pass --calib FILE (see `stereotrack calibrate`)")
    if args.config:
        config = load_config(args.config)
    elif scene:
        config = scene[1]
    else:
        raise StereotrackError("live tracking needs the target colours: pass --config FILE (see `stereotrack colour learn`)")
    if not config.targets:
        raise StereotrackError(f"{args.config}: no targets to track; add some under 'targets:'")
    for cam in rig.cameras:
        if settings.width and settings.height and tuple(cam.image_size) != (settings.width, settings.height):
            raise StereotrackError(
                f"camera {cam.name} is calibrated for {cam.width}x{cam.height}; pass --width {cam.width} --height {cam.height}"
            )

    from ..capture.signals import StopOnSignals

    with StopOnSignals() as stopper:  # a signal from here on ends the session cleanly, even during setup
        source, recorder, summary, latency, viz = _live_session(args, specs, settings, rig, config, stopper)

    stats = source.stats
    lat = np.asarray(latency.latencies) * 1000
    if len(lat):
        third = max(1, len(lat) // 3)
        info(
            f"tracked {summary.frames} of {stats.formed} pairs in {summary.seconds:.1f} s ({summary.fps:.1f} frames/s; "
            f"tracker step median {summary.median_step_ms:.1f} ms); {stats.formed - summary.frames} skipped while the tracker was busy; "
            f"grab-to-estimate latency median {np.median(lat):.0f} ms, 95% {np.percentile(lat, 95):.0f} ms "
            f"(first third {np.median(lat[:third]):.0f} ms, last third {np.median(lat[-third:]):.0f} ms); "
            f"unpaired frames {'/'.join(str(c.unpaired) for c in stats.cameras)}"
        )
    if stopper.signal_name:
        info(f"stopped by {stopper.signal_name}")
    if args.out:
        info(f"tracks written to {args.out}")
    if recorder is not None:
        lost = f", {stats.not_recorded} lost because the disk was too slow" if stats.not_recorded else ""
        info(f"{recorder.count} pairs recorded in {args.record}{lost}; replay the live run exactly with: stereotrack track {args.record}")
    if viz is not None and getattr(viz, "rrd_path", None):
        info(f"rerun recording written to {viz.rrd_path}; open it with: rerun {viz.rrd_path}")
    return 0


def _live_session(args, specs, settings, rig, config, stopper):
    from pathlib import Path

    from ..capture.cameras import CameraPairSource
    from ..errors import StereotrackError
    from ..pipeline.assemble import make_tracker, open_sinks
    from ..pipeline.run import close_all
    from ..recording import JPEG_QUALITY
    from ..sinks.recorder import RecordingSink, TrackedFramesSink

    names = [c.name for c in rig.cameras]
    from ..files import check_output

    out_csv = check_output(args.out, "--out", "tracks CSV", [args.calib, args.config]) if args.out else None  # before anything starts
    recorder = None
    if args.record:
        from ..config import config_to_dict

        out = Path(args.record)
        if out.exists() and (not out.is_dir() or any(out.iterdir())):
            raise StereotrackError(f"--record {out}: exists and is not an empty folder (choose another --record folder)")
        # every pair the cameras delivered, with the rig and targets in force; tracked.csv says which were tracked
        recorder = RecordingSink(
            out,
            names,
            settings.fps or 30.0,
            rig=rig,
            codec=args.codec,
            source="live",
            targets=config_to_dict(config),
            extra_meta={"devices": dict(zip(names, specs))},
        )
    tracker = make_tracker("particles", rig, config, keep_rays=getattr(args, "viz_rays", False))
    extra = [TrackedFramesSink(recorder)] if recorder is not None else []
    # without --seconds only Ctrl-C ends the run: a served viewer then stops with it (no second Ctrl-C)
    sinks = open_sinks(
        args, rig, config, tracks_csv=out_csv, live=True, extra=extra, protect=[args.calib, args.config], hold=args.seconds is not None
    )
    viz = next((s for s in sinks if hasattr(s, "rrd_path")), None)
    try:
        # queue_size=1: the tracker always gets the newest pair; latency cannot build up
        source = CameraPairSource(
            specs,
            names,
            settings,
            rig=rig,
            queue_size=1,
            stall_timeout=args.stall_timeout,
            recorder=recorder,
            jpeg_quality=JPEG_QUALITY if recorder is not None and args.codec == "mjpg" else None,
        )
    except BaseException:
        close_all(sinks)  # a camera that does not open: the sinks' threads and files end here, not at exit
        raise
    stopper.add(source.request_stop)
    summary, latency = run_live(source, tracker, sinks, args.seconds, show=not args.quiet, recorder=recorder)
    return source, recorder, summary, latency, viz
