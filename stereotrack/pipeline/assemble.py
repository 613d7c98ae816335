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
) -> list[Sink]:
    """Every sink of a run, in the order each frame goes to them: the tracks CSV (when given), the rerun viewer
    (when a viewer flag is given), then ``extra`` (e.g. ``live --record``'s recorder). ``live``: the viewer skips
    a frame rather than hold live cameras back."""
    from ..sinks.tracks_csv import TracksCsvSink
    from ..sinks.viewer.flags import make_viz_sink

    sinks: list[Sink] = []
    if tracks_csv is not None:
        sinks.append(TracksCsvSink(tracks_csv))
    viewer = make_viz_sink(args, rig, config, truth=truth, recording_name="live" if live else None, live=live)
    if viewer is not None:
        sinks.append(viewer)
    return sinks + list(extra)
