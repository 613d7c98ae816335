"""Synthetic render speed: frame pairs per second at 640x480 stereo, in memory and written to FFV1.

    .venv/bin/python benchmarks/render_speed.py [--frames 150]

The issue's target: >= 20 rendered frame pairs per second (no blur) on the
2-core reference machine. Prints one table; speeds are also given as ratios
to pendulum4's in-memory speed so a noisy machine still compares fairly.
"""

from __future__ import annotations

import argparse
import tempfile
import time

from stereotrack.simulation.presets import make_preset
from stereotrack.simulation.render import SceneRenderer
from stereotrack.simulation.write import render_scene


def pairs_per_second(renderer: SceneRenderer, frames: int) -> float:
    renderer.render(0)  # warm caches
    start = time.perf_counter()
    for i in range(frames):
        renderer.render(i % renderer.n_frames)
    return frames / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--frames", type=int, default=150)
    args = parser.parse_args()
    cases = [
        ("pendulum4", {}),
        ("clutter", {}),
        ("juggle5", {}),
        ("crossing", {}),
        ("pendulum4 blur 4", {"blur": 4}),
        ("pendulum4 4 cameras", {"cameras": 4}),
    ]
    rows = []
    for label, over in cases:
        spec = make_preset(label.split()[0], **over)
        rows.append((label, pairs_per_second(SceneRenderer(spec), args.frames)))
    with tempfile.TemporaryDirectory() as tmp:
        spec = make_preset("pendulum4", n_frames=args.frames)
        start = time.perf_counter()
        render_scene(spec, f"{tmp}/rec", progress=False)
        rows.append(("pendulum4 + FFV1 files", args.frames / (time.perf_counter() - start)))
    base = rows[0][1]
    print(f"{'scene (640x480)':<26} {'pairs/s':>8} {'ratio':>6}")
    for label, fps in rows:
        print(f"{label:<26} {fps:8.1f} {fps / base:6.2f}")


if __name__ == "__main__":
    main()
