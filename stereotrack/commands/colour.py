"""Target colours: learn an HSV range from a region of a recorded frame.

  stereotrack colour learn RECORDING --frame N --camera cam0 --roi x,y,w,h --name pink

Draw the region tightly around one ball (pixel coordinates: x, y of the
top-left corner, width, height; a rerun view of the recording shows them).
The learned target is written to --config (default: the recording's own
targets file, created and named in its meta.yaml if it has none), replacing
a target of the same name. It warns when the range also covers much of the
rest of the image, which would make the tracker chase the background.
"""

from __future__ import annotations

import argparse

HELP = "learn a target colour's HSV range from a region of a frame"


def add_arguments(p: argparse.ArgumentParser) -> None:
    from ..argtypes import number

    sub = p.add_subparsers(dest="colour_command", metavar="ACTION", required=True)
    learn = sub.add_parser(
        "learn", help="learn a target from a region of a frame", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    learn.add_argument("--debug", action="store_true", default=argparse.SUPPRESS, help="show full tracebacks on errors")
    learn.add_argument("recording", help="recording folder")
    learn.add_argument("--frame", type=number(0, integer=True), default=0, help="frame number (default 0)")
    learn.add_argument("--camera", default=None, help="camera name (default: the first)")
    learn.add_argument("--roi", required=True, help="region x,y,w,h in pixels, tight around one ball")
    learn.add_argument("--name", required=True, help="target name, e.g. pink")
    learn.add_argument(
        "--radius", type=number(0.001, 1.0), default=None, help="ball radius in metres, 0.001..1 (default: keep the target's, else 0.035)"
    )
    learn.add_argument("--config", help="config YAML to write/update (default: the recording's targets file)")
    learn.set_defaults(_run=run_learn)


def run(args) -> int:  # pragma: no cover - argparse requires an action
    return 2


def _parse_roi(text: str) -> tuple[int, int, int, int]:
    from ..errors import StereotrackError

    try:
        x, y, w, h = (int(v) for v in text.split(","))
    except ValueError:
        raise StereotrackError(f"--roi must be x,y,w,h in whole pixels, got {text!r}") from None
    return x, y, w, h


def run_learn(args) -> int:
    from dataclasses import replace
    from pathlib import Path

    from ..config import config_from_dict, load_config, save_config
    from ..console import info, warn
    from ..errors import StereotrackError
    from ..evidence.colour import learn_target
    from ..files import check_output, dump_yaml, write_text_atomic
    from ..recording import open_recording

    if not args.name.strip() or any(c in args.name for c in ",\n\r"):
        raise StereotrackError(f"--name {args.name!r}: expected a target name without commas (it becomes a column of tracks.csv)")
    rec = open_recording(args.recording)
    names = list(rec.camera_names)
    cam = args.camera or names[0]
    if cam not in names:
        raise StereotrackError(f"--camera {cam!r}: the recording's cameras are {', '.join(names)}")
    if not 0 <= args.frame < rec.n_frames:
        raise StereotrackError(f"--frame {args.frame} is outside the recording's {rec.n_frames} frames")
    pair = next(rec.frames(args.frame, args.frame + 1))
    image = pair.images[names.index(cam)]
    if args.config is not None:  # an empty --config is refused below, not taken as the default
        path = Path(args.config)
    elif rec.targets_path is not None:
        path = rec.targets_path
    else:
        path = rec.folder / "config.yaml"
    check_output(path, "--config", "config file", rec.own_files)  # never a recording's meta.yaml, video, ...
    config = load_config(path) if path.exists() else config_from_dict({}, path)
    old = {t.name: t for t in config.targets}
    radius = args.radius if args.radius is not None else (old[args.name].radius if args.name in old else 0.035)
    learned = learn_target(image, _parse_roi(args.roi), args.name, radius=radius)
    t = learned.target
    targets = tuple(t if o.name == t.name else o for o in config.targets) if t.name in old else (*config.targets, t)
    save_config(replace(config, targets=targets), path)
    if args.config is None and rec.targets_path is None:
        meta = dict(rec.meta)
        meta["targets"] = path.name
        write_text_atomic(rec.folder / "meta.yaml", dump_yaml(meta))
    info(f"target {t.name!r}: hsv_min {list(t.hsv_min)}, hsv_max {list(t.hsv_max)}, radius {t.radius} m -> {path}")
    info(f"covers {100 * learned.roi_coverage:.0f}% of the region and {100 * learned.background_coverage:.2f}% of the rest of the image")
    separates = _separation(image, t, _parse_roi(args.roi))
    info(f"colour model: separates the ball from the rest of the range by {separates:.2f} (1: perfectly, 0: no better than the range)")
    if learned.background_coverage > 0.01:
        warn(
            f"the range also covers {100 * learned.background_coverage:.1f}% of the image outside the region: "
            "the tracker may chase background of that colour; pick a tighter region, improve the lighting, or edit hsv_min/hsv_max"
        )
    return 0


def _separation(image, target, roi) -> float:
    """How well the tracker's colour model (evidence/colour_model.py) tells the ball's pixels in the region from the
    other pixels in the range, learnt from this one image."""
    import numpy as np

    from ..evidence.colour import target_mask, to_hsv
    from ..evidence.colour_model import ColourModel, separation

    hsv = to_hsv(image)
    in_range = target_mask(hsv, target)
    x, y, w, h = roi
    ball = np.zeros(in_range.shape, np.uint8)
    ball[y : y + h, x : x + w] = in_range[y : y + h, x : x + w]
    return separation(ColourModel.from_region(target, hsv, ball).probability(hsv), ball, in_range)
