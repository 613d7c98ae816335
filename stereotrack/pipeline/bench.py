"""Timing the tracker step against the floor: the least any colour tracker does per frame (HSV, then a threshold per target)."""

from __future__ import annotations

import time
from collections.abc import Iterable, Sequence

import cv2
import numpy as np

from ..camera import Rig
from ..config import Config, Target
from ..evidence.colour import target_mask
from ..frames import FramePair
from .tracker import Tracker


def floor(images: Sequence[np.ndarray], targets: Sequence[Target]) -> None:
    """Convert every camera's frame to HSV and threshold it once per target."""
    for img in images:
        hsv = cv2.cvtColor(img, cv2.COLOR_BGR2HSV)
        for t in targets:
            target_mask(hsv, t)


def bench_case(frames: Iterable[FramePair], rig: Rig, config: Config, warmup: int = 10) -> dict[str, float]:
    """Median ms per stage, of the step, of the floor, and of step / floor, each frame timed floor then step back to back.
    Also in CPU time of this process (``time.process_time``: every thread of it, the evidence pool's and OpenCV's, and
    none of the other jobs on a shared machine, which stretch the wall clock): ``step_cpu``, ``floor_cpu``, ``ratio_cpu``."""
    tracker = Tracker(rig, config)
    floor_ms, step_ms, floor_cpu, step_cpu, stages = [], [], [], [], {}
    for i, pair in enumerate(frames):
        c0, t0 = time.process_time(), time.perf_counter()
        floor(pair.images, config.targets)
        c1, t1 = time.process_time(), time.perf_counter()
        res = tracker.step(pair)
        c2 = time.process_time()
        if i < warmup:
            continue
        floor_ms.append(1e3 * (t1 - t0))
        step_ms.append(res.timings_ms["step"])
        floor_cpu.append(1e3 * (c1 - c0))
        step_cpu.append(1e3 * (c2 - c1))
        for k, v in res.timings_ms.items():
            stages.setdefault(k, []).append(v)
    out = {k: float(np.median(v)) for k, v in stages.items()}
    out["floor"] = float(np.median(floor_ms))
    out["ratio"] = float(np.median(np.array(step_ms) / np.array(floor_ms)))
    # CPU time: totals over the frames (a single frame's floor is a few clock ticks of some kernels' CPU clocks)
    out["step_cpu"], out["floor_cpu"] = float(np.mean(step_cpu)), float(np.mean(floor_cpu))
    out["ratio_cpu"] = out["step_cpu"] / out["floor_cpu"] if out["floor_cpu"] > 0 else float("nan")
    return out


def bench_in_turn(frames: Sequence[FramePair], rig: Rig, configs: dict[str, Config], rounds: int) -> dict[str, dict[str, float]]:
    """``bench_case`` of each config in turn, ``rounds`` times (machine load falls on all of them alike); per config, the
    median over rounds of each figure."""
    runs: dict[str, list[dict[str, float]]] = {label: [] for label in configs}
    for _ in range(rounds):
        for label, config in configs.items():
            runs[label].append(bench_case(frames, rig, config))
    return {label: {k: float(np.median([r[k] for r in results])) for k in results[0]} for label, results in runs.items()}
