"""The viewer's command-line flags (shared by track, live and demo) and the sink they ask for."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from ...camera import Rig
from ...config import Config
from ...files import check_output
from .process import check_serve_address, check_viewer_listens, normalise_connect_url
from .sink import RerunSink, VizOutputs, VizSettings


def add_viz_arguments(parser: argparse.ArgumentParser) -> None:
    """The viewer flags shared by `track`, `live` and `demo`."""
    from ...argtypes import number, port

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
    g.add_argument("--serve-port", metavar="PORT", type=port, default=9876, help="gRPC port for --serve (default 9876)")
    g.add_argument("--web-port", metavar="PORT", type=port, default=9090, help="web viewer port for --serve (default 9090)")
    g.add_argument(
        "--viz-every",
        metavar="N",
        type=number(1, 1_000_000, integer=True),
        default=VizSettings.every,
        help="log every N-th frame (default 1)",
    )
    g.add_argument(
        "--viz-max-particles",
        metavar="K",
        type=number(1, 10_000_000, integer=True),
        default=VizSettings.max_particles,
        help=f"log at most K particles per target and frame, a random subsample (default {VizSettings.max_particles})",
    )
    g.add_argument(
        "--viz-jpeg-quality",
        metavar="Q",
        type=number(0, 100, integer=True),
        default=VizSettings.jpeg_quality,
        help=f"JPEG quality of logged images, 1..100; 0 logs raw pixels (default {VizSettings.jpeg_quality})",
    )
    g.add_argument(
        "--viz-image-scale",
        metavar="S",
        type=number(above=0, hi=1),
        default=VizSettings.image_scale,
        help=f"log camera images at S times their size, 0 < S <= 1; overlays stay in the camera's pixels (default {VizSettings.image_scale})",
    )
    g.add_argument("--no-images", action="store_true", help="do not log camera images")
    g.add_argument("--viz-masks", action="store_true", help="log the colour masks as a layer over each image")
    g.add_argument("--viz-rays", action="store_true", help="log the abduction's viewing rays")
    g.add_argument(
        "--viz-trail",
        metavar="SECONDS",
        type=number(0, 600),
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
    protect: list = (),
    hold: bool = True,
) -> RerunSink | None:
    """The RerunSink the flags ask for, or None when no viewer output is given (and no default_rrd).

    ``live=True`` (live cameras): when logging lags, frames are skipped rather
    than waited for, so the viewer never holds the tracker back. ``protect``:
    the run's inputs and other outputs, which --rrd may not name. ``hold``: a
    served viewer keeps serving after the run until Ctrl-C.
    """
    outputs = VizOutputs(
        rrd=Path(args.rrd) if args.rrd is not None else (Path(default_rrd) if default_rrd else None),
        spawn=args.spawn,
        connect=args.connect,
        serve=args.serve,
        bind=args.bind,
        grpc_port=args.serve_port,
        web_port=args.web_port,
        hold=hold,
    )
    if not outputs.any:
        return None
    if outputs.rrd is not None:
        check_output(outputs.rrd, "--rrd", "rerun recording", protect)
    if outputs.connect:  # network checks first: they fail in a second, before rerun and the tracker are loaded
        check_viewer_listens(normalise_connect_url(outputs.connect))
    if outputs.serve:
        check_serve_address(outputs.bind, [("--serve-port", outputs.grpc_port), ("--web-port", outputs.web_port)])
    return RerunSink(
        rig, config, outputs, viz_settings_from_args(args, seed=config.tracker.seed, live=live), truth=truth, recording_name=recording_name
    )
