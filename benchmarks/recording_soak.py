"""Recording and replay soaks (issue 15): the long versions of tests/capture/test_stops.py.

    .venv/bin/python benchmarks/recording_soak.py codecs          # encode/decode cost and size per frame (~2 min)
    .venv/bin/python benchmarks/recording_soak.py record          # 60 s of two 1280x720 60 fps cameras, then replay (~4 min)
    .venv/bin/python benchmarks/recording_soak.py live-record     # the same with `live` tracking at the same time (~3 min)
    .venv/bin/python benchmarks/recording_soak.py kills           # 20 SIGKILLs, 20 Ctrl-C/SIGTERM stops, 20 uneven ends (~4 min)
    .venv/bin/python benchmarks/recording_soak.py memory          # `live` on simulated cameras for 10 min: RSS (~11 min)

Every random choice comes from a seeded generator. The simulated 720p60
cameras pre-render 10 s of `pendulum4` and loop them (``loop=10``), so they
cost no CPU, like webcams, and lose no frames (``drop=0``), so every missing
pair is the recording's; asked for MJPG (the default) they send JPEGs, as
webcams do.
Prints one line per figure (BENCHMARKS.md "Recording" quotes them).
"""

from __future__ import annotations

import argparse
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests" / "capture"))


def stereotrack(*args) -> list[str]:
    return [sys.executable, "-m", "stereotrack", *args]


def folder_mb(folder: Path) -> float:
    return sum(p.stat().st_size for p in folder.iterdir()) / 1e6


# --------------------------------------------------------------------------- codecs


