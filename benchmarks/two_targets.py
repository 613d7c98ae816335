"""A coloured ball tracked with a white target beside it: does the second target cost the first? (issue 14)

    .venv/bin/python benchmarks/two_targets.py --category hue_wall --seeds 0 80 --jobs 2
    .venv/bin/python benchmarks/two_targets.py --category static_props --seeds 3000 3040 --root /tmp/before --root .

Each scene of a stress category (rendered into ``--cache`` as ``stereotrack stress`` renders it, and reused) is
tracked by ``stereotrack track`` in a subprocess of each ``--root`` checkout, twice: with the scene's own config (its
one coloured target), and with a white target added (any hue, saturation up to 40, value from 200, the ball's
radius), as a user tracking a white ball and a coloured one types it. The stress scenes hold no white ball, so
whatever the white target tracks is its own business: only the coloured target's tracks are scored, like
``stereotrack eval``. Prints, per checkout, the coloured target's summed MOTA, median, worst and the seeds under 0.85
(the issue's worst-seed bar), alone and with the white target, and the seeds whose MOTA the white target changes most.
"""

from __future__ import annotations

import argparse
import csv
import os
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

WHITE = {"name": "white", "hsv_min": [0, 0, 200], "hsv_max": [179, 40, 255]}


def scene(category: str, seed: int, cache: Path) -> Path:
    """The scene's folder, rendered if it is not in the cache yet."""
    from stereotrack.commands.stress import Job, render_cached

    job = Job(category, seed, str(cache))
    job.folder.parent.mkdir(parents=True, exist_ok=True)
    render_cached(job.spec(), job.folder)
    return job.folder


def coloured_mota(root: Path, folder: Path, with_white: bool, work: Path) -> float:
    """MOTA of the scene's own target, tracked by ``root``'s code, with or without a white target beside it."""
    from stereotrack.evaluate import evaluate
    from stereotrack.recording import open_recording, read_truth_and_views

    config = yaml.safe_load((folder / "config.yaml").read_text())
    target = config["targets"][0]
    if with_white:
        config["targets"].append({**WHITE, "radius": target["radius"]})
    tag = f"{abs(hash((str(root), str(folder), with_white)))}"
    path, out = work / f"config-{tag}.yaml", work / f"tracks-{tag}.csv"
    path.write_text(yaml.safe_dump(config, sort_keys=False))
    env = {**os.environ, "PYTHONPATH": str(root)}
    cmd = [sys.executable, "-m", "stereotrack", "track", str(folder), "--config", str(path), "--out", str(out), "--quiet"]
    subprocess.run(cmd, cwd=root, env=env, capture_output=True, check=True)
    with out.open() as f:
        rows = [r for r in csv.DictReader(f) if r["target"] == target["name"]]
    tracks = np.array([[float(r[k]) for k in ("frame", "time", "track_id", "x", "y", "z")] for r in rows]).reshape(-1, 6)
    rec = open_recording(folder)
    truth, views = read_truth_and_views(rec.truth_path)
    return evaluate(tracks, truth, frames=list(range(rec.n_frames)), views=views).mota


def summary(motas: np.ndarray) -> str:
    """Over the scenes with a ball two cameras see (MOTA is nan without one: no tracker's failure)."""
    scored = motas[np.isfinite(motas)]
    unscored = f" ({len(motas) - len(scored)} scenes with no ball two cameras see)" if len(scored) < len(motas) else ""
    return (
        f"sum {scored.sum():.2f}, median {np.median(scored):.3f}, worst {scored.min():.3f}, "
        f"under 0.85: {int((scored < 0.85).sum())}{unscored}"
    )


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--category", default="hue_wall")
    p.add_argument("--seeds", type=int, nargs=2, default=(0, 20), metavar=("FIRST", "STOP"), help="seeds FIRST .. STOP - 1")
    p.add_argument("--root", action="append", type=Path, help="checkouts to run (default: this one)")
    p.add_argument("--cache", type=Path, default=ROOT / "out" / "stress")
    p.add_argument("--jobs", type=int, default=2)
    args = p.parse_args()
    roots = [r.resolve() for r in (args.root or [ROOT])]
    seeds = list(range(*args.seeds))
    folders = [scene(args.category, s, args.cache) for s in seeds]
    with tempfile.TemporaryDirectory() as tmp, ThreadPoolExecutor(args.jobs) as pool:
        for root in roots:
            n = len(folders)
            alone = np.array(list(pool.map(coloured_mota, [root] * n, folders, [False] * n, [Path(tmp)] * n)))
            paired = np.array(list(pool.map(coloured_mota, [root] * n, folders, [True] * n, [Path(tmp)] * n)))
            print(f"{root} ({args.category} seeds {seeds[0]}-{seeds[-1]}):")
            print(f"  alone:             {summary(alone)}")
            print(f"  with white target: {summary(paired)}")
            worst = np.argsort(np.nan_to_num(paired - alone))[:5]
            print("  most changed: " + ", ".join(f"{seeds[k]} {alone[k]:.3f} -> {paired[k]:.3f}" for k in worst))
    return 0


if __name__ == "__main__":
    sys.exit(main())
