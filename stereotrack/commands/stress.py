"""Score the particle tracker and the classic baseline on randomised stress scenes: a table per category.

Each category (see --list) draws a new scene from every seed: the rig, the
room, the balls' colour, size, number and paths, and the category's own
trouble. Seeds come in two sets that never overlap: 'tune' (look at these,
tune on these; seeds 0, 1, 2 ...) and 'report' (what docs/evaluation.md
shows, never tuned on; seeds 1000000, 1000001 ...). Every scene is rendered once into CACHE/CATEGORY/SEED and reused while
its spec and the renderer are unchanged; a method's score is reused while
the package's code is unchanged too, so reruns are cheap and an interrupted
run resumes (a run the machine failed, a full disk, is tried again). Both methods run as `stereotrack track --method
particles|baseline` does, with the target a user would type for the ball
(its hue +-10, S and V from about 80; a white ball: low S, high V) and every
other setting at this checkout's default, and are scored like `stereotrack
eval`. Ctrl-C stops at once: workers are killed, nothing half-done is kept.

examples:
  stereotrack stress --list
  stereotrack stress --seeds 5                                   # 5 tune seeds per category
  stereotrack stress --categories hands fast_ball --seeds 3 --jobs 1
  stereotrack stress --set report --seeds 20 --docs docs/evaluation.md
  stereotrack stress --categories hue_wall --seeds 40 --tracker-seed 1      # how much of each score is luck
"""

from __future__ import annotations

import argparse
import ast
import contextlib
import dataclasses
import functools
import hashlib
import io
import json
import os
import shutil
import statistics
import tempfile
import time
import warnings
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

HELP = "score both trackers on randomised stress scenes (tune or report seeds)"
METHODS = ("particles", "baseline")
CODEC = "mjpg"  # like a webcam's stream; lossless FFV1 takes 6.5 times the disk (26.7 vs 4.1 MB, hue_wall seed 0, 30 frames)
TARGET_MEDIAN, TARGET_WORST = 0.95, 0.85  # issue 14's goal for every category
PACKAGE = Path(__file__).resolve().parent.parent
# The scene side's own code: a scene is rendered again when its syntax tree changes (not for a comment or reformatting).
RENDER_CODE = ("simulation/spec.py", "simulation/render.py", "simulation/stage.py", "simulation/shapes.py", "simulation/hands.py",
               "simulation/trajectories.py")  # fmt: skip


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--list", action="store_true", help="list the categories and exit")
    p.add_argument("--set", dest="seed_set", choices=["tune", "report"], default="tune", help="seed set: 'tune' (default) or 'report'")
    p.add_argument("--seeds", type=int, default=20, metavar="N", help="seeds per category (default 20)")
    p.add_argument("--categories", nargs="+", metavar="NAME", help="categories to run (default: all)")
    p.add_argument("--methods", nargs="+", choices=METHODS, default=list(METHODS), help="default: both")
    p.add_argument("--frames", type=int, metavar="N", help="cut every scene to its first N frames (a quick look, not a report)")
    p.add_argument("--scale", type=float, default=1.0, metavar="S", help="image size factor, e.g. 0.5 (a quick look, not a report)")
    p.add_argument(
        "--jobs", type=int, default=min(2, os.cpu_count() or 1), metavar="J", help="scenes rendered and tracked at once (default 2)"
    )
    p.add_argument(
        "--tracker-seed",
        type=int,
        default=0,
        metavar="N",
        help="the particle tracker's random seed (tracker.seed; default 0, as the report): another shows how much of a "
        "scene's score is the draw of its particles (scored beside seed 0's, in files named _seedN)",
    )
    p.add_argument("--cache", default="out/stress", metavar="DIR", help="rendered scenes and scores (default out/stress)")
    p.add_argument("--docs", metavar="FILE", help="replace FILE's stress section with the table (report set, whole scenes only)")
    p.add_argument("--quiet", action="store_true", help="no line per scene")


