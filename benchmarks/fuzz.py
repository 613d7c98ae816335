#!/usr/bin/env python3
"""The long fuzzing run: the suite's properties (tests/test_fuzz.py) with many random examples each.

    .venv/bin/python benchmarks/fuzz.py                 # 200 examples per property (about an hour on 2 cores)
    .venv/bin/python benchmarks/fuzz.py --examples 20 -k config

For every file format and every command's options it counts the examples
run, how many exited 0 and how many were refused (exit 2, one line), and
prints the first input that broke the invariant ("exit 0, or exit 2 with one
line; no traceback; the user's files unchanged; within 30 s"), shrunk by
hypothesis. Unlike the suite it is not derandomized: each run explores new
inputs. Exit status 1 if any property failed.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
import traceback
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--examples", type=int, default=200, help="examples per property (default 200)")
    ap.add_argument("-k", default="", help="only the properties whose name contains this")
    args = ap.parse_args()
    os.environ["STEREOTRACK_FUZZ_EXAMPLES"] = str(args.examples)
    os.environ["STEREOTRACK_FUZZ_RANDOM"] = "1"

    import fuzzing
    import test_fuzz

    fixture = fuzzing.build_fixture(Path(tempfile.mkdtemp(prefix="fuzz_fixture_")) / "fixture")
    properties = [
        (f"file: {name}", test_fuzz.test_any_file_content_exits_0_or_one_line, {"name": name}, f"file {name}") for name in test_fuzz.FILES
    ]
    properties += [
        (f"options: {c}", test_fuzz.test_any_option_value_exits_0_or_one_line, {"command": c}, f"options {c}") for c in test_fuzz.OPTIONS
    ]
    properties += [
        (f"output: {c}", test_fuzz.test_any_output_path_harms_no_user_file, {"command": c}, f"output {c}")
        for c in test_fuzz.OUTPUT_COMMANDS
    ]
    properties += [("options: sim camera spec", test_fuzz.test_any_simulated_camera_spec_exits_0_or_one_line, {}, "sim camera")]
    failures = []
    t0 = time.monotonic()
    print("| property | examples | exit 0 | exit 2 | other | seconds | result |\n|---|---|---|---|---|---|---|", flush=True)
    for label, prop, kwargs, counter in properties:
        if args.k and args.k not in label:
            continue
        start = time.monotonic()
        result = "ok"
        try:
            prop(fixture=fixture, **kwargs)
        except BaseException as exc:  # a broken invariant (hypothesis shrinks it and re-raises), or a crash of the harness
            if isinstance(exc, KeyboardInterrupt):
                raise
            result = "FAILED"
            failures.append((label, "".join(traceback.format_exception_only(type(exc), exc)).strip()[-1500:]))
        c = fuzzing.COUNTS
        n0, n2, other = c[(counter, "ok")], c[(counter, "refused")], c[(counter, "other")]
        print(f"| {label} | {n0 + n2 + other} | {n0} | {n2} | {other} | {time.monotonic() - start:.0f} | {result} |", flush=True)
    total = sum(fuzzing.COUNTS.values())
    print(f"\n{total} examples in {time.monotonic() - t0:.0f} s; {len(failures)} properties failed")
    for label, message in failures:
        print(f"\n## {label}\n{message}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
