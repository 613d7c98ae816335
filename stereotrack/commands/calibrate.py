"""Calibrate two or more cameras from views of a board: intrinsics, relative poses, quality report.

Views come from one of:
  --images DIR0 DIR1 [...]   one folder (or quoted glob pattern) per camera; images of one
                             view have the same name (cam0/001.png <-> cam1/001.png); with
                             patterns, the part the wildcard matched ('left*.jpg' 'right*.jpg':
                             left01.jpg <-> right01.jpg)
  --recording DIR            a recording folder; frames where at least two cameras see the
                             board in a new pose are used
  --cam0 SPEC --cam1 SPEC    live cameras: a view is taken when the board is steady, seen by
                             both cameras and different from the views already taken; stop
                             with Ctrl-C or when --max-views are taken

Every camera's intrinsics and pose and every board pose are refined together (a bundle
adjustment over all views, any number of cameras). Writes the calibration YAML (--out, with
a 'quality' section) and a report next to it (calib/NAME.report.yaml): per-camera, per-pair
and per-view residuals after the fit, epipolar error, each baseline with its uncertainty,
image coverage and a verdict (good / usable / redo).

See what it saw: --rrd FILE logs every view (image, detected and fitted corners, residuals),
the coverage per camera and the board poses in 3D for the rerun viewer (--spawn or --connect
show live calibration as it goes); --save-views DIR writes the same as annotated PNGs.

examples:
  stereotrack calibrate --board calib/board.yaml --images shots/cam0 shots/cam1 --out calib/desk.yaml
  stereotrack calibrate --board calib/board.yaml --recording recordings/calib1 --out calib/desk.yaml
  stereotrack calibrate --board calib/board.yaml --cam0 0 --cam1 2 --out calib/desk.yaml
  stereotrack calibrate ... --drop-worst 2          # drop the 2 worst views and calibrate again
  stereotrack calibrate ... --world-view 007        # the board in view 007 (flat on the floor) is the world, z up
  stereotrack calibrate ... --rrd calib/desk.rrd --save-views calib/desk-views   # see what it saw
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ._capture_args import DEVICE_HELP, add_camera_arguments, camera_specs, capture_settings

HELP = "calibrate cameras from board images, a recording or live cameras, with a quality report"
__doc__ = __doc__ + "\n" + DEVICE_HELP


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from ..argtypes import number

    parser.add_argument("--board", default="calib/board.yaml", metavar="YAML", help="board description (default calib/board.yaml)")
    parser.add_argument(
        "--out", required=True, metavar="YAML", help="calibration file to write (e.g. calib/desk.yaml); the report goes beside it"
    )
    src = parser.add_argument_group("views (one of)")
    src.add_argument("--images", nargs="+", metavar="DIR", help="one image folder or quoted glob pattern per camera")
    src.add_argument("--recording", metavar="DIR", help="a recording folder")
    parser.add_argument("--names", nargs="+", metavar="NAME", help="camera names (default cam0 cam1 ..., or the recording's)")
    parser.add_argument(
        "--max-views", type=number(5, 10_000, integer=True), default=30, help="recording / live: stop after this many views (default 30)"
    )
    parser.add_argument(
        "--every",
        type=number(1, 1_000_000, integer=True),
        default=None,
        metavar="N",
        help="recording: look at every N-th frame pair (default: about 300 pairs in all)",
    )
    parser.add_argument("--seconds", type=number(above=0, hi=86_400), default=None, help="live: stop after this many seconds")
    m = parser.add_argument_group("lens model and solving")
    m.add_argument("--fix-aspect", action="store_true", help="square pixels: fx = fy")
    m.add_argument("--zero-tangent", action="store_true", help="no tangential distortion")
    m.add_argument("--fix-k3", action="store_true", help="no 6th-order radial term (steadier with few views)")
    m.add_argument("--rational", action="store_true", help="8-coefficient rational distortion model (wide-angle lenses)")
    m.add_argument(
        "--refine", action="store_true", help=argparse.SUPPRESS
    )  # the joint refinement is the default now; old command lines still run
    m.add_argument(
        "--subpix",
        type=number(1, 50, integer=True),
        default=None,
        metavar="PX",
        help="chessboard corner refinement half-window in pixels (default: a quarter of the corner spacing)",
    )
    parser.add_argument(
        "--drop-worst",
        type=number(0, 1000, integer=True),
        default=0,
        metavar="N",
        help="drop the N worst views (named in the report) and calibrate again",
    )
    parser.add_argument(
        "--world-view",
        metavar="VIEW",
        help="use the board pose in this view as the world frame (origin at the board's corner, z up out of the board)",
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress line")
    _add_seeing_arguments(parser)
    add_camera_arguments(parser, required=False)


def _add_seeing_arguments(parser: argparse.ArgumentParser) -> None:
    g = parser.add_argument_group("see what it saw")
    g.add_argument(
        "--rrd", metavar="FILE", help="log the views, corners, residuals, coverage and board poses to FILE.rrd for 'rerun FILE.rrd'"
    )
    g.add_argument("--spawn", action="store_true", help="show them in a rerun viewer window (live: each view as it is taken)")
    g.add_argument("--connect", metavar="URL", help="stream them to a rerun viewer elsewhere: rerun+http://HOST:9876/proxy (or HOST:PORT)")
    g.add_argument(
        "--save-views", metavar="DIR", help="write every view with its corners and residuals drawn, and each camera's coverage, as PNGs"
    )


def run(args: argparse.Namespace) -> int:
    from ..calibration.boards import load_board
    from ..calibration.report import format_report, report_path, save_report
    from ..calibration.solve import CalibrationOptions, calibrate
    from ..camera import save_rig

    _check_arguments(args)
    board = load_board(args.board)
    progress = not args.no_progress
    keep_images = _wants_viewer(args) or args.save_views is not None
    viewer = _open_viewer(args, board, _camera_names(args)) if _live(args) and _wants_viewer(args) else None
    try:
        views = _collect_views(args, board, progress, keep_images, viewer)
        if args.save_views is not None:  # now that the views' names are known, before the fit and any file is written
            from ..calibration.annotate import check_view_files, view_files

            check_view_files(view_files(args.save_views, views.view_names, views.camera_names), args.images or [])
        options = CalibrationOptions(
            fix_aspect=args.fix_aspect,
            zero_tangent=args.zero_tangent,
            fix_k3=args.fix_k3,
            rational=args.rational,
            drop_worst=args.drop_worst,
            world_view=args.world_view,
        )
        result = calibrate(views, board, options)
        save_rig(result.rig, args.out)
        rpath = report_path(args.out)
        save_report({"calibration": str(args.out), **result.report}, rpath)
        print(format_report(result.report))
        print(f"wrote {args.out} and {rpath}")
        if args.save_views is not None:
            from ..calibration.annotate import save_views

            written = save_views(result, args.save_views, args.images or [])
            print(f"wrote {len(written)} annotated images to {args.save_views}")
        if _wants_viewer(args):  # image folders and recordings: the viewer opens once the fit succeeded
            viewer = viewer or _open_viewer(args, board, views.camera_names)
            viewer.log_fit(result)
    finally:
        if viewer is not None:
            viewer.close()  # the .rrd takes its name here, and only when the run did not fail
    if viewer is not None and viewer.rrd_path is not None:
        print(f"wrote {viewer.rrd_path}: open it with 'rerun {viewer.rrd_path}'")
    return 0


def _check_arguments(args: argparse.Namespace) -> None:
    """Problems with the command line and its outputs, before any work (each one line)."""
    from ..calibration.report import report_path
    from ..errors import StereotrackError
    from ..files import check_output

    chosen = sum([bool(args.images), bool(args.recording), _live(args)])
    if chosen != 1:
        raise StereotrackError("give exactly one source of views: --images DIR0 DIR1, --recording DIR, or --cam0 SPEC --cam1 SPEC")
    if not str(args.out).endswith((".yaml", ".yml")):
        raise StereotrackError(f"--out must be a .yaml file, got {args.out}")
    if args.names and (len(set(args.names)) != len(args.names) or any(not n.strip() or "," in n for n in args.names)):
        raise StereotrackError(f"--names {' '.join(args.names)}: expected distinct camera names without commas")
    if args.rrd is not None and not str(args.rrd).endswith(".rrd"):
        raise StereotrackError(f"--rrd must be a .rrd file, got {args.rrd}")
    # Every output is checked before any work: a calibration that takes minutes never ends in a refused file.
    rpath = report_path(args.out)
    check_output(args.out, "--out", "calibration file", [args.board])
    check_output(rpath, "--out (its report)", "calibration report", [args.board])
    if args.rrd is not None:
        check_output(args.rrd, "--rrd", "rerun recording", [args.board, args.out, rpath])
    if args.save_views is not None:
        from ..calibration.annotate import check_views_folder

        check_views_folder(args.save_views, args.images or [])
    if args.connect:  # a viewer that is not there is found now, not after the fit
        from ..sinks.viewer.process import check_viewer_listens, normalise_connect_url

        check_viewer_listens(normalise_connect_url(args.connect))


def _live(args: argparse.Namespace) -> bool:
    return getattr(args, "cam0", None) is not None


def _wants_viewer(args: argparse.Namespace) -> bool:
    return bool(args.rrd or args.spawn or args.connect)


def _camera_names(args: argparse.Namespace) -> list[str]:
    return list(args.names) if args.names else [f"cam{i}" for i in range(len(camera_specs(args)))]


def _open_viewer(args: argparse.Namespace, board, camera_names):
    from ..sinks.viewer.calibration import CalibrationViewer
    from ..sinks.viewer.sink import VizOutputs

    outputs = VizOutputs(rrd=Path(args.rrd) if args.rrd else None, spawn=args.spawn, connect=args.connect)
    return CalibrationViewer(outputs, board, camera_names)


def _collect_views(args: argparse.Namespace, board, progress: bool, keep_images: bool, viewer):
    from ..calibration.views import views_from_frames, views_from_images
    from ..errors import StereotrackError

    if args.images:
        if args.names and len(args.names) != len(args.images):
            raise StereotrackError(f"--names gives {len(args.names)} names for {len(args.images)} image folders")
        return views_from_images(board, args.images, args.names, subpix_window=args.subpix, progress=progress, keep_images=keep_images)
    if args.recording:
        from ..recording import open_recording

        rec = open_recording(args.recording)
        names = args.names or list(rec.camera_names)
        if len(names) != len(rec.camera_names):
            raise StereotrackError(f"--names gives {len(names)} names but the recording has {len(rec.camera_names)} cameras")
        every = args.every or max(1, rec.n_frames // 300)
        if every < 1:
            raise StereotrackError(f"--every must be 1 or more, got {every}")
        return views_from_frames(
            board,
            rec.frames(),
            names,
            every=every,
            max_views=args.max_views,
            steady_px=2.0,
            total=rec.n_frames,
            progress=progress,
            subpix_window=args.subpix,
            keep_images=keep_images,
        )
    return _live_views(args, board, progress, keep_images, viewer)


def _live_views(args, board, progress, keep_images, viewer):
    import time

    from ..calibration.views import views_from_frames
    from ..capture.cameras import CameraPairSource
    from ..capture.signals import StopOnSignals
    from ..errors import StereotrackError

    specs = camera_specs(args)
    if args.names and len(args.names) != len(specs):
        raise StereotrackError(f"--names gives {len(args.names)} names for {len(specs)} cameras")
    with StopOnSignals() as stopper:  # a signal, even while the cameras open, ends the capture cleanly
        source = CameraPairSource(
            specs, camera_names=args.names, settings=capture_settings(args), queue_size=2, stall_timeout=args.stall_timeout
        )
        stopper.add(source.request_stop)
        start = time.monotonic()

        def frames():
            for pair in source:
                if args.seconds is not None and time.monotonic() - start > args.seconds:
                    return
                yield pair

        print("hold the board still in view of both cameras; move it to a new place and angle after each view is taken (Ctrl-C to finish)")
        try:
            return views_from_frames(
                board,
                frames(),
                source.camera_names,
                every=1,
                max_views=args.max_views,
                steady_px=2.0,
                progress=progress,
                label="live: taking board views",
                keep_images=keep_images,
                on_view=viewer.log_views if viewer is not None else None,
            )
        finally:
            source.close()
