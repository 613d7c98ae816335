"""Score a tracks CSV against ground truth: CLEAR MOT and 3D error.

MOTA, MOTP (mm), misses, false positives and id switches, with a distance
gate (a track further than the gate from a true ball does not match it),
plus the mean and 95th-percentile 3D error of the matches. A ball that
fewer than two cameras see (truth.csv's optional `clear` column: the cameras
that show a quarter of it or more; else its `visible` column) may be
tracked but need not be: neither a miss nor, when a track stands on it, a
false positive (--count-hidden counts it as any other ball).

example:
  stereotrack eval recordings/demo/tracks.csv recordings/demo/truth.csv
"""

from __future__ import annotations

import argparse
import json

HELP = "score tracks.csv against truth.csv (CLEAR MOT, 3D error)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("tracks", help="tracks CSV written by 'stereotrack track'")
    p.add_argument("truth", help="ground truth CSV (frame,object_id,x,y,z)")
    from ..argtypes import number

    p.add_argument("--gate", type=number(above=0, hi=1000), default=0.1, help="match distance in metres (default 0.1)")
    p.add_argument(
        "--count-hidden",
        action="store_true",
        help="require balls that fewer than two cameras see (truth.csv's 'clear' column, else 'visible') like any other; by default they are optional",
    )
    p.add_argument("--json", action="store_true", help="print the figures as JSON")


def run(args) -> int:
    from ..evaluate import evaluate
    from ..recording import read_truth_and_views
    from ..sinks.tracks_csv import read_tracks

    truth, views = read_truth_and_views(args.truth)
    ev = evaluate(read_tracks(args.tracks), truth, gate=args.gate, views=None if args.count_hidden else views)
    print(json.dumps(ev.as_dict(), indent=2) if args.json else ev.table())
    return 0
