"""List the video devices OpenCV can open, or check that two or more cameras run in sync.

Without camera flags: probes indices 0..--probe-max quietly and prints, for each
device that opens and delivers a frame, its index, its default resolution,
frame rate and pixel format (and its name on Linux). Exit status: 0 when at
least one device was found, 1 when none was (with a message saying what to check).

With --cam0 SPEC --cam1 SPEC [...]: captures for --seconds through the same
pairing as `stereotrack record` and reports the frame rate of each camera, how
far apart paired frames were taken (median and worst), and how many frames
found no partner. Exit status 0 when pairs were formed, 2 otherwise.

examples:
  stereotrack cameras
  stereotrack cameras --cam0 0 --cam1 2 --seconds 5
"""

from __future__ import annotations

import argparse

from ._capture_args import DEVICE_HELP, add_camera_arguments, camera_specs, capture_settings

HELP = "list the cameras OpenCV can open, or check two cameras' sync"
__doc__ = __doc__ + "\n" + DEVICE_HELP


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from ..argtypes import number

    parser.add_argument(
        "--probe-max", type=number(0, 63, integer=True), default=9, metavar="N", help="probe device indices 0..N (default 9)"
    )
    parser.add_argument(
        "--seconds", type=number(above=0, hi=3600), default=3.0, help="with --cam0/--cam1: how long to check sync (default 3)"
    )
    add_camera_arguments(parser, required=False)


def _device_name(index: int) -> str:
    from pathlib import Path

    p = Path(f"/sys/class/video4linux/video{index}/name")
    try:
        return p.read_text().strip()
    except OSError:
        return ""


def list_devices(probe_max: int) -> list[dict]:
    """Devices that open and deliver a frame, with their default size, rate and pixel format."""
    import sys

    import cv2

    from ..capture.devices import fourcc_text

    cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_SILENT)  # failed probes are expected, not news
    backend = cv2.CAP_V4L2 if sys.platform.startswith("linux") else cv2.CAP_ANY
    found = []
    for index in range(probe_max + 1):
        cap = cv2.VideoCapture(index, backend)
        try:
            if not cap.isOpened():
                continue
            ok, frame = cap.read()
            if not ok or frame is None:
                continue  # e.g. a UVC metadata node: opens, never delivers images
            found.append(
                {
                    "index": index,
                    "name": _device_name(index),
                    "width": frame.shape[1],
                    "height": frame.shape[0],
                    "fps": cap.get(cv2.CAP_PROP_FPS),
                    "fourcc": fourcc_text(cap.get(cv2.CAP_PROP_FOURCC)),
                    "backend": cap.getBackendName(),
                }
            )
        finally:
            cap.release()
    return found


def check_sync(specs: list[str], settings, seconds: float, stall_timeout: float) -> int:
    import time

    import numpy as np

    from ..capture.cameras import CameraPairSource
    from ..capture.signals import StopOnSignals
    from ..errors import StereotrackError

    spreads, size = [], None
    with StopOnSignals() as stopper:
        source = CameraPairSource(specs, settings=settings, queue_size=64, stall_timeout=stall_timeout)
        stopper.add(source.request_stop)
        try:
            start = time.monotonic()
            for pair in source:
                spreads.append(max(pair.timestamps) - min(pair.timestamps))
                size = pair.images[0].shape[1::-1]
                if time.monotonic() - start >= seconds:
                    break
        finally:
            source.close()
    stats = source.stats
    for cam in stats.cameras:
        print(f"{cam.name}: {cam.device}: {cam.frames} frames, {cam.fps:.1f} fps, {cam.unpaired} unpaired")
    if not spreads:
        raise StereotrackError(
            f"no frame pair formed in {seconds:g} s (pairing tolerance {1000 * source.tolerance:.1f} "
            "ms): the cameras run at different rates or one is not delivering"
        )
    s = np.asarray(spreads) * 1000
    print(
        f"{len(s)} pairs at {size[0]}x{size[1]}, {len(s) / seconds:.1f} pairs/s; capture time difference within a pair: "
        f"median {np.median(s):.1f} ms, worst {s.max():.1f} ms (tolerance {1000 * source.tolerance:.1f} ms)"
    )
    return 0


def run(args: argparse.Namespace) -> int:
    if any(getattr(args, f"cam{i}") for i in range(4)):
        return check_sync(camera_specs(args), capture_settings(args), args.seconds, args.stall_timeout)

    devices = list_devices(args.probe_max)
    if not devices:
        from ..errors import StereotrackError

        raise StereotrackError(
            f"no video devices found (probed indices 0..{args.probe_max}): check that the webcams are plugged in, "
            "that `v4l2-ctl --list-devices` shows them, and that you may read /dev/video* (the 'video' group)"
        )
    for d in devices:
        name = f"  {d['name']}" if d["name"] else ""
        print(f"{d['index']}: {d['width']}x{d['height']} {d['fps']:.0f} fps {d['fourcc'] or '?'} ({d['backend']}){name}")
    return 0