def codecs(n: int = 40) -> None:
    """Per frame: encode ms, kB, decode ms, PSNR for the candidate codecs, on rendered noisy frames and real footage."""
    import os
    from fractions import Fraction

    import av
    import cv2

    from stereotrack.recording import decode_jpeg, encode_jpeg
    from stereotrack.simulation.presets import make_preset
    from stereotrack.simulation.render import SceneRenderer

    cv2.setNumThreads(1)  # the recorder shares the machine with the tracker
    tmp = Path(tempfile.mkdtemp(prefix="codecs-"))

    def rendered(w, h):
        r = SceneRenderer(make_preset("pendulum4", width=w, height=h, fps=60.0))
        return [r.render(i)[0][0] for i in range(n)]

    def real(path):
        cap, out = cv2.VideoCapture(str(path)), []
        while len(out) < n:
            ok, img = cap.read()
            if not ok:
                break
            out.append(img)
        return out

    def psnr(a, b):
        d = np.mean((a.astype(np.float32) - b.astype(np.float32)) ** 2)
        return float("inf") if d == 0 else 10 * np.log10(255**2 / d)

    def timed(fn, items):
        t = time.perf_counter()
        out = [fn(x) for x in items]
        return out, 1e3 * (time.perf_counter() - t) / len(items)

    def cv_writer(frames, fourcc, ext):
        p = tmp / f"cv{ext}"
        h, w = frames[0].shape[:2]
        wr = cv2.VideoWriter(str(p), cv2.CAP_FFMPEG, cv2.VideoWriter_fourcc(*fourcc), 60.0, (w, h))
        _, enc = timed(wr.write, frames)
        wr.release()
        cap, dec = cv2.VideoCapture(str(p)), []
        t = time.perf_counter()
        while True:
            ok, img = cap.read()
            if not ok:
                break
            dec.append(img)
        return p, enc, 1e3 * (time.perf_counter() - t) / len(frames), dec

    def av_writer(frames, codec, opts, pix):
        p = tmp / f"av_{codec}.mkv"
        h, w = frames[0].shape[:2]
        c = av.open(str(p), "w")
        s = c.add_stream(codec, rate=60, options=opts)
        s.width, s.height, s.pix_fmt = w, h, pix
        s.codec_context.thread_count = 1

        def enc(f):
            for pkt in s.encode(av.VideoFrame.from_ndarray(f, format="bgr24")):
                c.mux(pkt)

        _, e = timed(enc, frames)
        for pkt in s.encode():
            c.mux(pkt)
        c.close()
        c = av.open(str(p))
        t = time.perf_counter()
        dec = [f.to_ndarray(format="bgr24") for f in c.decode(c.streams.video[0])]
        c.close()
        return p, e, 1e3 * (time.perf_counter() - t) / len(frames), dec

    def jpeg_mux(frames, q):
        p = tmp / f"jpeg{q}.avi"
        h, w = frames[0].shape[:2]
        packets, e = timed(lambda f: encode_jpeg(f, q), frames)
        c = av.open(str(p), "w", format="avi", options={"flush_packets": "1"})
        s = c.add_stream("mjpeg", rate=60)
        s.width, s.height, s.pix_fmt = w, h, "yuvj420p"
        tb = Fraction(1, 60)

        def mux(item):
            i, data = item
            pkt = av.Packet(data)
            pkt.stream, pkt.pts, pkt.dts, pkt.time_base, pkt.is_keyframe = s, i, i, tb, True
            c.mux(pkt)

        _, m = timed(mux, list(enumerate(packets)))
        c.close()
        dec, d = timed(decode_jpeg, packets)
        return p, e, m, d, dec

    # the project's real footage (shared/data/real, beside the repository or above a worktree)
    videos = next((d for d in (ROOT.parent / "shared", ROOT.parents[1] / "shared") if d.is_dir()), ROOT) / "data/real/ball-videos"
    sets = [
        ("rendered 640x480", rendered(640, 480)),
        ("rendered 1280x720", rendered(1280, 720)),
        ("real ball2.mp4 640x480", real(videos / "ball2.mp4")),
        ("real ball4.mp4 1280x720", real(videos / "ball4.mp4")),
    ]
    print("| frames | codec | encode ms | kB/frame | decode ms | PSNR dB |")
    print("|---|---|---|---|---|---|")
    for name, frames in sets:
        if not frames:
            continue

        def row(label, p, e, d, dec, mux=None, name=name, frames=frames):
            kb = os.path.getsize(p) / len(frames) / 1e3
            q = np.mean([psnr(a, b) for a, b in zip(frames, dec)])
            enc = f"{e:.1f}" + (f" + mux {mux:.2f}" if mux is not None else "")
            print(f"| {name} | {label} | {enc} | {kb:.0f} | {d:.1f} | {'lossless' if q == float('inf') else f'{q:.1f}'} |", flush=True)

        row("FFV1 (OpenCV writer, old default)", *cv_writer(frames, "FFV1", ".mkv"))
        row("MJPG (OpenCV writer, old option)", *cv_writer(frames, "MJPG", ".avi"))
        row("FFV1 (PyAV, `--codec ffv1`)", *av_writer(frames, "ffv1", {"g": "1"}, "bgr0"))
        row(
            "H.264 x264 ultrafast crf 18 (PyAV)",
            *av_writer(frames, "libx264", {"preset": "ultrafast", "crf": "18", "tune": "zerolatency"}, "yuv420p"),
        )
        for q in (90, 95):
            p, e, m, d, dec = jpeg_mux(frames, q)
            row(f"JPEG q{q} (libjpeg) muxed by PyAV{' (new default)' if q == 95 else ''}", p, e, d, dec, mux=m)
        p, e, m, d, dec = jpeg_mux(frames, 95)
        row("a camera's JPEG stored as it is (mux only)", p, 0.0, d, dec, mux=m)
    shutil.rmtree(tmp)


# --------------------------------------------------------------------------- record / live-record / replay

CAMS_720P60 = [
    "--cam0",
    "sim:pendulum4,loop=10,drop=0",
    "--cam1",
    "sim:pendulum4,loop=10,drop=0",
    "--width",
    "1280",
    "--height",
    "720",
    "--fps",
    "60",
]


