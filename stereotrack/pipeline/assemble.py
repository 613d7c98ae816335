"""A run's parts, put together the same way for `track`, `live` and `demo`: the tracker, and the sinks the flags ask for."""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..camera import Rig
from ..config import Config
from ..console import notice_if_slow
from ..results import Sink


def make_tracker(method: str, rig: Rig, config: Config, keep_rays: bool = False):
    """The particle tracker (``particles``) or the classic OpenCV pipeline (``baseline``)."""
    if method == "baseline":
        from .baseline import BaselineTracker

        return BaselineTracker(rig, config)
    from .tracker import Tracker

    with notice_if_slow("compiling the tracker's kernels (first run on this machine only: up to a minute) ..."):
        return Tracker(rig, config, keep_rays=keep_rays)


def open_sinks(
    args: argparse.Namespace,
    rig: Rig,
    config: Config,
    tracks_csv: Path | None = None,
    truth: np.ndarray | None = None,
    live: bool = False,
    extra: Sequence[Sink] = (),
    protect: Sequence[Path | str | None] = (),
    hold: bool = True,
) -> list[Sink]:
    """Every sink of a run, in the order each frame goes to them: the network sink (--udp/--osc: first, it is
    the low-latency feed), the tracks CSV (when given), the rerun viewer (when a viewer flag is given), then
    ``extra`` (e.g. ``live --record``'s recorder). ``live``: the viewer skips a frame rather than hold live
    cameras back. ``protect``: the run's inputs, which --rrd may not name; ``hold``: a served viewer keeps
    serving after the run until Ctrl-C.

    The network addresses are checked, then the viewer opens: a bad address, a viewer that is not there or a
    port another program holds is refused before the tracks file exists (it is written under a temporary
    name, see sinks/tracks_csv.py)."""
    from ..sinks.network import make_network_sink
    from ..sinks.tracks_csv import TracksCsvSink, hold_for
    from ..sinks.viewer.flags import make_viz_sink

    network = make_network_sink(args, config)
    opened: list[Sink] = [network] if network is not None else []
    viewer = None
    try:
        viewer = make_viz_sink(
            args, rig, config, truth=truth, recording_name="live" if live else None, live=live, protect=[*protect, tracks_csv], hold=hold
        )
        if tracks_csv is not None:
            opened.append(TracksCsvSink(tracks_csv, hold_for(config.tracks)))
    except BaseException:
        for sink in [*opened, viewer]:
            if sink is not None:
                sink.close()
        raise
    if viewer is not None:
        opened.append(viewer)
    return opened + list(extra)