def run(args) -> int:
    from datetime import UTC, datetime

    from ..console import info
    from ..errors import StereotrackError
    from ..evaluate import NO_BALL, figure
    from ..files import replace_section
    from ..simulation.stress import CATEGORIES, describe, seeds

    if args.list:
        width = max(map(len, CATEGORIES))
        for name in CATEGORIES:
            print(f"{name:<{width}}  {describe(name)}")
        return 0
    cats = args.categories or list(CATEGORIES)
    unknown = [c for c in cats if c not in CATEGORIES]
    if unknown:
        raise StereotrackError(f"unknown stress category {unknown[0]!r}: choose from {', '.join(CATEGORIES)} (see --list)")
    if not 1 <= args.seeds <= 1_000_000 or args.jobs < 1:
        raise StereotrackError("--seeds must be 1 to 1000000 and --jobs at least 1")
    if args.frames is not None and args.frames < 2:
        raise StereotrackError(f"--frames must be at least 2, got {args.frames}")
    if not 0.1 <= args.scale <= 2.0:
        raise StereotrackError(f"--scale must be between 0.1 and 2, got {args.scale}")
    if args.docs and (args.seed_set != "report" or args.frames is not None or args.scale != 1.0):
        raise StereotrackError("--docs takes the report set of whole scenes only: add --set report and drop --frames and --scale")
    if not 0 <= args.tracker_seed < 2**63:
        raise StereotrackError(f"--tracker-seed must be 0 to 2**63 - 1, got {args.tracker_seed}")
    if args.docs and args.tracker_seed:
        raise StereotrackError("--docs takes the tracker's default seed only: drop --tracker-seed")
    if args.docs and not Path(args.docs).is_file():
        raise StereotrackError(f"{args.docs}: no such file (point --docs at docs/evaluation.md)")
    jobs = [
        Job(c, s, str(args.cache), tuple(args.methods), args.frames, args.scale, args.tracker_seed)
        for c in cats
        for s in seeds(args.seed_set, args.seeds)
    ]
    remove_left_behind(Path(args.cache))
    start = time.perf_counter()

    def report(r: dict) -> None:
        if args.quiet:
            return
        parts = [
            f"{m} " + (f"failed ({v['error']})" if "error" in v else f"MOTA {figure(v['mota'], '.3f', NO_BALL)}")
            for m, v in r["methods"].items()
        ]
        how = "rendered" if r["rendered"] else "cached scene"
        info(f"{r['category']} seed {r['seed']}: {', '.join(parts)} ({how}; {time.perf_counter() - start:.0f} s)")

    results = run_jobs(jobs, args.jobs, report)
    minutes = (time.perf_counter() - start) / 60
    rendered = sum(r["rendered"] for r in results)
    table = markdown_table(summarise(results, args.methods))
    print(table)
    per_seed = write_results_csv(results, Path(args.cache) / f"{args.seed_set}-results{seed_suffix(args.tracker_seed)}.csv")
    info(
        f"{len(jobs)} scenes ({rendered} rendered, the rest cached) in {minutes:.1f} min with {args.jobs} job(s); every seed's figures in {per_seed}"
    )
    if args.docs:
        body = [
            "## Stress suite: random rooms in ten categories",
            "",
            f"Produced by `stereotrack stress --set report --seeds {args.seeds}"
            + (f" --categories {' '.join(cats)}" if args.categories else "")
            + (f" --methods {' '.join(args.methods)}" if tuple(args.methods) != METHODS else "")
            + f" --docs {args.docs}` on {datetime.now(UTC):%Y-%m-%d}: {len(jobs)} scenes ({rendered} rendered) in {minutes:.0f} min "
            f"with {args.jobs} job(s) on the shared 2-core machine (CPU: {host_cpu()}). Another CPU can score the same code on the "
            "same scenes differently: vectorised arithmetic rounds differently there, and a tracker's particles part ways "
            "from the first differing bit (fast_ball's median was 0.865 on one machine and 0.934 on the next, code unchanged). "
            "Compare rows measured on one machine.",
            f"Report seeds {seeds('report', 1)[0]} to {seeds('report', args.seeds)[-1]} of each category; tuning uses other seeds "
            "(`--set tune`). The target is the range a user would type for the ball; MOTA as `stereotrack eval` (0.1 m gate; "
            "a ball that fewer than two cameras show a quarter of or more is optional: truth.csv's `clear`).",
            "`particles` is `stereotrack track --method particles` as this checkout configures it: a scene's recording holds "
            "only its typed target (and `fast_ball`'s depth range), every other setting is its default in `stereotrack/config.py`, "
            "so a changed default is what the next run measures; `baseline` is `--method baseline`.",
            f"Issue 14's goal: median MOTA >= {TARGET_MEDIAN} and worst >= {TARGET_WORST} in every category.",
            "",
            table,
            "",
            *(f"- `{c}`: {describe(c)}" for c in cats),
        ]
        replace_section(args.docs, "stress", "\n".join(body))
        info(f"table written to {args.docs} (section 'stress')")
    return 0


