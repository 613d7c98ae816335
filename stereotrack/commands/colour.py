"""Target colours: learn a target (HSV range and colour model) from balls in a recording or a video.

  stereotrack colour learn RECORDING --region x,y,w,h --name pink
  stereotrack colour learn RECORDING --region cam0:10:300,200,40,40 --region cam1:80:120,60,36,36 --name pink
  stereotrack colour learn RECORDING --auto

--region (or --roi) marks one ball: x, y of the box's top-left corner, its
width and height in pixels (a rerun view of the recording shows them), on
--frame and --camera, or on the frame and camera it names
(CAMERA:FRAME:x,y,w,h or FRAME:x,y,w,h). Repeat it for balls on several
frames and cameras: the more lighting and places it sees, the better the
target. A region must hold one whole, round ball; a region on a wall, on a
box larger than it, or on no colour at all is refused.

--auto finds the balls itself: blobs that move, are round and have one
saturated hue, grouped by hue. Each group is proposed as a target (named by
its hue, or --name); with a calibrated recording the balls' radius is
measured too. The targets are printed as a config snippet.

RECORDING is a recording folder or a single video file. The learnt targets
are written to --config (default: the recording's own targets file, created
and named in its meta.yaml if it has none; for a video file nothing is
written without --config), replacing a target of the same name. Each target's
colour model (the ball's colours against the room's) goes to a file beside
the config, NAME.colour-model.yaml (or --model), which the target names in
its colour_model field. Every run reports how well that model separates the
ball from the rest of the range (1: perfectly, 0: no better than the range),
on the images it learnt from and on images it did not learn from.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

HELP = "learn a target's colour from regions of frames, or find the balls with --auto"
MIN_SEPARATION = 0.2  # below this the model hardly tells the ball from the rest of the range: say so
AUTO_FRAMES = 300  # frames --auto looks at by default (spread over the recording)


def add_arguments(p: argparse.ArgumentParser) -> None:
    from ..argtypes import number

    sub = p.add_subparsers(dest="colour_command", metavar="ACTION", required=True)
    learn = sub.add_parser(
        "learn", help="learn targets from regions of frames, or find the balls with --auto", description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )  # fmt: skip
    learn.add_argument("--debug", action="store_true", default=argparse.SUPPRESS, help="show full tracebacks on errors")
    learn.add_argument("recording", help="recording folder or video file")
    learn.add_argument("--frame", type=number(0, integer=True), default=0, help="frame of regions that name none (default 0)")
    learn.add_argument("--camera", default=None, help="camera of regions that name none (default: the first)")
    learn.add_argument(
        "--region", "--roi", dest="regions", action="append", metavar="[CAMERA:][FRAME:]x,y,w,h",
        help="a box in pixels around one ball; repeat for several balls, frames or cameras",
    )  # fmt: skip
    learn.add_argument("--auto", action="store_true", help="find the moving, round balls of one hue and propose their targets")
    learn.add_argument(
        "--frames",
        type=number(1, integer=True),
        default=AUTO_FRAMES,
        help=f"--auto: frames to look at, spread over the recording (default {AUTO_FRAMES})",
    )
    learn.add_argument("--name", help="target name, e.g. pink (required with --region; with --auto: the first target's name)")
    learn.add_argument(
        "--radius", type=number(0.001, 1.0), default=None,
        help="ball radius in metres, 0.001..1 (default: measured by --auto on a calibrated recording, else the target's, else 0.035)",
    )  # fmt: skip
    learn.add_argument("--config", help="config YAML to write/update (default: the recording's targets file)")
    learn.add_argument("--model", help="colour model file to write (default: NAME.colour-model.yaml beside the config)")
    learn.set_defaults(_run=run_learn)


def run(args) -> int:  # pragma: no cover - argparse requires an action
    return 2


# --------------------------------------------------------------------------- sources


class _Video:
    """A single video file as a one-camera source (no calibration)."""

    def __init__(self, path: Path):
        import cv2

        from ..errors import StereotrackError

        cap = cv2.VideoCapture(str(path))
        ok = cap.isOpened()
        n = int(cap.get(cv2.CAP_PROP_FRAME_COUNT)) if ok else 0
        w, h = int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)), int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT))
        cap.release()
        if not ok or n <= 0 or w <= 0:
            raise StereotrackError(f"{path}: OpenCV cannot read this video (expected a recording folder or a video file)")
        self.path, self.n_frames, self.size = path, n, (w, h)
        self.camera_names = (path.stem,)
        self.rig = None
        self.folder = path.parent
        self.targets_path = None
        self.own_files = (path,)

    def frames(self, only):
        import cv2

        wanted = sorted(set(int(i) for i in only))
        cap = cv2.VideoCapture(str(self.path))
        try:
            i = 0
            for index in wanted:
                while i < index and cap.grab():
                    i += 1
                ok, image = cap.read()
                i += 1
                if not ok:
                    return
                yield index, (image,)
        finally:
            cap.release()


class _Recording:
    def __init__(self, rec):
        self.rec = rec
        self.n_frames, self.camera_names, self.rig = rec.n_frames, rec.camera_names, rec.rig
        self.size, self.folder, self.targets_path, self.own_files = rec.image_size, rec.folder, rec.targets_path, rec.own_files

    def frames(self, only):
        for pair in self.rec.frames(only=sorted(set(only))):
            yield pair.index, pair.images


def _open(path: str):
    from ..recording import open_recording

    p = Path(path)
    return _Video(p) if p.is_file() else _Recording(open_recording(p))


def _cameras(source):
    """The source's cameras: its calibration, or a webcam's 60-degree field of view standing in."""
    import numpy as np

    from ..camera import Camera, intrinsics_from_fov

    if source.rig is not None:
        return list(source.rig.cameras)
    w, h = source.size
    return [Camera(n, (w, h), intrinsics_from_fov(w, h, 60.0), np.zeros(5), np.eye(3), np.zeros(3)) for n in source.camera_names]


# --------------------------------------------------------------------------- regions


def _parse_region(text: str, args, source) -> tuple[str, int, tuple[int, int, int, int]]:
    """[CAMERA:][FRAME:]x,y,w,h -> (camera, frame, box); a lone prefix that is a whole number is a frame."""
    from ..errors import StereotrackError

    *prefix, box = text.rsplit(":", 2) if text.count(":") >= 2 else text.split(":")
    camera, frame = args.camera, args.frame
    if len(prefix) == 2:
        camera, frame = prefix
    elif len(prefix) == 1:
        if prefix[0].strip().isdigit():
            frame = prefix[0]
        else:
            camera = prefix[0]
    try:
        x, y, w, h = (int(v) for v in box.split(","))
        frame = int(frame)
    except ValueError:
        raise StereotrackError(
            f"--region {text!r}: expected [CAMERA:][FRAME:]x,y,w,h in whole pixels, e.g. cam0:10:300,200,40,40"
        ) from None
    names = list(source.camera_names)
    camera = camera or names[0]
    if camera not in names:
        raise StereotrackError(f"--region {text!r}: camera {camera!r} is not one of the recording's cameras ({', '.join(names)})")
    if not 0 <= frame < source.n_frames:
        raise StereotrackError(f"--region {text!r}: frame {frame} is outside the recording's {source.n_frames} frames")
    return camera, frame, (x, y, w, h)


def _region_images(args, source):
    """One BallImage per (camera, frame) the regions name, its ball pixels the union of its regions' balls."""
    from ..errors import StereotrackError
    from ..evidence.colour import to_hsv
    from ..evidence.learn import BallImage, ball_in_region

    regions = [_parse_region(r, args, source) for r in args.regions]
    names = list(source.camera_names)
    by_frame: dict[int, list] = {}
    for cam, frame, box in regions:
        by_frame.setdefault(frame, []).append((cam, box))
    out = []
    for index, images in source.frames(by_frame):
        for cam in dict.fromkeys(c for c, _ in by_frame[index]):
            hsv = to_hsv(images[names.index(cam)])
            ball = sum(ball_in_region(hsv, box, f"{cam} frame {index}") for c, box in by_frame[index] if c == cam)
            out.append(BallImage(hsv, (ball > 0).astype("uint8"), f"{cam} frame {index}"))
    if len(out) < len({(c, f) for c, f, _ in regions}):
        raise StereotrackError(f"{args.recording}: could not read every frame the regions name (the videos end early?)")
    return out


