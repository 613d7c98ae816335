"""Running a source through a tracker into sinks, with a summary of the run."""

from __future__ import annotations

import time
from collections.abc import Iterable, Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from ..console import Progress
from ..frames import FramePair
from ..results import Sink


@dataclass(frozen=True)
class RunSummary:
    frames: int
    seconds: float
    median_step_ms: float
    tracks_seen: int
    max_objects: int

    @property
    def fps(self) -> float:
        return self.frames / self.seconds if self.seconds > 0 else 0.0


def run_pipeline(
    source: Iterable[FramePair], tracker, sinks: Sequence[Sink], progress: bool = True, total: int | None = None, ahead: bool = False
) -> RunSummary:
    """Feed every frame of ``source`` through ``tracker`` into ``sinks``; sinks are closed even on Ctrl-C.

    ``ahead``: while the tracker steps on one pair, another thread makes the next pair's colour masks
    (``Tracker.colours``; same tracks, less time on the tracker's thread). Only for a source whose next pair is
    at hand at once (a recording read as fast as it decodes): the pair after the one being tracked is taken
    from the source first."""
    bar = Progress(total, "tracking", "frames", enabled=progress)
    start = time.perf_counter()
    frames = 0
    step_ms = []
    ids: set[int] = set()
    max_objects = 0
    pairs = _colours_ahead(source, tracker) if ahead and hasattr(tracker, "colours") else ((pair, None) for pair in source)
    try:
        for pair, colours in pairs:
            result = tracker.step(pair) if colours is None else tracker.step(pair, colours)
            for sink in sinks:
                sink.write(result)
            frames += 1
            step_ms.append(result.timings_ms.get("step", 0.0))
            confirmed = result.confirmed
            ids.update(t.track_id for t in confirmed)
            max_objects = max(max_objects, len(confirmed))
            bar.update(1, extra=f"{len(confirmed)} tracks")
    finally:
        pairs.close()  # the thread making colours ahead ends before the sinks close
        bar.close()
        close_all(sinks)
    return RunSummary(frames, time.perf_counter() - start, float(np.median(step_ms)) if step_ms else 0.0, len(ids), max_objects)


def _colours_ahead(source: Iterable[FramePair], tracker) -> Iterator[tuple[FramePair, list]]:
    """Each pair with its colour masks, made in a thread of their own while the pair before it was tracked."""
    with ThreadPoolExecutor(1, thread_name_prefix="colours") as helper:
        pending = None
        for pair in source:
            job = helper.submit(tracker.colours, pair.images)
            if pending is not None:
                yield pending[0], pending[1].result()
            pending = (pair, job)
        if pending is not None:
            yield pending[0], pending[1].result()


def close_all(sinks: Sequence[Sink]) -> None:
    """Close every sink, even when one of them fails (its error is raised after the others are closed)."""
    error: BaseException | None = None
    for sink in sinks:
        try:
            sink.close()
        except BaseException as exc:  # noqa: B036 - re-raised below once every sink had its chance to finish its file
            error = error or exc
    if error is not None:
        raise error