def host_cpu() -> str:
    """The CPU the scores were measured on, as the tracker's compiler names it (numba's LLVM), e.g. 'sapphirerapids'."""
    try:
        from llvmlite import binding

        return binding.get_host_cpu_name()
    except Exception:  # noqa: BLE001 (a name in a table header: never worth failing the run)
        import platform

        return platform.machine() or "unknown"


# --------------------------------------------------------------------------- one scene


@dataclass(frozen=True)
class Job:
    category: str
    seed: int
    cache: str
    methods: tuple[str, ...] = METHODS
    frames: int | None = None  # cut the scene to its first frames (quick looks)
    scale: float = 1.0  # image size factor (quick looks)
    tracker_seed: int = 0  # the particle tracker's random seed (tracker.seed)

    @property
    def suffix(self) -> str:
        return seed_suffix(self.tracker_seed)

    @property
    def folder(self) -> Path:
        tag = f"{self.seed:07d}" + (f"-f{self.frames}" if self.frames else "") + (f"-x{self.scale:g}" if self.scale != 1.0 else "")
        return Path(self.cache) / self.category / tag

    def spec(self):
        from ..simulation.stress import stress_scene

        spec = stress_scene(self.category, self.seed)
        if self.frames:
            spec = dataclasses.replace(spec, n_frames=min(spec.n_frames, int(self.frames)))
        if self.scale != 1.0:
            w, h = (max(32, int(round(x * self.scale))) for x in (spec.rig.width, spec.rig.height))
            spec = dataclasses.replace(spec, rig=dataclasses.replace(spec.rig, width=w, height=h))
        return spec


def _canonical(obj: Any) -> Any:
    """A JSON-able, order-stable picture of a spec: dataclasses field by field, arrays by a hash of their bytes."""
    import numpy as np

    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {"@": type(obj).__name__, **{f.name: _canonical(getattr(obj, f.name)) for f in dataclasses.fields(obj)}}
    if isinstance(obj, np.ndarray):
        return {
            "@array": hashlib.sha256(np.ascontiguousarray(obj).tobytes()).hexdigest(),
            "shape": list(obj.shape),
            "dtype": str(obj.dtype),
        }
    if isinstance(obj, (list, tuple)):
        return [_canonical(x) for x in obj]
    if isinstance(obj, dict):
        return {str(k): _canonical(v) for k, v in sorted(obj.items())}
    if isinstance(obj, (float, np.floating)):
        return repr(float(obj))
    if isinstance(obj, np.generic):
        return obj.item()
    if obj is None or isinstance(obj, (bool, int, str)):
        return obj
    raise TypeError(f"cannot key a {type(obj).__name__} in a scene spec")


def _source_hash(paths: Iterable[Path]) -> str:
    """A hash of what the code does: its syntax tree, so reformatting or a comment does not re-render or re-track."""
    h = hashlib.sha256()
    for p in sorted(paths):
        h.update(str(p.relative_to(PACKAGE)).encode())
        h.update(ast.dump(ast.parse(p.read_text())).encode())
    return h.hexdigest()


def scene_key(spec) -> str:
    """Changes when the scene changes, or the code that renders it, or what the rest of the way to a recording makes of it.

    The scene's config counts as its recording holds it (only what differs from the defaults): a changed tracker
    default renders nothing again, and the scores, keyed on the package's code (code_key), are measured afresh.
    """
    from ..config import config_to_dict

    written = config_to_dict(spec.config())
    scene = _canonical(dataclasses.replace(spec, user_config=None))
    text = json.dumps([scene, written], sort_keys=True) + render_code_key() + renderer_fingerprint()
    return hashlib.sha256(text.encode()).hexdigest()[:24]


@functools.cache  # once per process: parsing the code took 1.4 s per scene, as long as tracking a small one
def render_code_key() -> str:
    return _source_hash(PACKAGE / p for p in RENDER_CODE)


@functools.cache
def renderer_fingerprint() -> str:
    """The pixels, truth and calibration of two tiny probe scenes written as a stress scene is and read back.

    The camera model, the recording writer and the codec live outside the simulation package: when they change
    what a recording holds, every scene is rendered again; when a change there moves no pixel, none is.
    """
    import tempfile

    from ..recording import open_recording
    from ..simulation.write import render_scene

    h = hashlib.sha256()
    with tempfile.TemporaryDirectory() as tmp:
        for category in ("hands", "lighting"):  # a stage, movers, tone curve, white balance, vignetting, blur
            spec = dataclasses.replace(Job(category, 0, tmp, frames=2, scale=0.15).spec(), jpeg_quality=60)
            folder = Path(tmp) / category
            render_scene(spec, folder, progress=False, codec=CODEC)
            for pair in open_recording(folder).frames():
                for image in pair.images:
                    h.update(image.tobytes())
            h.update((folder / "truth.csv").read_bytes() + (folder / "calib.yaml").read_bytes())
    return h.hexdigest()[:24]