# --------------------------------------------------------------------------- --auto


def _find(args, source, settings):
    """--auto: the proposals (evidence/find_balls.py), or one line saying none was found."""
    from ..console import Progress
    from ..errors import StereotrackError
    from ..evidence.find_balls import propose

    progress = Progress(min(args.frames, source.n_frames), "looking for moving balls", enabled=sys.stderr.isatty())
    try:
        found, looked = propose(
            source.frames, source.n_frames, _cameras(source), source.rig is not None, settings, args.frames, args.name, args.radius,
            progress.update,
        )  # fmt: skip
    finally:
        progress.close()
    if not found:
        raise StereotrackError(
            f"{args.recording}: no moving, round ball of one hue found in {looked} frames; "
            "mark a ball yourself with --region x,y,w,h (on a frame where it is in view)"
        )
    return [(p.name, p.learnt, len(p.group.detections), len(p.group.frames), p.radius) for p in found]


# --------------------------------------------------------------------------- the command


def _model_path(args, config_path: Path, name: str, k: int) -> Path:
    if args.model and k == 0:
        return Path(args.model)
    import re

    return config_path.parent / f"{re.sub(r'[^A-Za-z0-9_.-]+', '_', name).strip('._') or 'target'}.colour-model.yaml"  # a name is no path