def record(seconds: float = 60.0, live: bool = False) -> None:
    out = Path(tempfile.mkdtemp(prefix="soak-")) / "rec"
    if live:
        cmd = stereotrack("live", *CAMS_720P60, "--seconds", str(seconds), "--quiet", "--record", str(out))
    else:
        cmd = stereotrack("record", *CAMS_720P60, "--seconds", str(seconds), "--out", str(out))
    res = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=seconds + 300)
    if res.returncode != 0:
        sys.exit(res.stderr)
    from stereotrack.recording import open_recording

    rec = open_recording(out)
    expected = round(seconds * 60)
    lost = max(0, expected - rec.n_frames)
    what = "live --record (tracking at the same time)" if live else "record"
    summary = [line for line in res.stderr.splitlines() if line.startswith(("tracked", "done", "stopped"))]
    print(
        f"{what}, two 1280x720 cameras at 60 fps for {seconds:g} s: {rec.n_frames} of {expected} pairs recorded "
        f"({100 * lost / expected:.2f} % dropped), {folder_mb(out) / (seconds / 60):.0f} MB per minute on disk"
    )
    for line in summary:
        print(f"  {line}")
    if not live:
        start = time.perf_counter()
        n = sum(1 for _ in rec.frames())
        print(f"reading it back (both cameras decoded, no tracking): {n / (time.perf_counter() - start):.0f} pairs/s")
        res = subprocess.run(
            stereotrack("track", str(out), "--quiet", "--all-frames", "--out", str(out.parent / "t.csv")),
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=1200,
        )
        m = re.search(
            r"tracked (\d+)(?: of \d+)? frames in ([\d.]+) s \(([\d.]+) frames/s including decoding; tracker step median ([\d.]+) ms",
            res.stderr,
        )
        print(
            f"replay (`track`, every frame): {m.group(3)} frames/s including decoding over {m.group(1)} frames, tracker step median {m.group(4)} ms"
            if m
            else res.stderr
        )
        replay_cpu(out)
    shutil.rmtree(out.parent)


def replay_cpu(folder: Path) -> None:
    """Replay in this process as `track --all-frames` does, and split its CPU time per frame: the tracker's thread
    (the step and the sinks) and the others (decoding, the next pair's colour masks). On a machine nobody else uses, the run cannot be faster than
    either the tracker's thread or the whole CPU time shared by the cores: a bound that load does not move much,
    where the frames/s above follow the load."""
    import os

    from stereotrack.capture.replay import RecordingSource
    from stereotrack.commands.track import resolve_config
    from stereotrack.pipeline.run import run_pipeline
    from stereotrack.pipeline.tracker import Tracker
    from stereotrack.recording import open_recording
    from stereotrack.sinks.tracks_csv import TracksCsvSink

    rec = open_recording(folder)
    tracker = Tracker(rec.rig, resolve_config(rec, None))
    source = RecordingSource(rec)
    cpu, main, wall = time.process_time(), time.thread_time(), time.perf_counter()
    summary = run_pipeline(source, tracker, [TracksCsvSink(folder.parent / "cpu.csv")], progress=False, ahead=True)  # as `track` does
    cpu, main, wall = time.process_time() - cpu, time.thread_time() - main, time.perf_counter() - wall
    source.close()
    n, cores = summary.frames, os.cpu_count() or 1
    per = lambda x: 1e3 * x / n  # noqa: E731
    bound = 1e3 / max(per(main), per(cpu) / cores)
    print(
        f"replay CPU per frame: tracker thread {per(main):.1f} ms, other threads (decoding; the next pair's colour masks) {per(cpu - main):.1f} ms "
        f"({n / wall:.1f} frames/s here, load average {os.getloadavg()[0]:.1f}): at most {bound:.0f} frames/s on {cores} idle cores"
    )


# --------------------------------------------------------------------------- kills and stops


# On a machine loaded several times over, a file camera can get no CPU for 2 s (the default stall
# timeout) and the recording would end as if it were unplugged: give it longer.
PATIENT = ["--stall-timeout", "10"]


