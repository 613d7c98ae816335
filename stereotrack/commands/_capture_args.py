"""Command-line flags shared by the commands that open cameras (record, live, cameras --check).

Kept free of heavy imports: it runs while building ``--help``.
"""

from __future__ import annotations

import argparse

MAX_CAMERAS = 4

DEVICE_HELP = """\
camera devices (--cam0 SPEC, --cam1 SPEC, ... up to --cam3):
  0, 2, ...             a webcam by OpenCV index (Linux: /dev/video0, /dev/video2;
                        `stereotrack cameras` lists them)
  path/to/video.mkv     a video file, delivered at its own frame rate
  sim:PRESET[,k=v...]   a simulated camera filming a synthetic scene (presets:
                        `stereotrack synth --list`; sim:dots is a cheap test
                        pattern). Options: view=N (camera of the scene's rig,
                        default the slot), jitter=SECONDS (timestamp jitter s.d.,
                        0.002), drop=P (lost-frame probability, 0.01),
                        stop=SECONDS (hang after that long, like an unplugged
                        webcam), seed=N, loop=SECONDS (at most 10; render that long up
                        front and loop it: a camera that costs no CPU)
"""


def add_camera_arguments(parser: argparse.ArgumentParser, required: bool = True) -> None:
    from ..argtypes import number

    g = parser.add_argument_group("cameras")
    for i in range(MAX_CAMERAS):
        g.add_argument(
            f"--cam{i}",
            metavar="SPEC",
            required=required and i < 2,
            help=f"device for camera cam{i}" + (" (required)" if required and i < 2 else ""),
        )
    g.add_argument("--width", type=number(16, 16384, integer=True), default=640, help="requested frame width (default 640)")
    g.add_argument("--height", type=number(16, 16384, integer=True), default=480, help="requested frame height (default 480)")
    g.add_argument("--fps", type=number(above=0, hi=1000), default=30.0, help="requested frame rate (default 30)")
    g.add_argument(
        "--fourcc", default="MJPG", help="requested pixel format (default MJPG: two USB webcams can share a bus; 'none' = device default)"
    )
    g.add_argument(
        "--exposure",
        type=number(0, 1e9),
        default=None,
        help="manual exposure in device units (V4L2: 100 µs); default: leave the device's setting",
    )
    g.add_argument("--gain", type=number(0, 1e9), default=None, help="manual gain in device units; default: leave the device's setting")
    g.add_argument(
        "--white-balance",
        type=number(1000, 20000),
        default=None,
        metavar="KELVIN",
        help="manual white balance; default: leave the device's setting",
    )
    g.add_argument(
        "--stall-timeout",
        type=number(above=0, hi=3600),
        default=2.0,
        metavar="S",
        help="give up when a camera delivers nothing for S seconds (default 2)",
    )


def camera_specs(args: argparse.Namespace) -> list[str]:
    """The --camN specs in order; gaps are a user error."""
    from ..errors import StereotrackError

    specs = [getattr(args, f"cam{i}", None) for i in range(MAX_CAMERAS)]
    while specs and specs[-1] is None:
        specs.pop()
    if len(specs) < 2 or None in specs:
        raise StereotrackError("give cameras as --cam0 SPEC --cam1 SPEC [--cam2 SPEC ...] without gaps")
    return specs


def capture_settings(args: argparse.Namespace):
    from ..capture.devices import CaptureSettings
    from ..errors import StereotrackError

    for name in ("width", "height", "fps"):
        if getattr(args, name) <= 0:
            raise StereotrackError(f"--{name} must be positive, got {getattr(args, name)}")
    if args.stall_timeout <= 0:
        raise StereotrackError(f"--stall-timeout must be positive, got {args.stall_timeout}")
    fourcc = None if str(args.fourcc).lower() == "none" else str(args.fourcc)
    if fourcc is not None and len(fourcc) != 4:
        raise StereotrackError(f"--fourcc must be four characters (e.g. MJPG, YUYV) or 'none', got {args.fourcc!r}")
    return CaptureSettings(args.width, args.height, args.fps, fourcc, args.exposure, args.gain, args.white_balance)
