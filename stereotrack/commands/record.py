"""Record synchronised frame pairs from two or more cameras into a recording folder.

Frames are paired by capture timestamp (within half a frame period); every pair
is written at once (videos + a flushed frames.csv row), so the folder stays
readable whatever happens. One status line on stderr shows frames/s per
camera, pairs dropped because the disk was too slow, and frames left unpaired.

Stop with Ctrl-C (or SIGTERM) or --seconds: the folder is complete (exit 0).
A camera that stops delivering frames ends the recording after --stall-timeout
seconds with a message (exit 2); everything recorded so far is kept.

examples:
  stereotrack record --cam0 0 --cam1 2 --out recordings/session1 --calib calib/desk.yaml
  stereotrack record --cam0 sim:pendulum4 --cam1 sim:pendulum4 --out recordings/sim --seconds 10
"""

from __future__ import annotations

import argparse

from ._capture_args import DEVICE_HELP, add_camera_arguments, camera_specs, capture_settings

HELP = "record synchronised frames from two or more cameras"
__doc__ = __doc__ + "\n" + DEVICE_HELP


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from ..argtypes import number

    parser.add_argument("--out", required=True, metavar="DIR", help="recording folder to create (recordings/NAME)")
    parser.add_argument(
        "--calib", metavar="FILE", help="calibration YAML to store with the recording (its cameras and image size must match)"
    )
    parser.add_argument("--seconds", type=number(above=0), default=None, help="stop after this many seconds (default: until Ctrl-C)")
    parser.add_argument(
        "--codec",
        choices=("mjpg", "ffv1"),
        default="mjpg",
        help="mjpg (default): the JPEGs an MJPG camera sends, stored as they are (other frames encoded at quality 95); "
        "ffv1: lossless, about 20x larger and too slow for 720p",
    )
    parser.add_argument("--overwrite", action="store_true", help="replace an earlier recording at --out (never a folder of other files)")
    add_camera_arguments(parser)


def run(args: argparse.Namespace) -> int:
    from ..camera import load_rig
    from ..capture.cameras import CameraPairSource
    from ..capture.signals import StopOnSignals
    from ..console import Progress, info
    from ..errors import StereotrackError
    from ..files import check_output_folder
    from ..recording import JPEG_QUALITY
    from ..sinks.recorder import RecordingSink

    specs = camera_specs(args)
    settings = capture_settings(args)
    out = check_output_folder(args.out, "--out", args.overwrite)
    rig = load_rig(args.calib) if args.calib else None
    simulated = all(s.startswith("sim:") for s in specs)
    targets = None
    if simulated and rig is None and not any(s.startswith("sim:dots") for s in specs):
        from ..config import config_to_dict
        from .live import simulated_scene

        rig, config = simulated_scene(specs, settings)  # the scene's rig and targets: the recording can be tracked as it is
        targets = config_to_dict(config)

    with StopOnSignals() as stopper:  # from here on a signal ends the recording cleanly, even during setup
        names = [f"cam{i}" for i in range(len(specs))]
        sink = RecordingSink(
            out,
            names,
            settings.fps or 30.0,
            rig=rig,
            codec=args.codec,
            overwrite=args.overwrite,
            source="simulated cameras" if simulated else "live",
            targets=targets,
            extra_meta={"devices": dict(zip(names, specs))},
        )
        source = CameraPairSource(
            specs,
            names,
            settings=settings,
            rig=rig,
            queue_size=0,
            stall_timeout=args.stall_timeout,
            recorder=sink,
            jpeg_quality=JPEG_QUALITY if args.codec == "mjpg" else None,
            seconds=args.seconds,
        )
        stopper.add(source.request_stop)
        total = round(args.seconds * source.fps) if args.seconds else None
        progress = Progress(total, label="recording", unit="pairs")
        error = None
        try:
            while source.wait(0.2):
                progress.update(sink.count - progress.done, extra=source.stats.line())
        except StereotrackError as exc:
            error = exc
        finally:
            source.close()  # capture threads stop first, then the writer finishes the queue
            try:
                sink.close()
            finally:
                progress.close()
        if error is None:
            sink.check()
    stats = source.stats
    if error is not None:  # one line: the error says what was kept
        kept = f"{sink.count} pairs kept in {out}" if sink.count else "nothing was recorded"
        raise StereotrackError(f"{error}; recording stopped, {kept}")
    if sink.count == 0 and not stopper.signal_name:  # before the status line: an error is one line
        raise StereotrackError(
            "no frame pair was recorded (cameras out of sync or not delivering? check with `stereotrack cameras --check`)"
        )
    how = f"stopped by {stopper.signal_name}" if stopper.signal_name else "done"
    info(f"{how}: {sink.count} pairs in {out} ({stats.line()})")
    return 0
