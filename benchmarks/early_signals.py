"""Stop signals in a command's first second, hundreds of times: hangs and bad exits (issue 15, clean shutdown).

    .venv/bin/python benchmarks/early_signals.py --runs 450                    # live --record, record, track in turn (~15 min)
    .venv/bin/python benchmarks/early_signals.py --runs 300 --root /tmp/old --root .  # two checkouts, alternating

Each run starts the real command as a subprocess (``python -m stereotrack``),
waits until its SIGTERM handler is in place (the package's first lines; before
that Python's own defaults apply), then sends SIGINT or SIGTERM after a delay
drawn uniformly from 0-1 s (``--max-delay``; a seeded generator draws every delay and signal up
front, so the schedule does not depend on ``--jobs``). A run still alive after
``--timeout`` seconds is a hang: it gets SIGABRT, and faulthandler
(PYTHONFAULTHANDLER) prints every thread's stack, kept in ``--keep``. A bad exit
is a traceback, an exit status other than 0, 2 or 128 + the signal, or a
recording folder that does not open. ``--jobs 2`` runs two at once: the
machine is then loaded, as the suite's runs are when the hang was seen. With
several ``--root`` checkouts (e.g. an export of the commit before a fix, and
this one) each gets the same schedule, run by run in alternation, so both see
the same load.
Prints one line per command and one for the total (BENCHMARKS.md quotes them).
"""

from __future__ import annotations

import argparse
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections import Counter
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests" / "capture"))

from test_stops import wait_for_handlers  # noqa: E402  (the suite's own wait: same moment zero)

SIM = ["--width", "320", "--height", "240", "--fps", "30"]
COMMANDS = ("live", "record", "track")


def command_line(command: str, out: Path, source: Path) -> list[str]:
    return {
        "live": ["live", "--cam0", "sim:pendulum4", "--cam1", "sim:pendulum4", *SIM, "--quiet", "--record", str(out)],
        "record": ["record", "--cam0", "sim:dots", "--cam1", "sim:dots", *SIM, "--out", str(out)],
        "track": ["track", str(source), "--quiet", "--out", str(out.with_suffix(".csv"))],
    }[command]


def one_run(k: str, command: str, delay: float, sig: int, root: Path, work: Path, source: Path, timeout: float) -> tuple[str, str]:
    """('ok' | 'hang' | 'bad', detail)."""
    from stereotrack.recording import open_recording

    out = work / f"{command}{k}"
    env = dict(os.environ, PYTHONFAULTHANDLER="1")  # SIGABRT then prints every thread's stack
    proc = subprocess.Popen(
        [sys.executable, "-m", "stereotrack", *command_line(command, out, source)],
        cwd=root,
        env=env,
        stdin=subprocess.DEVNULL,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    wait_for_handlers(proc)
    time.sleep(delay)
    proc.send_signal(sig)
    try:
        _, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.send_signal(signal.SIGABRT)
        try:
            _, err = proc.communicate(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            _, err = proc.communicate()
        return "hang", err
    if "Traceback" in err or proc.returncode not in (0, 2, 128 + sig, -sig):
        return "bad", f"exit {proc.returncode}: {err[-2000:]}"
    if (out / "meta.yaml").exists():
        try:
            open_recording(out)
        except Exception as exc:  # noqa: BLE001 - any failure to open is the finding
            return "bad", f"folder does not open: {exc}"
    shutil.rmtree(out, ignore_errors=True)
    return "ok", f"exit {proc.returncode}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=450, help="runs in all, the commands in turn (default 450)")
    ap.add_argument("--commands", default=",".join(COMMANDS), help="comma-separated, of live,record,track")
    ap.add_argument("--seed", type=int, default=15)
    ap.add_argument("--max-delay", type=float, default=1.0, help="signals come 0 to this many seconds after the handlers are in place")
    ap.add_argument("--root", type=Path, action="append", help="checkout whose stereotrack runs (default: this one); repeat to compare")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--timeout", type=float, default=20.0, help="seconds after the signal before a run counts as hung")
    ap.add_argument("--label", action="append", help="name of each --root in the output (default: its git commit)")
    ap.add_argument("--keep", type=Path, default=None, help="folder for the stderr of hangs and bad exits")
    a = ap.parse_args()
    commands = a.commands.split(",")
    rng = np.random.default_rng(a.seed)
    delays = rng.uniform(0.0, a.max_delay, a.runs)
    sigs = rng.choice([int(signal.SIGINT), int(signal.SIGTERM)], a.runs)
    work = Path(tempfile.mkdtemp(prefix="early-signals-"))
    keep = a.keep or work / "findings"
    keep.mkdir(parents=True, exist_ok=True)
    roots = [r.resolve() for r in (a.root or [ROOT])]
    labels = a.label or [f"{r.name}@{_head(r)}" for r in roots]
    source = work / "source"
    if "track" in commands:
        subprocess.run(
            [sys.executable, "-m", "stereotrack", "synth", "pendulum4", "--frames", "60", *SIM[:4], "--out", str(source)],
            cwd=roots[0],
            check=True,
            capture_output=True,
            timeout=300,
        )
    plan = [(k, r, commands[k % len(commands)], float(delays[k]), int(sigs[k])) for k in range(a.runs) for r in range(len(roots))]
    outcomes = {(r, c): Counter() for r in range(len(roots)) for c in commands}
    statuses = {(r, c): Counter() for r in range(len(roots)) for c in commands}  # where the signals landed, by exit status
    start = time.monotonic()

    def job(item):
        k, r, command, delay, sig = item
        verdict, detail = one_run(f"{k}-{r}", command, delay, sig, roots[r], work, source, a.timeout)
        if verdict != "ok":
            name = f"{k:04d}-{labels[r]}-{command}-{verdict}.txt".replace("/", "_")
            (keep / name).write_text(f"{labels[r]}: delay {delay:.3f} s, {signal.Signals(sig).name}\n{detail}")
            print(f"  {labels[r]} run {k} {command} {signal.Signals(sig).name} at {delay:.3f} s: {verdict} ({keep / name})", flush=True)
        return r, command, verdict, detail.split(":")[0] if verdict != "hang" else "hang"

    with ThreadPoolExecutor(a.jobs) as pool:
        for r, command, verdict, status in pool.map(job, plan):
            outcomes[r, command][verdict] += 1
            statuses[r, command][status] += 1
    minutes = (time.monotonic() - start) / 60
    for r, label in enumerate(labels):
        for c in commands:
            o = outcomes[r, c]
            how = ", ".join(f"{n} {s}" for s, n in sorted(statuses[r, c].items()))
            print(f"{label} {c}: {sum(o.values())} runs, {o['hang']} hangs, {o['bad']} bad exits ({how})")
        total = sum((outcomes[r, c] for c in commands), Counter())
        print(f"{label} all: {sum(total.values())} runs: {total['hang']} hangs, {total['bad']} bad exits")
    print(
        f"{len(plan)} runs in {minutes:.1f} min (signals 0-{a.max_delay:g} s in, --jobs {a.jobs}, seed {a.seed}, timeout {a.timeout:g} s); "
        f"findings in {keep}"
    )
    shutil.rmtree(work / "source", ignore_errors=True)


def _head(root: Path) -> str:
    try:
        return (
            subprocess.run(["git", "-C", str(root), "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip() or "?"
        )
    except OSError:
        return "?"


if __name__ == "__main__":
    main()
