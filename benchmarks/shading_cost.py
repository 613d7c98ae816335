"""What the shading map costs a white or grey target: the tracker step against the floor, with and without it.

A white or grey ball at rest in a white room shows by its shading alone (evidence/motion.py ``shading``: a
gradient map on the background's grid, its round patches kept). Only a target of every hue builds it. This renders
white_ball tune scenes (640x480, two cameras) into memory and times the step (N = 2000, alpha = 0.2, as
``stereotrack bench``) against the floor (HSV and a threshold per target), each frame floor then step back to back
(``bench_case``), with the shading map and without it (``tracker.shading: false``: the foreground alone), in turn,
ROUNDS times; the figure is the median over rounds of each run's median. It also times ``shading`` alone on each
camera's frame on the background's grid.

    .venv/bin/python benchmarks/shading_cost.py                 # tune seeds 9 and 47, 3 rounds
    .venv/bin/python benchmarks/shading_cost.py --seeds 1 --rounds 1 --frames 40
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from dataclasses import replace
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument(
        "--seeds", type=int, nargs="+", default=[9, 47], help="white_ball tune seeds (each holds a ball at rest that the map finds)"
    )
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--frames", type=int, default=60, help="frames per run (the first 10 are warm-up)")
    args = p.parse_args()

    from stereotrack.evidence.motion import SCALE, halved, shading
    from stereotrack.pipeline.bench import bench_in_turn
    from stereotrack.pipeline.tracker import SHADING_NEAR, warm_up
    from stereotrack.simulation.render import SceneRenderer
    from stereotrack.simulation.stress import stress_scene

    warm_up()
    print(f"load average at start: {os.getloadavg()[0]:.1f} ({os.cpu_count()} cores)", file=sys.stderr)
    print("| scene | variant | step ms | floor ms | step / floor | shading alone, ms a camera |")
    print("|---|---|---|---|---|---|")
    for seed in args.seeds:
        spec = stress_scene("white_ball", seed)
        renderer = SceneRenderer(spec)
        frames = [renderer.pair(i) for i in range(min(args.frames, spec.n_frames))]
        base = spec.config()
        config = replace(base, tracker=replace(base.tracker, particles=2000, alpha=0.2))
        target, s = config.targets[0], config.tracker
        alone = []
        for pair in frames[10:]:
            for cam, image in zip(renderer.rig.cameras, pair.images):
                small = halved(image)
                seen = cam.apparent_radius(target.radius, 1.0) / SCALE
                t0 = time.perf_counter()
                shading(small, target, seen / max(s.d_min, SHADING_NEAR), seen / s.d_max)
                alone.append(1e3 * (time.perf_counter() - t0))
        configs = {"with the shading map": config, "without it": replace(config, tracker=replace(config.tracker, shading=False))}
        for label, med in bench_in_turn(frames, renderer.rig, configs, args.rounds).items():
            extra = f"{statistics.median(alone):.2f}" if label == "with the shading map" else ""
            print(
                f"| white_ball tune {seed} | {label} | {med['step']:.2f} | {med['floor']:.2f} | {med['ratio']:.1f} | {extra} |",
                flush=True,
            )
    print(f"load average at end: {os.getloadavg()[0]:.1f}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
