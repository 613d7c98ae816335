"""Where the stress suite's errors are: each miss and false positive of its scored scenes, by kind.

MOTA counts misses, false positives and identity switches; it does not say which balls they were. This reads the
scenes ``stereotrack stress`` rendered and tracked (its cache: truth.csv and tracks_METHOD.csv per scene) and scores
each again event by event (``stereotrack.evaluate.error_events``: the same assignment, gate and optional balls as
``stereotrack eval``), then sorts them:

- a miss of a ball that some camera shows under HIDDEN of (``simulation.visibility.shown``: behind a prop, deep in a hand) is
  **hidden in a view**: required though a camera hardly sees it (truth's ``clear`` leaves a ball optional when fewer than
  two cameras show a quarter of it; with three cameras two may, and the third show a sliver; a scene rendered before
  ``clear`` counts a camera that shows a pixel of it);
- else a miss before the ball's first match is **not yet found** (the tracker finds a ball late: at start, or when it
  first comes into view); a miss of a ball never matched in its scene is **never found**;
- a miss after its ball's first match is a ball **lost**: **slow** where the ball moves under SLOW m/s (at rest,
  held or carried in a hand, at a swing's turning point), **fast** otherwise;
- a false positive belongs to a track that is false in LASTING or more frames of its scene (**lasting**: a ghost
  that stays) or in fewer (**brief**: a track a frame or two off its ball, a ghost that dies).

    .venv/bin/python benchmarks/error_classes.py                               # report seeds, after `stereotrack stress --set report`
    .venv/bin/python benchmarks/error_classes.py --set tune --seeds 80 --categories hands hue_wall
    .venv/bin/python benchmarks/error_classes.py --docs docs/evaluation.md     # replace that file's error-classes section

Counts are ball-frames (one ball in one frame) summed over the seeds; it scores the tracks already there, so run
``stereotrack stress`` with the same --set, --seeds and --cache first (on the code it should describe).
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass, fields
from datetime import date
from pathlib import Path

import numpy as np

from stereotrack.evaluate import FALSE, MATCH, MISS, SWITCH, error_events
from stereotrack.files import replace_section
from stereotrack.recording import open_recording, read_truth_and_views
from stereotrack.simulation import visibility
from stereotrack.simulation.render import CLEAR_SHARE, SceneRenderer
from stereotrack.simulation.stress import CATEGORIES, seeds, stress_scene
from stereotrack.sinks.tracks_csv import read_tracks

SLOW = 1.0  # m/s: a ball slower than this is at rest, held, carried or turning, not flying
LASTING = 10  # frames: a track false in this many frames of its scene is a ghost that stays
HIDDEN = CLEAR_SHARE  # a camera that shows under this share of a ball's pixels hardly sees it (as truth's ``clear``)


@dataclass
class Classes:
    """Ball-frames of one or more scenes, by what became of them."""

    ball_frames: int = 0  # ball-frames that count (the ball seen by two cameras or more)
    hidden: int = 0
    not_yet_found: int = 0
    never_found: int = 0
    lost_slow: int = 0
    lost_fast: int = 0
    false_lasting: int = 0
    false_brief: int = 0
    id_switches: int = 0

    def __add__(self, other: Classes) -> Classes:
        return Classes(*(getattr(self, f.name) + getattr(other, f.name) for f in fields(self)))


def speeds(truth: np.ndarray, times: np.ndarray) -> dict[tuple[int, int], float]:
    """Per (frame, ball id) of ``truth`` (frame, id, x, y, z rows): the ball's speed there, m/s, from its positions in
    its neighbouring rows (``times``: each frame's time, s); 0 for a ball in one row only."""
    out = {}
    for ball in np.unique(truth[:, 1]):
        rows = truth[truth[:, 1] == ball]
        rows = rows[np.argsort(rows[:, 0], kind="stable")]
        frames = rows[:, 0].astype(int)
        if len(rows) < 2:
            v = np.zeros(len(rows))
        else:
            v = np.linalg.norm(np.gradient(rows[:, 2:5], times[frames], axis=0), axis=1)
        out.update({(int(f), int(ball)): float(s) for f, s in zip(frames, v)})
    return out


def classify(events: np.ndarray, speed: dict[tuple[int, int], float], least_shown=lambda frame, ball: 1.0) -> Classes:
    """One scene's ``error_events`` sorted into Classes (``speed``: per (frame, ball id), from ``speeds``;
    ``least_shown(frame, ball)``: the least share of the ball any camera shows then, from ``simulation.visibility.shown``)."""
    c = Classes()
    kind, frame, ball, track = events[:, 1], events[:, 0], events[:, 2], events[:, 3]
    found = (kind == MATCH) | (kind == SWITCH)
    c.ball_frames = int((found | (kind == MISS)).sum())
    c.id_switches = int((kind == SWITCH).sum())
    first = {int(b): int(frame[found & (ball == b)].min()) for b in np.unique(ball[found])}
    for f, b in zip(frame[kind == MISS].tolist(), ball[kind == MISS].tolist()):
        if least_shown(f, b) < HIDDEN:
            c.hidden += 1
        elif b not in first:
            c.never_found += 1
        elif f < first[b]:
            c.not_yet_found += 1
        elif speed.get((f, b), 0.0) < SLOW:
            c.lost_slow += 1
        else:
            c.lost_fast += 1
    _, per_track = np.unique(track[kind == FALSE], return_counts=True)
    c.false_lasting = int(per_track[per_track >= LASTING].sum())
    c.false_brief = int(per_track[per_track < LASTING].sum())
    return c


def scene_classes(folder: Path, method: str, category: str, seed: int) -> Classes:
    """Classes of one scene the stress command tracked and scored (its folder in the cache), rendered again where a
    ball was missed to tell how much of it each camera showed."""
    recording = open_recording(folder)
    truth, views = read_truth_and_views(recording.truth_path)
    tracks = read_tracks(folder / f"tracks_{method}.csv")
    events = error_events(tracks, truth, frames=np.arange(recording.n_frames), views=views)
    shown = {}
    if (events[:, 1] == MISS).any():
        renderer = SceneRenderer(stress_scene(category, seed))
        shown = {int(f): visibility.shown(renderer, int(f)) for f in np.unique(events[events[:, 1] == MISS, 0])}
    return classify(events, speeds(truth, recording.timestamps[:, 0]), lambda f, b: float(np.nanmin(shown[f][:, b], initial=1.0)))


def table(rows: dict[str, Classes], n_seeds: int, seed_set: str, command: str) -> str:
    head = [
        f"Produced by `{command}` on {date.today().isoformat()}, from the tracks `stereotrack stress` left in its cache.",
        f"Per category, the ball-frames of {n_seeds} `{seed_set}` seeds that MOTA counts as misses, false positives and",
        f"id switches, by kind (HIDDEN = {HIDDEN:g}, SLOW = {SLOW:g} m/s, LASTING = {LASTING} frames; the script's docstring says what each is). MOTA =",
        "1 - (misses + false positives + id switches) / ball-frames, here over all the seeds at once.",
        "",
        "| category | ball-frames | hidden in a view | not yet found | never found | lost, slow | lost, fast | false, lasting | false, brief | id switches |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    lines = [
        f"| {name} | {c.ball_frames} | {c.hidden} | {c.not_yet_found} | {c.never_found} | {c.lost_slow} | {c.lost_fast} | {c.false_lasting} | "
        f"{c.false_brief} | {c.id_switches} |"
        for name, c in rows.items()
    ]
    return "\n".join(head + lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--cache", default="out/stress", help="the stress command's cache (default out/stress)")
    p.add_argument("--set", dest="seed_set", choices=["tune", "report"], default="report")
    p.add_argument("--seeds", type=int, default=20, help="seeds per category (default 20)")
    p.add_argument("--categories", nargs="+", choices=list(CATEGORIES), default=list(CATEGORIES))
    p.add_argument("--method", default="particles", choices=["particles", "baseline"])
    p.add_argument("--docs", metavar="FILE", help="replace FILE's error-classes section with the table")
    args = p.parse_args(argv)
    rows = {}
    for category in args.categories:
        total = Classes()
        for seed in seeds(args.seed_set, args.seeds):
            folder = Path(args.cache) / category / f"{seed:07d}"
            if not (folder / f"tracks_{args.method}.csv").is_file():
                print(
                    f"{folder}: no tracks_{args.method}.csv (run `stereotrack stress --set {args.seed_set} --seeds {args.seeds}` first)",
                    file=sys.stderr,
                )
                return 2
            total = total + scene_classes(folder, args.method, category, seed)
        rows[category] = total
    command = " ".join([".venv/bin/python benchmarks/error_classes.py", *(argv if argv is not None else sys.argv[1:])])
    text = table(rows, args.seeds, args.seed_set, command)
    print(text, end="")
    if args.docs:
        replace_section(args.docs, "error-classes", "## Where the errors are\n\n" + text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