def kills(n: int = 20, sigkill: bool = True) -> None:
    from test_stops import decodable, frames_csv_rows, wait_for_rows, write_video

    from stereotrack.recording import open_recording

    tmp = Path(tempfile.mkdtemp(prefix="kills-"))
    rng = np.random.default_rng(15)
    worst = 0
    for k, delay in enumerate(rng.uniform(0.0, 3.0, n) if sigkill else []):
        out = tmp / f"k{k}"
        proc = subprocess.Popen(
            stereotrack("record", "--cam0", "sim:dots", "--cam1", "sim:dots", "--out", str(out)),
            cwd=ROOT,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )
        wait_for_rows(proc, out, 1, timeout=120)
        time.sleep(delay)
        proc.kill()
        proc.communicate()
        rows = frames_csv_rows(out)
        rec = open_recording(out)
        counts = [decodable(p) for p in rec.video_paths]
        worst = max(worst, rows - min(counts))
        assert rows <= min(counts) <= rows + 1 and len(list(rec.frames())) == rows, (k, rows, counts)
    print(
        f"{n if sigkill else 0} SIGKILLs at random moments (0-3 s into recording): every folder opens; rows - decodable frames at most {worst} "
        f"(every row has its frames)"
    )
    clips = tmp / "clips"
    clips.mkdir()
    for name, frames in (("a", 150), ("b", 150), ("short", 60)):
        write_video(clips / f"{name}.mkv", frames)
    aborts = bad = 0
    for k, delay in enumerate(rng.uniform(0.0, 3.0, n)):
        out = tmp / f"s{k}"
        sig = (signal.SIGINT, signal.SIGTERM)[k % 2]
        proc = subprocess.Popen(
            stereotrack("record", "--cam0", str(clips / "a.mkv"), "--cam1", str(clips / "b.mkv"), *PATIENT, "--out", str(out)),
            cwd=ROOT,
            stderr=subprocess.PIPE,
            text=True,
            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
        )
        wait_for_rows(proc, out, 1, timeout=120)
        time.sleep(delay)
        proc.send_signal(sig)
        _, err = proc.communicate()
        aborts += proc.returncode != 0 or "Assertion" in err
        rows = frames_csv_rows(out)
        bad += any(decodable(p) != rows for p in open_recording(out).video_paths)
    print(f"video-file cameras, {n} Ctrl-C/SIGTERM stops at random moments: {aborts} aborts, {bad} folders where rows != decodable frames")
    aborts = bad = 0
    for k in range(n):
        out = tmp / f"u{k}"
        cams = [str(clips / "a.mkv"), str(clips / "short.mkv")][:: 1 if k % 2 else -1]
        res = subprocess.run(
            stereotrack("record", "--cam0", cams[0], "--cam1", cams[1], "--out", str(out)), cwd=ROOT, capture_output=True, text=True
        )
        aborts += res.returncode != 0 or "Assertion" in res.stderr
        rows = frames_csv_rows(out)
        bad += any(decodable(p) != rows for p in open_recording(out).video_paths)
    print(f"video-file cameras, {n} runs with files of uneven length: {aborts} aborts, {bad} folders where rows != decodable frames")
    shutil.rmtree(tmp)


# --------------------------------------------------------------------------- memory


def rss_mb(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return float("nan")


def memory(seconds: float = 600.0) -> None:
    """`live` on simulated cameras (rendered as they go: the scene loops every 10 s) for ten minutes."""
    proc = subprocess.Popen(
        stereotrack("live", "--cam0", "sim:pendulum4", "--cam1", "sim:pendulum4", "--seconds", str(seconds), "--quiet"),
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    samples = []
    start = time.monotonic()
    while proc.poll() is None:
        time.sleep(5.0)
        try:
            samples.append((time.monotonic() - start, rss_mb(proc.pid)))
        except FileNotFoundError:
            break
    err = proc.stderr.read()
    samples = [s for s in samples if s[1] == s[1]]
    at = lambda t: next(r for s, r in samples if s >= t)  # noqa: E731
    print(
        f"live on two simulated 640x480 cameras for {seconds / 60:g} min: RSS {at(30):.0f} MB at 30 s, {at(seconds / 2):.0f} MB at "
        f"{seconds / 120:g} min, {samples[-1][1]:.0f} MB at the end (max {max(r for _, r in samples):.0f} MB)"
    )
    print("  " + next((line for line in err.splitlines() if line.startswith("tracked")), err[-300:]))


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("what", choices=["codecs", "record", "live-record", "kills", "stops", "memory"])
    ap.add_argument("--seconds", type=float, default=None)
    a = ap.parse_args()
    if a.what == "codecs":
        codecs()
    elif a.what in ("record", "live-record"):
        record(a.seconds or 60.0, live=a.what == "live-record")
    elif a.what in ("kills", "stops"):
        kills(sigkill=a.what == "kills")
    else:
        memory(a.seconds or 600.0)
