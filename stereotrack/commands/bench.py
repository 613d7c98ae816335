"""Benchmark the tracker step against the floor, in one run.

The floor is the least any colour tracker must do per frame: convert every
camera's frame to HSV and threshold it. Each frame of a rendered scene (4
pendulum balls) is timed twice back to back, floor then tracker step, so the
ratio step / floor is measured under the same machine load. Decoding is
excluded (frames are rendered into memory first).

Cases: 640x480 and 1280x720; N in {1000, 2000, 5000}; alpha in {0, 0.2, 1.0}.

  stereotrack bench                 # every case, Markdown table on stdout
  stereotrack bench --quick         # 640x480, N=2000, alpha=0.2 only
  stereotrack bench --em sklearn    # the same with scikit-learn's GaussianMixture for EM
"""

from __future__ import annotations

import argparse

HELP = "benchmark the tracker step and its stages against the HSV+threshold floor"


def add_arguments(p: argparse.ArgumentParser) -> None:
    from ..argtypes import number

    p.add_argument(
        "--frames", type=number(11, 100_000, integer=True), default=60, help="frames per case (default 60; the first 10 are warm-up)"
    )
    p.add_argument("--quick", action="store_true", help="only 640x480, N=2000, alpha=0.2")
    p.add_argument("--em", choices=["numpy", "sklearn"], default="numpy", help="EM implementation to time")


def run(args) -> int:
    from dataclasses import replace

    from ..console import Progress
    from ..pipeline.bench import bench_case
    from ..simulation.presets import make_preset
    from ..simulation.render import SceneRenderer

    sizes = [(640, 480)] if args.quick else [(640, 480), (1280, 720)]
    cases = [(2000, 0.2)] if args.quick else [(n, a) for n in (1000, 2000, 5000) for a in (0.0, 0.2, 1.0)]
    print("| size | N | alpha | step ms | floor ms | step / floor | masks | blobs | particles | clusters | tracks |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for w, h in sizes:
        spec = make_preset("pendulum4", width=w, height=h, n_frames=args.frames)
        renderer = SceneRenderer(spec)
        bar = Progress(spec.n_frames, f"rendering {w}x{h}", "frames")
        frames = []
        for i in range(spec.n_frames):
            frames.append(renderer.pair(i))
            bar.update()
        bar.close()
        base = spec.config()
        for n, alpha in cases:
            config = replace(base, tracker=replace(base.tracker, particles=n, alpha=alpha, em=args.em))
            r = bench_case(frames, renderer.rig, config)
            print(
                f"| {w}x{h} | {n} | {alpha:g} | {r['step']:.2f} | {r['floor']:.2f} | {r['ratio']:.1f} | "
                f"{r['masks']:.2f} | {r['blobs']:.2f} | {r['particles']:.2f} | {r['clusters']:.2f} | {r['tracks']:.2f} |",
                flush=True,
            )
    return 0