@functools.cache
def code_key() -> str:
    """Changes when the code that tracks or scores changes: the package but the scene side (keyed by scene_key) and this command."""
    own = {PACKAGE / "commands" / "stress.py"}
    return _source_hash(p for p in PACKAGE.rglob("*.py") if p not in own and "simulation" not in p.relative_to(PACKAGE).parts)[:24]


def render_cached(spec, folder: Path) -> bool:
    """Render ``spec`` into ``folder`` unless a complete rendering with the same key is there; True if rendered.

    MJPG (CODEC), like a webcam's stream. A half-written
    rendering never takes the folder's place: it is written beside it and renamed when complete (a run
    killed mid-way leaves it hidden beside the folder, and the next run removes it). Two runs sharing a cache may
    render one new scene at once: the one that finishes second keeps the first's folder, which that run may be
    tracking already (renamed aside, its tracks file had nowhere to go).
    """
    from ..errors import StereotrackError
    from ..recording import open_recording
    from ..simulation.write import render_scene

    key = scene_key(spec)

    def complete() -> bool:
        stamp = folder / "scene.key"
        if stamp.is_file() and stamp.read_text().strip() == key:
            try:
                return open_recording(folder).n_frames == spec.n_frames
            except StereotrackError:
                pass
        return False

    if complete():
        return False
    tmp = folder.with_name(f".{folder.name}.partial-{os.getpid()}")
    try:
        render_scene(spec, tmp, progress=False, codec=CODEC)
        (tmp / "scene.key").write_text(key + "\n")
        if complete():  # another run sharing the cache put the same scene there meanwhile, and may be tracking it: keep it
            return True
        old = folder.with_name(f".{folder.name}.partial-old-{os.getpid()}")
        if folder.exists():  # renamed aside, not deleted in place: a run killed here leaves no half-deleted scene
            os.replace(folder, old)
        os.replace(tmp, folder)
        shutil.rmtree(old, ignore_errors=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)  # only there when rendering failed or was interrupted
    return True


def remove_left_behind(cache: Path) -> None:
    """Remove the half-written scenes a killed run left hidden in the cache (those of a live run are kept)."""
    for stale in cache.glob("*/.*.partial-*"):
        pid = stale.name.rpartition("-")[2]  # the process that wrote it
        if pid.isdigit() and not _running(int(pid)):
            shutil.rmtree(stale, ignore_errors=True)


