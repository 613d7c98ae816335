"""Two versions of the tracker on the same stress scenes, with the luck of the particles' draws measured, not guessed.

A scene's MOTA moves with the particle tracker's random seed (``stereotrack stress --tracker-seed N``): where a
ball is weak, a few particles more or less decide whether a ghost lasts or a ball is found. On tune seeds 80-159
of ``hands`` the same code summed 74.3, 75.8, 76.1 and 76.8 over its 80 scenes with tracker seeds 0-3, so a change
measured with one tracker seed can gain or lose 2.5 by luck alone. This pairs the results CSVs of a base and a new
version run on the same scenes with the same tracker seeds (``--base`` and ``--new``, one file per tracker seed, in
the same order) and reports, per category, the summed MOTA of each, their difference per tracker seed with its mean
and the standard error of that mean, how many runs fall under 0.85 (the issue's worst-seed bar) and how many scenes
each version does better on (their MOTA averaged over the tracker seeds, by more than SCENE_MARGIN).

    stereotrack stress --set tune --seeds 80 --tracker-seed 1    # in each checkout, for each tracker seed 0..3
    # (one --cache for both checkouts renders the scenes once; copy the base's results CSVs aside before the new runs)
    .venv/bin/python benchmarks/compare_runs.py \\
        --base out/stress/tune-results.csv out/stress/tune-results_seed1.csv ... \\
        --new ../new/out/stress/tune-results.csv ../new/out/stress/tune-results_seed1.csv ...

A difference under twice its standard error is luck ("within luck"): with one tracker seed there is no telling.
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

WORST = 0.85  # the bar for a category's worst scene
SCENE_MARGIN = 0.02  # a scene is done better by the version whose MOTA, averaged over tracker seeds, is this much higher


def read_scores(path: Path, method: str = "particles") -> dict[tuple[str, int], float]:
    """(category, seed) -> MOTA of one results CSV (``stereotrack stress``'s, or one written by ``write_results_csv``);
    a run that failed (an error, no MOTA) is NaN."""
    with open(path, newline="") as f:
        rows = [r for r in csv.DictReader(f) if r.get("method") == method]
    if not rows:
        raise ValueError(f"{path}: no rows of method {method!r} (a results CSV of stereotrack stress?)")
    return {(r["category"], int(r["seed"])): float(r["mota"]) if r.get("mota") else math.nan for r in rows}


@dataclass(frozen=True)
class Comparison:
    """One category, base against new, over the scenes both scored with every tracker seed."""

    category: str
    scenes: int
    base_sums: tuple[float, ...]  # per tracker seed, MOTA summed over the scenes
    new_sums: tuple[float, ...]
    base_under: int  # runs (scene, tracker seed) under WORST
    new_under: int
    better: int  # scenes whose mean MOTA over the tracker seeds rose by more than SCENE_MARGIN
    worse: int
    dropped: int  # scenes left out: a run of either version failed, or a file lacks them

    @property
    def differences(self) -> np.ndarray:
        return np.array(self.new_sums) - np.array(self.base_sums)

    @property
    def mean(self) -> float:
        return float(self.differences.mean())

    @property
    def standard_error(self) -> float:
        """Of the mean difference, from its spread over the tracker seeds (NaN with one)."""
        d = self.differences
        return float(d.std(ddof=1) / math.sqrt(len(d))) if len(d) > 1 else math.nan

    @property
    def verdict(self) -> str:
        if math.isnan(self.standard_error):
            return "one tracker seed: luck unknown"
        if abs(self.mean) < 2.0 * self.standard_error:
            return "within luck"
        return "better" if self.mean > 0 else "worse"


def compare(base: Sequence[dict], new: Sequence[dict]) -> list[Comparison]:
    """Per category, the pairs of runs (``base[i]`` and ``new[i]``: one tracker seed, read_scores) compared."""
    if len(base) != len(new) or not base:
        raise ValueError("give as many --new files as --base files, one per tracker seed, in the same order")
    out = []
    for category in sorted({c for runs in (*base, *new) for c, _ in runs}):
        every = [{s for c, s in runs if c == category} for runs in (*base, *new)]
        scenes = sorted(set.union(*every))
        kept = [s for s in scenes if all(np.isfinite(runs.get((category, s), math.nan)) for runs in (*base, *new))]
        a = np.array([[runs[(category, s)] for s in kept] for runs in base]).reshape(len(base), len(kept))
        b = np.array([[runs[(category, s)] for s in kept] for runs in new]).reshape(len(new), len(kept))
        gain = b.mean(axis=0) - a.mean(axis=0)
        out.append(
            Comparison(
                category,
                len(kept),
                tuple(float(x) for x in a.sum(axis=1)),
                tuple(float(x) for x in b.sum(axis=1)),
                int((a < WORST).sum()),
                int((b < WORST).sum()),
                int((gain > SCENE_MARGIN).sum()),
                int((gain < -SCENE_MARGIN).sum()),
                len(scenes) - len(kept),
            )
        )
    return out


def markdown(rows: Sequence[Comparison]) -> str:
    lines = [
        "| category | scenes | tracker seeds | base MOTA summed | new MOTA summed | difference per tracker seed | mean difference "
        f"(standard error) | runs under {WORST} | scenes better / worse | verdict |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        dropped = f" ({r.dropped} left out)" if r.dropped else ""
        se = "" if math.isnan(r.standard_error) else f" ({r.standard_error:.2f})"
        lines.append(
            f"| {r.category} | {r.scenes}{dropped} | {len(r.base_sums)} | {np.mean(r.base_sums):.2f} | {np.mean(r.new_sums):.2f} | "
            f"{' '.join(f'{d:+.2f}' for d in r.differences)} | {r.mean:+.2f}{se} | {r.base_under} -> {r.new_under} of "
            f"{r.scenes * len(r.base_sums)} | {r.better} / {r.worse} | {r.verdict} |"
        )
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--base", nargs="+", type=Path, required=True, help="the base version's results CSVs, one per tracker seed")
    p.add_argument("--new", nargs="+", type=Path, required=True, help="the new version's, the same tracker seeds in the same order")
    p.add_argument("--method", default="particles", help="the method compared (default particles)")
    args = p.parse_args(argv)
    try:
        for path in (*args.base, *args.new):
            if not path.is_file():
                raise ValueError(f"{path}: no such results CSV (run stereotrack stress first)")
        rows = compare([read_scores(f, args.method) for f in args.base], [read_scores(f, args.method) for f in args.new])
    except (ValueError, KeyError, csv.Error, UnicodeDecodeError) as exc:
        print(f"compare_runs: {exc}", file=sys.stderr)
        return 2
    print(markdown(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
