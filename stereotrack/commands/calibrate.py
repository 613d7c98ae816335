"""Calibrate two or more cameras from views of a board: intrinsics, relative poses, quality report.

Views come from one of:
  --images DIR0 DIR1 [...]   one folder (or quoted glob pattern) per camera; images of one
                             view are matched by name (cam0/001.png <-> cam1/001.png,
                             left01.jpg <-> right01.jpg)
  --recording DIR            a recording folder; frames where at least two cameras see the
                             board in a new pose are used
  --cam0 SPEC --cam1 SPEC    live cameras: a view is taken when the board is steady, seen by
                             both cameras and different from the views already taken; stop
                             with Ctrl-C or when --max-views are taken

Writes the calibration YAML (--out, with a 'quality' section) and a report next to it
(calib/NAME.report.yaml): per-camera and stereo RMS, epipolar error, per-view errors with
the worst views named, baseline, image coverage and a verdict (good / usable / redo).

examples:
  stereotrack calibrate --board calib/board.yaml --images shots/cam0 shots/cam1 --out calib/desk.yaml
  stereotrack calibrate --board calib/board.yaml --recording recordings/calib1 --out calib/desk.yaml
  stereotrack calibrate --board calib/board.yaml --cam0 0 --cam1 2 --out calib/desk.yaml
  stereotrack calibrate ... --drop-worst 2          # drop the 2 worst views and calibrate again
  stereotrack calibrate ... --world-view 007        # the board in view 007 (flat on the floor) is the world, z up
"""

from __future__ import annotations

import argparse

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
    m.add_argument("--refine", action="store_true", help="after the stereo step, refine intrinsics and extrinsics jointly (two cameras)")
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
    add_camera_arguments(parser, required=False)


def run(args: argparse.Namespace) -> int:
    from ..calibration.boards import load_board
    from ..calibration.report import format_report, report_path, save_report
    from ..calibration.solve import CalibrationOptions, calibrate
    from ..calibration.views import views_from_frames, views_from_images
    from ..camera import save_rig
    from ..errors import StereotrackError
    from ..files import check_output

    live = getattr(args, "cam0", None) is not None
    chosen = sum([bool(args.images), bool(args.recording), live])
    if chosen != 1:
        raise StereotrackError("give exactly one source of views: --images DIR0 DIR1, --recording DIR, or --cam0 SPEC --cam1 SPEC")
    if not str(args.out).endswith((".yaml", ".yml")):
        raise StereotrackError(f"--out must be a .yaml file, got {args.out}")
    if args.names and (len(set(args.names)) != len(args.names) or any(not n.strip() or "," in n for n in args.names)):
        raise StereotrackError(f"--names {' '.join(args.names)}: expected distinct camera names without commas")
    check_output(args.out, "--out", "calibration file", [args.board])
    check_output(report_path(args.out), "--out (its report)", "calibration report", [args.board])
    board = load_board(args.board)
    progress = not args.no_progress

    if args.images:
        if args.names and len(args.names) != len(args.images):
            raise StereotrackError(f"--names gives {len(args.names)} names for {len(args.images)} image folders")
        views = views_from_images(board, args.images, args.names, subpix_window=args.subpix, progress=progress)
    elif args.recording:
        from ..recording import open_recording

        rec = open_recording(args.recording)
        names = args.names or list(rec.camera_names)
        if len(names) != len(rec.camera_names):
            raise StereotrackError(f"--names gives {len(names)} names but the recording has {len(rec.camera_names)} cameras")
        every = args.every or max(1, rec.n_frames // 300)
        if every < 1:
            raise StereotrackError(f"--every must be 1 or more, got {every}")
        views = views_from_frames(
            board,
            rec.frames(),
            names,
            every=every,
            max_views=args.max_views,
            steady_px=2.0,
            total=rec.n_frames,
            progress=progress,
            subpix_window=args.subpix,
        )
    else:
        views = _live_views(args, board, progress)

    options = CalibrationOptions(
        fix_aspect=args.fix_aspect,
        zero_tangent=args.zero_tangent,
        fix_k3=args.fix_k3,
        rational=args.rational,
        refine=args.refine,
        drop_worst=args.drop_worst,
        world_view=args.world_view,
    )
    result = calibrate(views, board, options)
    save_rig(result.rig, args.out)
    rpath = report_path(args.out)
    save_report({"calibration": str(args.out), **result.report}, rpath)
    print(format_report(result.report))
    print(f"wrote {args.out} and {rpath}")
    return 0


def _live_views(args, board, progress):
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
            )
        finally:
            source.close()
