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
    parser.add_argument("scene", nargs="?", metavar="SCENE", help="preset name or scene .yaml file")
    parser.add_argument("--out", metavar="DIR", help="recording folder to write")
    parser.add_argument("--list", action="store_true", help="list the presets and exit")
    parser.add_argument("--frames", type=int, metavar="N", help="number of frame pairs (default: the scene's)")
    parser.add_argument("--fps", type=float, metavar="F", help="frame rate (default 30)")
    parser.add_argument("--seed", type=int, metavar="S", help="random seed (background, noise)")
    parser.add_argument("--width", type=int, metavar="W", help="image width in pixels (default 640)")
    parser.add_argument("--height", type=int, metavar="H", help="image height in pixels (default 480)")
    parser.add_argument("--cameras", type=int, metavar="C", help="number of cameras, >= 2 (default 2)")
    parser.add_argument("--baseline", type=float, metavar="B", help="distance between neighbouring cameras, metres (default 0.3)")
    parser.add_argument(
        "--codec",
        choices=["mjpg", "ffv1"],
        default="mjpg",
        help="video codec: mjpg (default: JPEG quality 95, below the sensor noise, 7x smaller than ffv1) or ffv1 (lossless)",
    )
    parser.add_argument("--overwrite", action="store_true", help="replace the files of an existing --out folder")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    from ..errors import StereotrackError
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
    for key in ("n_frames", "width", "height"):
        if key in overrides and overrides[key] < 1:
            raise StereotrackError(f"--{'frames' if key == 'n_frames' else key} must be at least 1, got {overrides[key]}")
    if "fps" in overrides and overrides["fps"] <= 0:
        raise StereotrackError(f"--fps must be positive, got {overrides['fps']}")
    if args.scene.endswith((".yaml", ".yml")) or Path(args.scene).is_file():
        import yaml

        base = load_scene_yaml(args.scene)  # validates the file
        if overrides:
            data = yaml.safe_load(Path(args.scene).read_text())
            rig_keys = {"width", "height", "cameras", "baseline"}
            data.setdefault("rig", {})
            data["rig"] = dict(data["rig"] or {}, **{k: v for k, v in overrides.items() if k in rig_keys})
            data.update({k: v for k, v in overrides.items() if k not in rig_keys})
            base = scene_from_dict(data, args.scene)
        spec = base
    else:
        spec = make_preset(args.scene, **overrides)
    out = render_scene(spec, args.out, progress=not args.no_progress, codec=args.codec, overwrite=args.overwrite)
    print(f"wrote {spec.n_frames} frame pairs of '{spec.name}' ({len(spec.balls)} balls, {spec.rig.cameras} cameras) to {out}")
    return 0
