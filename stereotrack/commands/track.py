"""Track the balls of a recording and write tracks.csv (and optionally a rerun .rrd).

Targets come from --config, else from the recording's own target file
(`targets:` in its meta.yaml; every synthetic scene has one). With a
truth.csv in the recording, the summary also scores the run.

examples:
  stereotrack track recordings/demo
  stereotrack track recordings/mine --config pink.yaml --out mine.csv --rrd mine.rrd
  stereotrack track recordings/mine --method baseline
"""

from __future__ import annotations

import argparse
from pathlib import Path

HELP = "track a recording: write tracks.csv (and a rerun .rrd)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    from ..argtypes import number

    p.add_argument("recording", help="recording folder (meta.yaml, frames.csv, one video per camera)")
    p.add_argument("--config", help="target/tracker config YAML (default: the recording's own targets file)")
    p.add_argument("--calib", help="calibration YAML (default: the recording's calib.yaml)")
    p.add_argument("--out", help="tracks CSV to write (default: RECORDING/tracks.csv)")
    p.add_argument(
        "--method",
        choices=["particles", "baseline"],
        default="particles",
        help="the particle tracker (default) or the classic OpenCV pipeline",
    )
    p.add_argument("--start", type=number(0, integer=True), default=0, help="first frame (default 0)")
    p.add_argument("--frames", type=number(1, integer=True), help="track at most this many frames")
    p.add_argument(
        "--realtime",
        action="store_true",
        help="play the recording at its recorded pace, as a live camera would (late frames are skipped and counted)",
    )
    p.add_argument(
        "--all-frames",
        action="store_true",
        help="a `live --record` recording: track every recorded frame, not only those the live run tracked",
    )
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    from ..sinks.network import add_network_arguments
    from ..sinks.viewer.flags import add_viz_arguments  # viz imports rerun only when a viewer flag is used

    add_viz_arguments(p)
    add_network_arguments(p)


START_SPAN = 10.0  # seconds: the backgrounds' starting frames are spread over the first this much of the frames tracked


def start_frames(timestamps, wanted, count: int):
    """Up to ``count`` of the ``wanted`` frames (indices), evenly spread over their first START_SPAN seconds
    (``timestamps``: seconds, a row per frame, a column per camera)."""
    import numpy as np

    wanted = np.asarray(wanted, int)
    if not len(wanted) or count <= 0:
        return wanted[:0]
    times = np.asarray(timestamps, float)[wanted].mean(axis=1)
    first = wanted[times - times[0] <= START_SPAN]
    return np.unique(first[np.linspace(0, len(first) - 1, min(count, len(first))).round().astype(int)])


def resolve_config(recording, config_path: str | None):
    from ..config import load_config
    from ..errors import StereotrackError

    if config_path:
        return with_recording_up(load_config(config_path), recording)
    path = recording.targets_path
    if path is None:
        raise StereotrackError(f"{recording.folder}: no targets file in the recording; pass --config FILE (see 'stereotrack colour learn')")
    return with_recording_up(load_config(path), recording)


def with_recording_up(config, recording):
    """Gravity for the tracks' motion model from the recording's optional 'up' axis, unless the config sets one."""
    from dataclasses import replace

    from ..config import up_axis

    up = recording.meta.get("up")
    if config.tracks.up is not None or up is None:
        return config
    return replace(config, tracks=replace(config.tracks, up=up_axis(up, f"{recording.folder / 'meta.yaml'}: 'up'")))


def track_recording(args, default_out: Path | None = None) -> int:
    """Shared by `track` and `demo`. A signal stops it cleanly: outputs complete up to the last frame tracked."""
    from ..capture.signals import Interrupted, StopOnSignals

    with StopOnSignals() as stopper:
        status = _track(args, default_out, stopper)
    if stopper.signal_name:
        raise Interrupted(stopper.signal_name)  # the outputs are closed; the command line says "interrupted"
    return status