def _running(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # someone else's
        return True
    return True


def track_and_score(folder: Path, method: str, n_frames: int, tracker_seed: int = 0) -> dict:
    """``stereotrack track --method METHOD`` on a scene (its own code, in this process), scored like ``stereotrack eval``;
    with a ``tracker_seed``, the scene's config with that ``tracker.seed`` (a copy beside the run, not the scene's own).

    A run that fails is a result too: its error goes in the table instead of stopping the other scenes. One the
    machine failed (an OSError: a full disk, a file another process held) is marked ``retry``: not the code's result.
    """
    from ..evaluate import evaluate
    from ..recording import open_recording, read_truth_and_views
    from ..sinks.tracks_csv import read_tracks
    from . import track

    parser = argparse.ArgumentParser(prog="stereotrack track")
    track.add_arguments(parser)
    out = folder / f"tracks_{method}{seed_suffix(tracker_seed)}.csv"
    start = time.perf_counter()
    try:
        with tempfile.TemporaryDirectory() as tmp:
            config = ["--config", _with_tracker_seed(open_recording(folder).targets_path, tracker_seed, Path(tmp))] if tracker_seed else []
            args = parser.parse_args([str(folder), "--method", method, "--out", str(out), "--quiet", *config])
            with contextlib.redirect_stderr(io.StringIO()), contextlib.redirect_stdout(io.StringIO()):
                track.run(args)
    except Exception as exc:  # noqa: BLE001 (a user error or a tracker bug: both are this scene's result)
        failed = {"error": f"{type(exc).__name__}: {exc}", "seconds": time.perf_counter() - start}
        return {**failed, "retry": True} if isinstance(exc, OSError) else failed
    seconds = time.perf_counter() - start
    with warnings.catch_warnings():  # an empty tracks.csv is a result here, not news
        warnings.simplefilter("ignore", UserWarning)
        tracks, (truth, views) = read_tracks(out), read_truth_and_views(open_recording(folder).truth_path)
    return {**evaluate(tracks, truth, frames=list(range(n_frames)), views=views).as_dict(), "seconds": seconds}


def seed_suffix(tracker_seed: int) -> str:
    """What a tracker seed's tracks and scores add to their file names: nothing for the default (what a report uses)."""
    return f"_seed{tracker_seed}" if tracker_seed else ""


def _with_tracker_seed(config: Path, seed: int, folder: Path) -> str:
    """A copy of the scene's ``config`` in ``folder`` with ``tracker.seed`` set to ``seed``; its path."""
    import yaml

    data = yaml.safe_load(config.read_text()) or {}
    data.setdefault("tracker", {})["seed"] = int(seed)
    copy = folder / config.name
    copy.write_text(yaml.safe_dump(data, sort_keys=False))
    return str(copy)


def run_job(job: Job) -> dict:
    """Render (or reuse) one scene and score each method on it (or reuse the score)."""
    spec = job.spec()
    folder = job.folder
    folder.parent.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    rendered = render_cached(spec, folder)
    out = {"category": job.category, "seed": job.seed, "rendered": rendered, "render_seconds": time.perf_counter() - start, "methods": {}}
    from ..files import write_text_atomic

    key = scene_key(spec) + "-" + code_key()
    for method in job.methods:
        stamp = folder / f"score_{method}{job.suffix}.json"
        if stamp.is_file():
            saved = json.loads(stamp.read_text())
            if saved.get("key") == key:
                out["methods"][method] = saved["score"]
                continue
        score = track_and_score(folder, method, spec.n_frames, job.tracker_seed)
        if not score.pop("retry", False):  # the machine's failure is not kept: the next run tries that scene again
            write_text_atomic(stamp, json.dumps({"key": key, "score": score}, indent=1))
        out["methods"][method] = score
    return out


def _worker(conn) -> None:
    """A worker process: run the jobs its parent sends, one at a time, until it sends None (or kills it).

    Ctrl-C reaches the whole process group; it is the parent's to handle, so workers ignore it and keep out of
    the tracking loop's stop handling (which would otherwise end a scene early and score it). One thread each:
    the jobs are the parallelism, and the machine is shared.
    """
    import cv2

    from ..capture.signals import leave_to_parent

    leave_to_parent()
    cv2.setNumThreads(1)
    while (job := conn.recv()) is not None:
        try:
            conn.send(("ok", run_job(job)))
        except Exception as exc:  # noqa: BLE001 (the parent says which scene failed, and stops)
            conn.send(("error", f"{type(exc).__name__}: {exc}"))


def run_jobs(jobs: list[Job], workers: int, report: Callable[[dict], None] | None = None) -> list[dict]:
    """Every job, ``workers`` at a time in worker processes; results in the jobs' order.

    On Ctrl-C (or any error) the workers are killed at once, whatever they are doing: a scene they were
    rendering never took its folder's place (render_cached), a score they were writing is not saved.
    """
    results: list[dict] = []
    if workers <= 1 or len(jobs) <= 1:
        for job in jobs:
            results.append(run_job(job))
            if report:
                report(results[-1])
        return results
    import multiprocessing
    import signal
    from multiprocessing.connection import wait

    os.environ.setdefault("NUMBA_NUM_THREADS", "1")
    context = multiprocessing.get_context("spawn")  # fresh interpreters: no OpenCV or numba threads inherited mid-flight
    todo = list(reversed(jobs))
    busy: dict[Any, Job] = {}  # a worker's end of the pipe -> the job it runs
    procs = []
    try:
        for _ in range(min(workers, len(jobs))):
            ours, theirs = context.Pipe()
            # Born with Ctrl-C ignored (an ignored signal stays ignored through exec), so one that comes while a worker
            # starts cannot print a traceback there; this process handles Ctrl-C again as soon as the worker is started.
            previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
            try:
                proc = context.Process(target=_worker, args=(theirs,), daemon=True)
                proc.start()
            finally:
                signal.signal(signal.SIGINT, previous)
            theirs.close()
            procs.append(proc)
            busy[ours] = todo.pop()
            ours.send(busy[ours])
        while busy:
            for conn in wait(list(busy)):
                job = busy.pop(conn)
                try:
                    status, value = conn.recv()
                except EOFError:
                    raise RuntimeError(f"the worker running {job.category} seed {job.seed} died") from None
                if status != "ok":
                    raise RuntimeError(f"{job.category} seed {job.seed}: {value}")
                results.append(value)
                if report:
                    report(value)
                if todo:
                    busy[conn] = todo.pop()
                    conn.send(busy[conn])
                else:
                    conn.send(None)
    finally:
        for proc in procs:
            proc.kill()  # SIGKILL: nothing a worker does can hold the stop up
        for proc in procs:
            proc.join(timeout=10)
    order = {(j.category, j.seed): i for i, j in enumerate(jobs)}
    return sorted(results, key=lambda r: order[(r["category"], r["seed"])])


# --------------------------------------------------------------------------- the table


def summarise(results: list[dict], methods: Iterable[str]) -> list[dict]:
    """Per category and method: median and worst MOTA (and its seed), id switches, 3D error, recall, precision."""
    rows = []
    for cat in dict.fromkeys(r["category"] for r in results):
        for method in methods:
            runs = [(r["seed"], r["methods"][method]) for r in results if r["category"] == cat and method in r["methods"]]
            if not runs:
                continue
            done = [(s, m) for s, m in runs if "error" not in m]
            ok = [(s, m) for s, m in done if m["mota"] == m["mota"]]  # NaN: no ball seen by two cameras, nothing to score
            row: dict[str, Any] = {
                "category": cat,
                "method": method,
                "seeds": len(runs),
                "failed": len(runs) - len(done),
                "no_ball": len(done) - len(ok),
            }
            if ok:
                worst_seed, worst = min(ok, key=lambda sm: sm[1]["mota"])
                errors = [m["mean_error_mm"] for _, m in ok if m["mean_error_mm"] == m["mean_error_mm"]]  # NaN: nothing matched
                precisions = [m["precision"] for _, m in ok if m["precision"] == m["precision"]]  # NaN: no track at all
                row.update(
                    mota_median=statistics.median(m["mota"] for _, m in ok),
                    mota_worst=worst["mota"],
                    worst_seed=worst_seed,
                    id_switches_median=statistics.median(m["id_switches"] for _, m in ok),
                    id_switches_max=max(m["id_switches"] for _, m in ok),
                    error_mm_median=statistics.median(errors) if errors else float("nan"),
                    recall_median=statistics.median(m["recall"] for _, m in ok),
                    precision_median=statistics.median(precisions) if precisions else float("nan"),
                )
            rows.append(row)
    return rows


def write_results_csv(results: list[dict], path: Path) -> Path:
    """One row per scene and method: the figures behind the table, to find the seeds worth a look."""
    fields = ("mota", "id_switches", "recall", "precision", "mean_error_mm", "false_positives", "misses", "seconds")
    lines = ["category,seed,method," + ",".join(fields) + ",error"]
    for r in results:
        for method, m in r["methods"].items():
            values = ",".join("" if k not in m else f"{m[k]:.4g}" if isinstance(m[k], float) else str(m[k]) for k in fields)
            lines.append(f"{r['category']},{r['seed']},{method},{values},{m.get('error', '').replace(',', ';')}")
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines) + "\n")
    return path


def markdown_table(rows: list[dict]) -> str:
    from ..evaluate import figure

    lines = [
        "| category | method | seeds | MOTA median | MOTA worst (seed) | id switches median / max | 3D error median (mm) "
        "| recall median | precision median | goal met |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        failed = f" ({r['failed']} failed)" if r["failed"] else ""
        failed += f" ({r['no_ball']} with no ball seen by two cameras, not scored)" if r.get("no_ball") else ""
        if "mota_median" not in r:
            lines.append(f"| {r['category']} | {r['method']} | {r['seeds']}{failed} | | | | | | | no |")
            continue
        met = r["mota_median"] >= TARGET_MEDIAN and r["mota_worst"] >= TARGET_WORST and not r["failed"]
        lines.append(
            f"| {r['category']} | {r['method']} | {r['seeds']}{failed} | {r['mota_median']:.3f} | {r['mota_worst']:.3f} ({r['worst_seed']}) "
            f"| {r['id_switches_median']:g} / {r['id_switches_max']} | {figure(r['error_mm_median'], '.1f')} | {r['recall_median']:.3f} "
            f"| {figure(r['precision_median'], '.3f')} "
            f"| {'yes' if met else 'no'} |"
        )
    return "\n".join(lines)
