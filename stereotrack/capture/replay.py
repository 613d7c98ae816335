"""Replaying a recording as a source: as fast as possible, or paced at its recorded times."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from pathlib import Path

import numpy as np

from ..console import warn
from ..frames import CameraStats, FramePair, SourceStats
from ..recording import Recording, open_recording

MAX_WAIT = 2.0  # seconds: the longest pause between two frames a paced replay waits out


def paced(
    pairs: Iterable[FramePair],
    timestamps: np.ndarray,
    skip_late: bool = True,
    clock: Callable[[], float] = time.monotonic,
    sleep: Callable[[float], None] = time.sleep,
    on_skip: Callable[[FramePair], None] | None = None,
) -> Iterator[FramePair]:
    """Yield pairs at their recorded pace; row i of ``timestamps`` holds the i-th pair's capture times.

    With ``skip_late`` a pair more than one frame period behind schedule is
    skipped (``on_skip`` is told), as a live camera would drop it, so a slow
    consumer sees the recording's present, not a growing backlog.
    """
    times = np.asarray(timestamps, dtype=float).reshape(len(timestamps), -1).mean(axis=1)
    period = float(np.median(np.diff(times))) if len(times) > 1 else 0.0
    start_wall = start_rec = None
    for pair, t in zip(pairs, times):  # row i of timestamps belongs to the i-th pair, whatever its index
        if start_wall is None:
            start_wall, start_rec = clock(), t
        due = start_wall + (t - start_rec)
        now = clock()
        if due - now > MAX_WAIT:  # a pause in the recording (or a wrong timestamp) is replayed as MAX_WAIT, not waited out
            warn(f"the recording pauses for {due - now:.0f} s before frame {pair.index}; replaying the pause as {MAX_WAIT:g} s")
            start_wall -= due - now - MAX_WAIT
            due = now + MAX_WAIT
        if due > now:
            sleep(due - now)
        elif skip_late and now - due > period > 0:
            if on_skip:
                on_skip(pair)
            continue
        yield pair


class RecordingSource:
    """A recording folder as a source: as fast as possible, or at its recorded pace (``realtime``).

    ``only``: just these frames (in order), e.g. those a ``live`` run tracked (``Recording.tracked_frames``).
    ``stats.pairs_dropped`` counts the frames ``realtime`` skipped because the consumer was late.
    """

    def __init__(
        self,
        recording: Recording | str | Path,
        realtime: bool = False,
        calib: str | Path | None = None,
        start: int = 0,
        stop: int | None = None,
        skip_late: bool = True,
        only: Sequence[int] | None = None,
    ):
        self.recording = recording if isinstance(recording, Recording) else open_recording(recording, calib)
        self.realtime = realtime
        self.rig = self.recording.rig
        self.fps = self.recording.fps
        self.camera_names = self.recording.camera_names
        self._start, self._stop = start, stop
        span = range(self.recording.n_frames)[start:stop]
        self._only = None if only is None else np.asarray([i for i in only if i in span], dtype=int)
        self.n_frames = len(span) if self._only is None else len(self._only)
        self.skip_late = skip_late
        self._delivered = 0
        self._skipped = 0
        self._frames: Iterator[FramePair] | None = None

    def __iter__(self) -> Iterator[FramePair]:
        frames = self.recording.frames(self._start, self._stop, only=self._only)
        self._frames = frames
        if self.realtime:
            rows = self.recording.timestamps[self._start : self._stop] if self._only is None else self.recording.timestamps[self._only]
            frames = paced(frames, rows, self.skip_late, on_skip=self._count_skip)
        for pair in frames:
            self._delivered += 1
            yield pair

    def _count_skip(self, pair: FramePair) -> None:
        self._skipped += 1

    @property
    def stats(self) -> SourceStats:
        cams = tuple(
            CameraStats(n, str(self.recording.folder), self._delivered + self._skipped, self.fps, self._skipped, 0)
            for n in self.camera_names
        )
        return SourceStats(cams, self._delivered, self._skipped)

    def close(self) -> None:
        if self._frames is not None and hasattr(self._frames, "close"):
            self._frames.close()  # releases the video readers
