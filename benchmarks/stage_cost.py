"""Where the tracker step's time goes: CPU time per frame of each stage and of the functions inside it.

Renders a scene into memory and tracks it with the defaults (pendulum4: N = 2000, alpha = 0.2, as
observation_cost.py), timing the floor (HSV and a threshold per target), the step, and each wrapped function inside
the step in CPU time of the tracking thread (``time.thread_time``: the shared machine's other jobs do not count;
OpenCV on one thread). Times are inclusive (a function's time holds the functions it calls) and per frame, summed
over cameras and targets, after 10 frames of warm-up. ``--cprofile`` prints cProfile's table instead (its overhead
inflates the Python glue about 1.5x, not the compiled kernels).

    .venv/bin/python benchmarks/stage_cost.py                        # pendulum4 640x480, 60 frames
    .venv/bin/python benchmarks/stage_cost.py --scene hue_wall:0     # a stress tune scene, at its own size
    .venv/bin/python benchmarks/stage_cost.py --cprofile --sort tottime
"""

from __future__ import annotations

import argparse
import collections
import sys
import time
from dataclasses import replace
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from stereotrack.simulation.stress import scene_name  # noqa: E402

# (module, owner within it or "", function name, label); nested labels are indented
WRAPPED = [
    ("tracks.manager", "TrackManager", "predicted", "tracks: predicted"),
    ("pipeline.tracker", "Tracker", "_colours", "colours (grid, HSV, ranges)"),
    ("pipeline.tracker", "", "camera_masks", "  HSV and ranges"),
    ("evidence.motion", "BackgroundModel", "update", "background"),
    ("pipeline.tracker", "Tracker", "_shaded", "shading map"),
    ("evidence.colour_model", "ColourModel", "table_and_things", "colour model: table"),
    ("evidence.colour_model", "ColourModel", "learn", "colour model: learn"),
    ("evidence.gather", "CameraEvidence", "from_mask", "maps, blobs, seeds (from_mask)"),
    ("evidence.gather", "", "evidence_maps", "  evidence_maps"),
    ("evidence.gather", "", "integral_image", "  integral images"),
    ("evidence.gather", "", "find_blobs", "  find_blobs"),
    ("evidence.blobs", "", "_uneven", "    _uneven"),
    ("evidence.gather", "", "still_streaks", "  still_streaks"),
    ("evidence.gather", "", "_seeds", "  _seeds"),
    ("evidence.gather", "", "_add_faint_streaks", "  faint streaks"),
    ("evidence.gather", "", "_streaks_only", "  streaks only"),
    ("particles.population", "Population", "step", "particles"),
    ("particles.population", "", "systematic_indices", "  resampling"),
    ("particles.proposal", "RayProposal", "__call__", "  proposal"),
    ("particles.proposal", "", "crossing_points", "    crossing_points"),
    ("particles.likelihoods.ball_shape", "Model", "__call__", "  likelihood"),
    ("pipeline.tracker", "", "cluster_particles", "clustering"),
    ("pipeline.tracker", "", "explain", "explain"),
    ("objects.explain", "", "_swept", "  _swept"),
    ("objects.explain", "", "_refine_all", "  _refine_all"),
    ("pipeline.tracker", "Tracker", "_off_surfaces", "surface test"),
    ("tracks.manager", "TrackManager", "update", "tracks: update"),
    ("particles.population", "Population", "follow", "particles follow tracks"),
]


def _wrap(spent: dict, module, owner: str, name: str, label: str) -> None:
    holder = getattr(module, owner) if owner else module
    raw = holder.__dict__.get(name) if owner else getattr(module, name)
    is_classmethod = isinstance(raw, classmethod)
    fn = raw.__func__ if is_classmethod else raw

    def timed(*a, **k):
        start = time.thread_time()
        try:
            return fn(*a, **k)
        finally:
            spent[label] += time.thread_time() - start

    setattr(holder, name, classmethod(timed) if is_classmethod else timed)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--scene", default=None, type=scene_name, help="a stress scene CATEGORY:SEED (default: pendulum4)")
    p.add_argument("--size", default="640x480", help="pendulum4's size")
    p.add_argument("--frames", type=int, default=60, help="frames (the first 10 are warm-up)")
    p.add_argument("--cprofile", action="store_true", help="print cProfile's table instead of the stages")
    p.add_argument("--sort", default="tottime", help="cProfile's order (tottime, cumulative)")
    args = p.parse_args()

    import importlib

    import cv2

    from stereotrack.pipeline.bench import floor
    from stereotrack.pipeline.tracker import Tracker, warm_up
    from stereotrack.simulation.render import SceneRenderer

    cv2.setNumThreads(1)
    spent: dict[str, float] = collections.defaultdict(float)
    if not args.cprofile:
        for module, owner, name, label in WRAPPED:
            _wrap(spent, importlib.import_module(f"stereotrack.{module}"), owner, name, label)
    warm_up()
    if args.scene is None:
        from stereotrack.simulation.presets import make_preset

        w, h = (int(x) for x in args.size.split("x"))
        spec = make_preset("pendulum4", width=w, height=h, n_frames=args.frames)
        base = spec.config()
        config = replace(base, tracker=replace(base.tracker, particles=2000, alpha=0.2))
    else:
        from stereotrack.simulation.stress import stress_scene

        spec = replace(stress_scene(*args.scene), n_frames=args.frames)
        config = spec.config()
    renderer = SceneRenderer(spec)
    frames = [renderer.pair(i) for i in range(spec.n_frames)]
    tracker = Tracker(renderer.rig, config)
    warmup = min(10, len(frames) - 1)
    for pair in frames[:warmup]:
        tracker.step(pair)
    if args.cprofile:
        import cProfile
        import pstats

        profile = cProfile.Profile(time.thread_time)
        profile.enable()
        for pair in frames[warmup:]:
            tracker.step(pair)
        profile.disable()
        pstats.Stats(profile).sort_stats(args.sort).print_stats(60)
        return 0
    spent.clear()
    step = floor_s = 0.0
    for pair in frames[warmup:]:
        t0 = time.thread_time()
        floor(pair.images, config.targets)
        t1 = time.thread_time()
        tracker.step(pair)
        step += time.thread_time() - t1
        floor_s += t1 - t0
    n = len(frames) - warmup
    name = f"{args.scene[0]}:{args.scene[1]}" if args.scene else f"pendulum4 {args.size}"
    print(f"{name}, {n} frames: step {1e3 * step / n:.2f} ms CPU, floor {1e3 * floor_s / n:.2f} ms CPU, {step / floor_s:.1f}x")
    print("| stage | ms CPU a frame |")
    print("|---|---|")
    for _, _, _, label in WRAPPED:
        indent = len(label) - len(label.lstrip())
        print(f"| {'&nbsp;' * indent}{label.strip()} | {1e3 * spent[label] / n:.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
