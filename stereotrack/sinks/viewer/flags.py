"""The viewer's command-line flags (shared by track, live and demo) and the sink they ask for."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from ...camera import Rig
from ...config import Config
from .process import normalise_connect_url
from .sink import RerunSink, VizOutputs, VizSettings


def _parse_number(text: str, cast, expected: str):
    try:
        return cast(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected {expected}, got {text!r}") from None


def _positive_int(text: str) -> int:
    value = _parse_number(text, int, "a whole number")
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    return value


def _quality(text: str) -> int:
    value = _parse_number(text, int, "a whole number 0..100")
    if not 0 <= value <= 100:
        raise argparse.ArgumentTypeError(f"must be 0 (raw images) or 1..100, got {value}")
    return value


def _scale(text: str) -> float:
    value = _parse_number(text, float, "a number")
    if not 0 < value <= 1:
        raise argparse.ArgumentTypeError(f"must be more than 0 and at most 1, got {value}")
    return value


def _seconds(text: str) -> float:
    value = _parse_number(text, float, "seconds")
    if not 0 <= value <= 600:
        raise argparse.ArgumentTypeError(f"must be between 0 and 600 seconds, got {value}")
    return value


def add_viz_arguments(parser: argparse.ArgumentParser) -> None:
    """The viewer flags shared by `track`, `live` and `demo`."""
    g = parser.add_argument_group("rerun viewer (any of --rrd, --spawn, --connect, --serve turns it on)")
    g.add_argument("--rrd", metavar="FILE", type=Path, help="save the viewer log to FILE.rrd; open it later with 'rerun FILE.rrd'")
    g.add_argument("--spawn", action="store_true", help="start a rerun viewer window on this machine")
    g.add_argument("--connect", metavar="URL", help="stream to a rerun viewer elsewhere: rerun+http://HOST:9876/proxy (or HOST:PORT)")
    g.add_argument(
        "--serve", action="store_true", help="serve gRPC + a web viewer for a browser; keeps serving after a finished run until Ctrl-C"
    )
    g.add_argument(
        "--bind", metavar="ADDR", default="127.0.0.1", help="address --serve listens on (default 127.0.0.1; 0.0.0.0 for every interface)"
    )
    g.add_argument("--serve-port", metavar="PORT", type=_positive_int, default=9876, help="gRPC port for --serve (default 9876)")
    g.add_argument("--web-port", metavar="PORT", type=_positive_int, default=9090, help="web viewer port for --serve (default 9090)")
    g.add_argument("--viz-every", metavar="N", type=_positive_int, default=VizSettings.every, help="log every N-th frame (default 1)")
    g.add_argument(
        "--viz-max-particles",
        metavar="K",
        type=_positive_int,
        default=VizSettings.max_particles,
        help=f"log at most K particles per target and frame, a random subsample (default {VizSettings.max_particles})",
    )
    g.add_argument(
        "--viz-jpeg-quality",
        metavar="Q",
        type=_quality,
        default=VizSettings.jpeg_quality,
        help=f"JPEG quality of logged images, 1..100; 0 logs raw pixels (default {VizSettings.jpeg_quality})",
    )
    g.add_argument(
        "--viz-image-scale",
        metavar="S",
        type=_scale,
        default=VizSettings.image_scale,
        help=f"log camera images at S times their size, 0 < S <= 1; overlays stay in the camera's pixels (default {VizSettings.image_scale})",
    )
    g.add_argument("--no-images", action="store_true", help="do not log camera images")
    g.add_argument("--viz-masks", action="store_true", help="log the colour masks as a layer over each image")
    g.add_argument("--viz-rays", action="store_true", help="log the abduction's viewing rays")
    g.add_argument(
        "--viz-trail",
        metavar="SECONDS",
        type=_seconds,
        default=VizSettings.trail_seconds,
        help="length of the tracks' fading trails (default 2)",
    )


def viz_settings_from_args(args: argparse.Namespace, seed: int = 0, live: bool = False) -> VizSettings:
    return VizSettings(
        every=args.viz_every,
        max_particles=args.viz_max_particles,
        images=not args.no_images,
        jpeg_quality=args.viz_jpeg_quality,
        image_scale=args.viz_image_scale,
        masks=args.viz_masks,
        rays=args.viz_rays,
        trail_seconds=args.viz_trail,
        seed=seed,
        skip_when_behind=live,
    )


def make_viz_sink(
    args: argparse.Namespace,
    rig: Rig,
    config: Config,
    truth: np.ndarray | None = None,
    default_rrd: str | Path | None = None,
    recording_name: str | None = None,
    live: bool = False,
) -> RerunSink | None:
    """The RerunSink the flags ask for, or None when no viewer output is given (and no default_rrd).

    ``live=True`` (live cameras): when logging lags, frames are skipped rather
    than waited for, so the viewer never holds the tracker back.
    """
    outputs = VizOutputs(
        rrd=Path(args.rrd) if args.rrd is not None else (Path(default_rrd) if default_rrd else None),
        spawn=args.spawn,
        connect=args.connect,
        serve=args.serve,
        bind=args.bind,
        grpc_port=args.serve_port,
        web_port=args.web_port,
    )
    if not outputs.any:
        return None
    if outputs.connect:
        normalise_connect_url(outputs.connect)  # a bad URL fails before any work starts
    return RerunSink(
        rig, config, outputs, viz_settings_from_args(args, seed=config.tracker.seed, live=live), truth=truth, recording_name=recording_name
    )
