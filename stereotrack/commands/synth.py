"""Render a synthetic stereo scene with exact ground truth into a recording folder.

SCENE is a preset name (see --list) or a scene .yaml file. The folder gets one
video per camera, frames.csv, calib.yaml, truth.csv (frame,object_id,x,y,z,
visible) and config.yaml with target colours that cover the rendered balls.

examples:
  stereotrack synth --list
  stereotrack synth pendulum4 --out recordings/pendulum4
  stereotrack synth juggle5 --fps 60 --out recordings/juggle5_60
  stereotrack synth my_scene.yaml --out recordings/mine --frames 100 --seed 3
"""

from __future__ import annotations

import argparse

HELP = "render a synthetic scene (preset or scene .yaml) with ground truth"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from ..argtypes import number

    parser.add_argument("scene", nargs="?", metavar="SCENE", help="preset name or scene .yaml file")
    parser.add_argument("--out", metavar="DIR", help="recording folder to write")
    parser.add_argument("--list", action="store_true", help="list the presets and exit")
    parser.add_argument("--frames", type=number(1, 100_000, integer=True), metavar="N", help="number of frame pairs (default: the scene's)")
    parser.add_argument("--fps", type=number(above=0, hi=1000), metavar="F", help="frame rate (default 30)")
    parser.add_argument("--seed", type=number(0, 2**32 - 1, integer=True), metavar="S", help="random seed (background, noise)")
    parser.add_argument("--width", type=number(32, 8192, integer=True), metavar="W", help="image width in pixels (default 640)")
    parser.add_argument("--height", type=number(32, 8192, integer=True), metavar="H", help="image height in pixels (default 480)")
    parser.add_argument("--cameras", type=number(2, 8, integer=True), metavar="C", help="number of cameras, >= 2 (default 2)")
    parser.add_argument(
        "--baseline", type=number(above=0, hi=10), metavar="B", help="distance between neighbouring cameras, metres (default 0.3)"
    )
    parser.add_argument(
        "--codec",
        choices=["mjpg", "ffv1"],
        default="mjpg",
        help="video codec: mjpg (default: JPEG quality 95, below the sensor noise, 7x smaller than ffv1) or ffv1 (lossless)",
    )
    parser.add_argument("--overwrite", action="store_true", help="replace an earlier recording at --out (never a folder of other files)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")


def run(args: argparse.Namespace) -> int:
    import os
    import shutil
    from pathlib import Path

    from ..errors import StereotrackError
    from ..files import check_output_folder, load_yaml, replace_folder
    from ..simulation.presets import PRESETS, load_scene_yaml, make_preset, scene_from_dict
    from ..simulation.write import render_scene

    if args.list:
        width = max(len(n) for n in PRESETS)
        for name, (_, description) in PRESETS.items():
            print(f"{name:<{width}}  {description}")
        return 0
    if not args.scene:
        raise StereotrackError("give a preset name or a scene .yaml file (see 'stereotrack synth --list')")
    if not args.out:
        raise StereotrackError("give the recording folder to write with --out DIR")
    overrides = {
        key: value
        for key, value in (
            ("fps", args.fps),
            ("n_frames", args.frames),
            ("seed", args.seed),
            ("width", args.width),
            ("height", args.height),
            ("cameras", args.cameras),
            ("baseline", args.baseline),
        )
        if value is not None
    }
    out = check_output_folder(args.out, "--out", args.overwrite)
    if args.scene.endswith((".yaml", ".yml")) or Path(args.scene).is_file():
        base = load_scene_yaml(args.scene)  # validates the file
        if overrides:
            data = load_yaml(args.scene)
            rig_keys = {"width", "height", "cameras", "baseline"}
            data.setdefault("rig", {})
            data["rig"] = dict(data["rig"] or {}, **{k: v for k, v in overrides.items() if k in rig_keys})
            data.update({k: v for k, v in overrides.items() if k not in rig_keys})
            base = scene_from_dict(data, args.scene)
        spec = base
    else:
        spec = make_preset(args.scene, **overrides)
    # Rendered under a temporary name and put in place when complete: a failed render leaves --out as it was.
    partial = out.with_name(f".{out.name}.{os.getpid()}.partial")
    try:
        render_scene(spec, partial, progress=not args.no_progress, codec=args.codec)
    except BaseException:
        shutil.rmtree(partial, ignore_errors=True)
        raise
    replace_folder(partial, out)
    print(f"wrote {spec.n_frames} frame pairs of '{spec.name}' ({len(spec.balls)} balls, {spec.rig.cameras} cameras) to {out}")
    return 0
