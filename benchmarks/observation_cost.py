"""What each part of the observation model costs: the tracker step against the floor with each part on and off.

Renders ``pendulum4`` once per size into memory, then times the step of
several tracker variants (N = 2000, alpha = 0.2) against the floor (HSV and a
threshold per target), each frame floor then step back to back
(``stereotrack bench``'s ``bench_case``). The variants run in turn, ROUNDS
times, so a change in the shared machine's load falls on all of them; the
figure is the median over rounds of each run's median step / floor. The "CPU" columns are the same run in CPU time of
the process (``time.process_time``, totals over the frames): the shared machine's other jobs stretch the wall clock,
not these.

    .venv/bin/python benchmarks/observation_cost.py                    # 640x480 and 1280x720, 3 rounds
    .venv/bin/python benchmarks/observation_cost.py --sizes 640x480 --rounds 1 --frames 40
    .venv/bin/python benchmarks/observation_cost.py --scene hue_wall:18   # a stress tune scene, at its own size

A stress scene shows what a part costs where it has work: the surface test judges still objects, which
pendulum4 has none of once its balls have travelled.
"""

from __future__ import annotations

import argparse
import os
import sys
from dataclasses import replace
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from stereotrack.simulation.stress import scene_name  # noqa: E402

# (label, tracker settings changed from the defaults)
VARIANTS = [
    ("default (all on)", {}),
    ("no colour model", {"colour_model": False}),
    ("no motion", {"motion": False}),
    ("cameras side by side (threads 0)", {"threads": 0}),
    ("every pixel (evidence_scale 1)", {"evidence_scale": 1}),  # the default builds 1280-wide evidence on every other pixel
    ("colour window likelihood", {"likelihood": "colour_window"}),
    ("no surface test", {"surfaces": False}),
    ("no outline search", {"outlines": False}),
    ("all off (the paper's model)", {"colour_model": False, "motion": False, "ball_blobs_only": False, "likelihood": "colour_window"}),
]


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--sizes", nargs="+", default=["640x480", "1280x720"])
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--frames", type=int, default=60, help="frames per run (the first 10 are warm-up)")
    p.add_argument(
        "--scene",
        default=None,
        type=scene_name,
        help="a stress scene CATEGORY:SEED at its own size (default: pendulum4 at each of --sizes)",
    )
    args = p.parse_args()

    from stereotrack.pipeline.bench import bench_in_turn
    from stereotrack.pipeline.tracker import warm_up
    from stereotrack.simulation.presets import make_preset
    from stereotrack.simulation.render import SceneRenderer
    from stereotrack.simulation.stress import stress_scene

    warm_up()
    print(f"load average at start: {os.getloadavg()[0]:.1f} (2 cores)", file=sys.stderr)
    print(
        "| size | variant | step ms | floor ms | step / floor | step ms CPU | floor ms CPU | step / floor CPU | "
        "evidence (wall) | masks (work) | blobs (work) | particles | objects |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    stress = args.scene is not None
    for size in args.sizes[:1] if stress else args.sizes:
        w, h = (int(x) for x in size.split("x"))
        if stress:
            spec = replace(stress_scene(*args.scene), n_frames=args.frames)
            w, h = spec.rig.width, spec.rig.height
        else:
            spec = make_preset("pendulum4", width=w, height=h, n_frames=args.frames)
        renderer = SceneRenderer(spec)
        frames = [renderer.pair(i) for i in range(spec.n_frames)]
        base = spec.config()
        # Below 1280 pixels wide the default already reads every pixel.
        variants = [(label, changes) for label, changes in VARIANTS if w >= 1280 or "evidence_scale" not in changes]
        configs = {label: replace(base, tracker=replace(base.tracker, particles=2000, alpha=0.2, **changes)) for label, changes in variants}
        for label, med in bench_in_turn(frames, renderer.rig, configs, args.rounds).items():
            print(
                f"| {w}x{h} | {label} | {med['step']:.2f} | {med['floor']:.2f} | {med['ratio']:.1f} | "
                f"{med['step_cpu']:.2f} | {med['floor_cpu']:.2f} | {med['ratio_cpu']:.1f} | "
                f"{med['evidence']:.2f} | {med['masks']:.2f} | {med['blobs']:.2f} | {med['particles']:.2f} | {med['clusters']:.2f} |",
                flush=True,
            )
    print(f"load average at end: {os.getloadavg()[0]:.1f}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
