"""What the surface test (objects/surface.py) costs where it has work: stress scenes with still things of the ball's colour.

Renders each scene into memory and tracks it with the defaults, timing the whole step and the surface test's part of it
in CPU time of the tracking thread (``time.thread_time``: on a shared machine, other jobs' load does not count in it),
and counting the judgements (a still object compared between views), with each spot's verdict kept for
VERDICT_SECONDS as the tracker does, and with none kept (judged every frame).

    .venv/bin/python benchmarks/surface_cost.py                                   # hue_wall 16 and 18, static_props 46
    .venv/bin/python benchmarks/surface_cost.py --scenes hue_wall:18 --frames 60
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from stereotrack.simulation.stress import scene_name  # noqa: E402


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument(
        "--scenes",
        nargs="+",
        default=[("hue_wall", 16), ("hue_wall", 18), ("static_props", 46)],
        type=scene_name,
        help="stress tune scenes CATEGORY:SEED",
    )
    p.add_argument("--frames", type=int, default=90)
    args = p.parse_args()

    import stereotrack.objects.surface as surface
    from stereotrack.pipeline.tracker import Tracker, warm_up
    from stereotrack.simulation.render import SceneRenderer
    from stereotrack.simulation.stress import stress_scene

    kept_for = surface.VERDICT_SECONDS
    drop, judge = surface.SurfacePatches.drop, surface.on_surface
    spent, judged = [0.0], [0]

    def timed_drop(self, *a):
        start = time.thread_time()
        out = drop(self, *a)
        spent[0] += time.thread_time() - start
        return out

    def counted_judge(*a):
        judged[0] += 1
        return judge(*a)

    surface.SurfacePatches.drop, surface.on_surface = timed_drop, counted_judge
    warm_up()
    print("| scene | verdicts kept | frames | step ms CPU | surface test ms CPU | share of step | judgements |")
    print("|---|---|---|---|---|---|---|")
    for category, seed in args.scenes:
        name = f"{category}:{seed}"
        spec = replace(stress_scene(category, seed), n_frames=args.frames)
        renderer = SceneRenderer(spec)
        frames = [renderer.pair(i) for i in range(spec.n_frames)]
        for label, seconds in ((f"{kept_for} s", kept_for), ("none", -1.0)):
            surface.VERDICT_SECONDS = seconds
            tracker = Tracker(renderer.rig, spec.config())
            spent[0], judged[0], step = 0.0, 0, 0.0
            for pair in frames:
                start = time.thread_time()
                tracker.step(pair)
                step += time.thread_time() - start
            n = len(frames)
            print(
                f"| {name} | {label} | {n} | {1e3 * step / n:.2f} | {1e3 * spent[0] / n:.3f} | {100 * spent[0] / step:.1f} % | {judged[0]} |",
                flush=True,
            )
    surface.VERDICT_SECONDS = kept_for
    return 0


if __name__ == "__main__":
    sys.exit(main())