def _track(args, default_out: Path | None, stopper) -> int:
    import itertools

    import numpy as np

    from ..capture.replay import RecordingSource
    from ..console import info, warn
    from ..errors import StereotrackError
    from ..files import check_output
    from ..pipeline.assemble import make_tracker, open_sinks
    from ..pipeline.run import close_all, run_pipeline
    from ..recording import open_recording, read_truth_and_views
    from ..sinks.network import check_network_flags
    from ..sinks.tracks_csv import read_tracks

    check_network_flags(args)
    rec = open_recording(args.recording, calib=args.calib)
    rig = rec.require_rig()
    config = resolve_config(rec, args.config)
    if rec.n_frames == 0:
        raise StereotrackError(f"{rec.folder}: the recording holds no complete frame pair")
    if args.start >= rec.n_frames:
        raise StereotrackError(f"--start {args.start} is outside the recording's {rec.n_frames} frames")
    stop = rec.n_frames if args.frames is None else min(rec.n_frames, args.start + args.frames)
    wanted = np.arange(args.start, stop)
    if rec.tracked_frames is not None and not getattr(args, "all_frames", False):
        # a live run's recording: replay exactly the frames the live tracker had time for
        wanted = np.unique(rec.tracked_frames[(rec.tracked_frames >= args.start) & (rec.tracked_frames < stop)])
        info(f"replaying the {len(wanted)} frames the live run tracked, of {stop - args.start} recorded (--all-frames tracks every frame)")
    # Every output is checked before anything is written; none may be one of the run's inputs.
    inputs = [*rec.own_files, rec.targets_path, args.config, args.calib]
    out = check_output(args.out if args.out is not None else (default_out or rec.folder / "tracks.csv"), "--out", "tracks CSV", inputs)
    truth = views = None
    if rec.truth_path:
        try:
            truth, views = read_truth_and_views(rec.truth_path)
        except StereotrackError as exc:  # scoring is a bonus; never refuse the run for it
            warn(f"not scoring against truth.csv: {exc}")
    sinks = open_sinks(args, rig, config, tracks_csv=out, truth=truth, protect=inputs)  # a missing viewer or a taken port: refused here
    try:
        tracker = make_tracker(args.method, rig, config, keep_rays=getattr(args, "viz_rays", False))
        count = getattr(tracker, "background_start", 0)  # the baseline has no background
        if count:  # the backgrounds start from frames spread over the recording, not from its first frame's balls
            starts = rec.frames(only=start_frames(rec.timestamps, wanted, count))
            try:  # a Ctrl-C meanwhile stops the decoding, and the run stops at its first frame
                tracker.start_backgrounds(itertools.takewhile(lambda _: not stopper.requested, starts))
            finally:
                starts.close()  # the decoders release the videos
    except BaseException:
        close_all(sinks)
        raise
    viz_sink = next((s for s in sinks if hasattr(s, "rrd_path")), None)
    only = None if len(wanted) == stop - args.start else wanted
    source = RecordingSource(rec, realtime=args.realtime, start=args.start, stop=stop, only=only)
    objects_seen = {t.name: 0 for t in config.targets}
    tracked: list[int] = []

    class _Counter:
        def write(self, result):
            tracked.append(result.frame.index)
            for o in result.objects:
                objects_seen[o.target] += 1

        def close(self):
            pass

    def until_stopped(pairs):
        for pair in pairs:
            if stopper.requested:
                break
            yield pair

    try:
        summary = run_pipeline(
            until_stopped(source), tracker, [*sinks, _Counter()], progress=not args.quiet, total=len(wanted), ahead=not args.realtime
        )
    finally:
        source.close()  # the readers stop before anything else
    skipped = source.stats.pairs_dropped
    for name, count in objects_seen.items():
        if count == 0 and not stopper.requested:
            warn(
                f"target {name!r} matched nothing in the whole recording: check its HSV range ('stereotrack colour learn') and the lighting"
            )
    not_tracked = []
    if skipped:
        not_tracked.append(f"{skipped} skipped because the tracker ran late (--realtime)")
    if stopper.requested:
        not_tracked.append(f"stopped by {stopper.signal_name}")
    untracked = f" ({'; '.join(not_tracked)})" if not_tracked else ""
    of = f" of {len(wanted)}" if summary.frames != len(wanted) else ""  # the summary says so when frames were left out
    info(
        f"tracked {summary.frames}{of} frames in {summary.seconds:.1f} s ({summary.fps:.1f} frames/s including decoding; "
        f"tracker step median {summary.median_step_ms:.1f} ms){untracked}: {summary.tracks_seen} tracks, up to {summary.max_objects} at once"
    )
    info(f"tracks written to {out}")
    if truth is not None and tracked:
        from ..evaluate import NO_BALL, evaluate, figure

        try:
            tracks = read_tracks(out)
            scored = np.isin(truth[:, 0], tracked)
            ev = evaluate(tracks, truth[scored], frames=tracked, views=None if views is None else views[scored])
            scope = f" (scored over the {len(tracked)} frames tracked)" if len(tracked) < stop - args.start else ""
            # the ball-frames truth marks as seen clearly by fewer than two cameras: said, as eval's table says them
            optional = f"; {ev.optional_objects} ball-frames fewer than two cameras see clearly not scored" if ev.optional_objects else ""
            info(
                f"against the recording's truth.csv{scope}: MOTA {figure(ev.mota, '.3f', NO_BALL)}, MOTP {figure(ev.motp_mm, '.1f', unit=' mm')}, "
                f"id switches {ev.id_switches}, recall {figure(ev.recall, '.3f')}, precision {figure(ev.precision, '.3f')}, "
                f"mean 3D error {figure(ev.mean_error_mm, '.1f', unit=' mm')}{optional}"
            )
        except StereotrackError as exc:  # scoring is a bonus; never fail the run for it
            warn(f"could not score against truth.csv: {exc}")
    if viz_sink is not None and getattr(viz_sink, "rrd_path", None):
        import os
        import sys

        viewer = Path(sys.executable).parent / "rerun"
        viewer_cmd = os.path.relpath(viewer) if viewer.exists() else "rerun"
        info(f"rerun recording written to {viz_sink.rrd_path}; open it with: {viewer_cmd} {viz_sink.rrd_path}")
    return 0


def run(args) -> int:
    return track_recording(args)