def run_learn(args) -> int:
    from dataclasses import replace

    from ..config import config_from_dict, load_config, save_config
    from ..console import info, warn
    from ..errors import StereotrackError
    from ..evidence.learn import learn
    from ..files import check_output, dump_yaml, write_text_atomic

    if args.auto == bool(args.regions):
        raise StereotrackError("colour learn: give --region x,y,w,h (one or more) or --auto, not both and not neither")
    if args.name is not None and (not args.name.strip() or any(c in args.name for c in ",\n\r")):
        raise StereotrackError(f"--name {args.name!r}: expected a target name without commas (it becomes a column of tracks.csv)")
    if args.regions and args.name is None:
        raise StereotrackError("--name: give the target a name, e.g. --name pink")
    source = _open(args.recording)
    if args.config is not None:  # an empty --config is refused below, not taken as the default
        path: Path | None = Path(args.config)
    elif source.targets_path is not None:
        path = source.targets_path
    elif isinstance(source, _Recording):
        path = source.folder / "config.yaml"
    else:
        path = None  # a video: print only
    config = config_from_dict({}, path or "<config>")
    if path is not None:
        check_output(path, "--config", "config file", source.own_files)  # never a recording's meta.yaml, video, ...
        config = load_config(path) if path.exists() and path.stat().st_size else config
    old = {t.name: t for t in config.targets}
    if args.regions:
        radius = args.radius if args.radius is not None else (old[args.name].radius if args.name in old else 0.035)
        if path is not None:
            _check_model(_model_path(args, path, args.name, 0), path, source)
        learnt = learn(_region_images(args, source), args.name, radius)
        found = [(args.name, learnt, None, None, None)]
    else:
        found = _find(args, source, config.tracker)
    learnt_targets = []
    for k, (name, learnt, detections, frames, radius) in enumerate(found):
        t = learnt.target
        if args.auto and args.radius is None and radius is None and name in old:
            t = replace(t, radius=old[name].radius)  # keep the radius a user set when none was measured
        model_path = _check_model(_model_path(args, path, name, k), path, source) if path is not None else None
        if model_path is not None and str(model_path) in {x.colour_model for x in learnt_targets}:
            raise StereotrackError(f"--model {model_path}: two targets would share it; rename one with --name")
        learnt_targets.append(replace(t, colour_model=str(model_path)) if model_path is not None else t)
        _report(learnt_targets[-1], learnt, detections, frames, radius, model_path)
    if path is not None:  # every output checked: now write them
        targets = list(config.targets)
        for t, (_, learnt, *_) in zip(learnt_targets, found):
            learnt.model.save(t.colour_model, t, learnt.held_out if learnt.held_out is not None else learnt.separation)
            targets = [t if o.name == t.name else o for o in targets] if t.name in old else [*targets, t]
        save_config(replace(config, targets=tuple(targets)), path)
        if args.config is None and source.targets_path is None:
            meta = dict(source.rec.meta)
            meta["targets"] = path.name
            write_text_atomic(source.folder / "meta.yaml", dump_yaml(meta))
        info(f"{len(found)} target{'s' * (len(found) > 1)} written to {path}, each with its colour model file")
    if args.auto:
        from ..config import target_to_dict

        folder = path.parent if path is not None else None
        print(dump_yaml({"targets": [target_to_dict(t, folder) for t in learnt_targets]}), end="")
    if path is None:
        warn(f"{args.recording} is a video file: nothing written; pass --config FILE to keep the target{'s' * (len(found) > 1)}")
    return 0


def _check_model(model: Path, config_path: Path, source) -> Path:
    from ..errors import StereotrackError
    from ..files import check_output

    if model.resolve() == config_path.resolve():
        raise StereotrackError(f"--model {model}: is the config file; choose another name")
    return check_output(model, "--model", "colour model", source.own_files)


def _report(t, learnt, detections, frames, radius, model_path) -> None:
    from ..console import info, warn

    found = f" ({detections} detections in {frames} frames)" if detections else ""
    size = f"radius {t.radius} m" + (" (measured)" if radius else "")
    info(f"target {t.name!r}{found}: hsv_min {list(t.hsv_min)}, hsv_max {list(t.hsv_max)}, {size}")
    info(
        f"covers {100 * learnt.ball_coverage:.0f}% of the ball's pixels and {100 * learnt.background_coverage:.2f}% of the rest "
        f"of the {learnt.images} image{'s' * (learnt.images > 1)}"
    )
    held = f", {learnt.held_out:.2f} on images it did not learn from" if learnt.held_out is not None else ""
    where = f" ({model_path})" if model_path is not None else ""
    info(
        f"colour model: separates the ball from the rest of the range by {learnt.separation:.2f} on the images it learnt from{held}"
        f" (1: perfectly, 0: no better than the range){where}"
    )
    figure = learnt.held_out if learnt.held_out is not None else learnt.separation
    if figure < MIN_SEPARATION:
        warn(
            f"the colour model hardly tells {t.name!r} from the rest of its range ({figure:.2f}): other things of its colour are in view "
            "(other balls of the same colour are fine); shape and motion will have to tell them apart"
        )
    if learnt.background_coverage > 0.01:
        warn(
            f"the range also covers {100 * learnt.background_coverage:.1f}% of the image outside the ball: "
            "the tracker may chase background of that colour; mark the ball on more frames, improve the lighting, or edit hsv_min/hsv_max"
        )
