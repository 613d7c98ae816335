"""What a fast track's robust update (tracks/motion.robust_noise) costs: the track manager's update, on and off.

Three balls thrown at 20-25 m/s, 10-15 m away, at 60 fps, their objects vague in depth as far balls' are (a seeded
``numpy.random.Generator``). The same object stream goes through a TrackManager with the robust update
(``ROBUST_SIGMAS`` = 1, the default) and without it (infinite: every object at face value), the two in turn for
``--rounds`` rounds so load on the shared machine falls on both; CPU time of this thread (``time.thread_time``) per
update, the median of the rounds.

    .venv/bin/python benchmarks/robust_update_cost.py
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from stereotrack.config import TrackSettings  # noqa: E402
from stereotrack.results import Object3D  # noqa: E402
from stereotrack.simulation.trajectories import Flight  # noqa: E402
from stereotrack.tracks import motion  # noqa: E402
from stereotrack.tracks.manager import TrackManager  # noqa: E402


def stream(frames: int, fps: float, rng: np.random.Generator) -> list[tuple[float, list[Object3D]]]:
    flights = [
        Flight((6.0, 12.0, 1.0), (-22.0, 1.0, 3.0), 0.0, 0.012),
        Flight((-6.0, 15.0, 1.5), (20.0, -2.0, 2.0), 0.0, 0.012),
        Flight((5.0, 10.0, 0.5), (-25.0, 3.0, 4.0), 0.0, 0.012),
    ]
    times = np.arange(frames) / fps
    claimed = np.diag([0.01, 0.25, 0.01]) ** 2
    paths = [f.positions(times) for f in flights]
    out = []
    for i, t in enumerate(times):
        objs = [Object3D("ball", p[i] + rng.normal(0.0, [0.005, 0.1, 0.005]), claimed, 0.3, 100) for p in paths]
        out.append((float(t), objs))
    return out


def run(objects: list, robust_sigmas: float) -> float:
    """CPU seconds per update over the stream."""
    motion.ROBUST_SIGMAS = robust_sigmas
    manager = TrackManager(TrackSettings(up=(0.0, 0.0, 1.0)))
    start = time.thread_time()
    for t, objs in objects:
        manager.update(objs, t)
    return (time.thread_time() - start) / len(objects)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--rounds", type=int, default=7)
    p.add_argument("--frames", type=int, default=40, help="frames of the stream (the balls fly about 0.6 s)")
    args = p.parse_args()
    objects = stream(args.frames, 60.0, np.random.default_rng(0))
    default = motion.ROBUST_SIGMAS
    run(objects, default)  # compile the kernels, warm the caches
    on, off = [], []
    for _ in range(args.rounds):
        on.append(run(objects, default))
        off.append(run(objects, float("inf")))
    motion.ROBUST_SIGMAS = default
    a, b = statistics.median(on) * 1e3, statistics.median(off) * 1e3
    print(
        f"track update, 3 fast balls: robust {a:.3f} ms, plain {b:.3f} ms, difference {a - b:+.3f} ms a frame ({args.rounds} rounds each)"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
