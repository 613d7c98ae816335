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
  stereotrack bench --docs BENCHMARKS.md   # every case, then the table and the speed targets into its tracker-bench section
"""

from __future__ import annotations

import argparse

HELP = "benchmark the tracker step and its stages against the HSV+threshold floor"
FRAMES = 60  # frames per case by default
# The tracker issue's speed targets: the step within this many times the floor at N = 2000, alpha = 0.2, by image size.
TARGET_CASE = (2000, 0.2)
TARGETS = {(640, 480): 5.0, (1280, 720): 3.0}


def add_arguments(p: argparse.ArgumentParser) -> None:
    from ..argtypes import number

    p.add_argument(
        "--frames",
        type=number(11, 100_000, integer=True),
        default=FRAMES,
        help=f"frames per case (default {FRAMES}; the first 10 are warm-up)",
    )
    p.add_argument("--quick", action="store_true", help="only 640x480, N=2000, alpha=0.2")
    p.add_argument("--em", choices=["numpy", "sklearn"], default="numpy", help="EM implementation to time")
    p.add_argument(
        "--docs",
        metavar="FILE",
        help="after the run, replace FILE's tracker-bench section with the command, date, machine, table and the speed "
        "targets (BENCHMARKS.md; default EM only)",
    )


def run(args) -> int:
    from dataclasses import replace

    from ..console import Progress, info
    from ..errors import StereotrackError
    from ..files import read_text, replace_section
    from ..pipeline.bench import bench_case
    from ..simulation.presets import make_preset
    from ..simulation.render import SceneRenderer

    if args.docs and args.em != "numpy":
        raise StereotrackError("--docs shows the default EM only: drop --em sklearn")
    if args.docs:  # a missing, unreadable or binary FILE is refused now, not after the run
        read_text(args.docs, "markdown file", missing="no such file (point --docs at BENCHMARKS.md)")
    produced = produced_by(args) if args.docs else ""  # the load average before this run adds its own
    sizes = [(640, 480)] if args.quick else [(640, 480), (1280, 720)]
    cases = [TARGET_CASE] if args.quick else [(n, a) for n in (1000, 2000, 5000) for a in (0.0, 0.2, 1.0)]
    table = [
        "| size | N | alpha | step ms | floor ms | step / floor | masks | blobs | particles | clusters | tracks |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    print("\n".join(table))
    ratios: dict[tuple[int, int, int, float], float] = {}
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
            ratios[(w, h, n, alpha)] = r["ratio"]
            table.append(
                f"| {w}x{h} | {n} | {alpha:g} | {r['step']:.2f} | {r['floor']:.2f} | {r['ratio']:.1f} | "
                f"{r['masks']:.2f} | {r['blobs']:.2f} | {r['particles']:.2f} | {r['clusters']:.2f} | {r['tracks']:.2f} |"
            )
            print(table[-1], flush=True)
    if args.docs:  # only now: a run that fails or is stopped leaves FILE as it was
        replace_section(args.docs, "tracker-bench", docs_body(produced, table, ratios))
        info(f"table written to {args.docs} (section 'tracker-bench')")
    return 0


def produced_by(args) -> str:
    """The section's first line: the command line that gives it again (the options that change it, as a shell reads
    them), the date, the machine and its load, the frames per case."""
    import os
    import shlex
    from datetime import UTC, datetime

    from .stress import host_cpu

    argv = ["stereotrack", "bench", *(["--quick"] if args.quick else [])]
    argv += ["--frames", str(args.frames)] if args.frames != FRAMES else []
    try:
        load = f", load average {os.getloadavg()[0]:.1f} when it started"
    except OSError:  # no load average on this system
        load = ""
    return (
        f"Produced by `{shlex.join([*argv, '--docs', str(args.docs)])}` on {datetime.now(UTC):%Y-%m-%d} (UTC), on a machine "
        f"with {os.cpu_count()} cores (CPU: {host_cpu()}){load}; {args.frames} frames per case, the first 10 of them warm-up."
    )


def docs_body(produced: str, table: list[str], ratios: dict[tuple[int, int, int, float], float]) -> str:
    """The tracker-bench section: how, when and where it was measured, the table, and each speed target it covers."""
    n, alpha = TARGET_CASE
    lines = [produced, "", *table, "", f"Against the tracker issue's speed targets (step / floor at N = {n}, alpha = {alpha:g}):", ""]
    for (w, h), target in TARGETS.items():
        if (w, h, n, alpha) in ratios:
            measured = round(ratios[(w, h, n, alpha)], 1)  # judged as printed: 5.04 reads 5.0x, within 5x
            lines.append(f"- {w}x{h}: measured {measured:.1f}x (target <= {target:g}x): {'met' if measured <= target else 'not met'}")
    return "\n".join(lines)
