"""The tracks CSV (formats.md section 3): a sink that writes it, flushed every frame, and a reader."""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..capture.signals import output_kept
from ..config import TrackSettings
from ..files import AtomicOutput, read_columns
from ..results import FrameResult, TrackEstimate

_EPS_TIME = 1e-9
_FRAME_MARGIN = 0.1  # seconds: a frame or more at any camera rate, beyond the hold's bound
HEADER = ["frame", "time", "track_id", "x", "y", "z", "sx", "sy", "sz", "n_particles", "target"]


class TracksCsvSink:
    """Writes one row per confirmed track per frame, flushed every frame, into a temporary file beside
    ``path`` that replaces it when the run ends or is stopped with Ctrl-C; a run that fails leaves the
    previous file as it was (check the path first with ``files.check_output``).

    With ``hold`` seconds, each frame's rows wait that long before they are written, so that a track confirmed
    meanwhile is in the file from the frame it was first seen (its ``TrackEstimate.before`` frames, in frame
    order): a ball is not missing for the confirm_time it takes to trust it; and each row is written with its
    track's smoothed state at its frame (``TrackEstimate.smoothed``, smooth_time later). ``hold_for`` gives the
    hold that covers every track a config can confirm, and the smoothing."""

    def __init__(self, path: str | Path, hold: float = 0.0):
        self.path = Path(path)
        self.hold = hold
        self._out = AtomicOutput(self.path, "tracks file")
        self._file = self._out.open("w", newline="")
        self._file.write(",".join(HEADER) + "\n")
        self._held: deque[tuple[float, int, list[_Row]]] = deque()  # (time, index, rows) of the frames not written yet, oldest first
        self.rows = 0

    def write(self, result: FrameResult) -> None:
        f = result.frame
        rows = [_Row(f.index, f.time, tr.track_id, tr.position, tr.covariance, tr.n_particles, tr.target) for tr in result.confirmed]
        self._held.append((f.time, f.index, rows))
        for tr in result.confirmed:
            if tr.before:
                self._add_before(tr)
        for tr in result.tracks:
            if tr.smoothed:
                self._smooth(tr)
        while self._held and self._held[0][0] <= f.time - self.hold + _EPS_TIME:  # a frame's rows go once it is ``hold`` old
            self._flush_oldest()
        self._file.flush()

    def _add_before(self, tr: TrackEstimate) -> None:
        """A track confirmed this frame: each of its tentative hits joins the held frame of its time (always there,
        when the hold covers the config's confirm_time: hold_for)."""
        for held, (time, position, covariance, n_particles) in frames_of_hits(self._held, tr.before):
            held[2].append(_Row(held[1], time, tr.track_id, position, covariance, n_particles, tr.target))

    def _smooth(self, tr: TrackEstimate) -> None:
        """A track's smoothed state at a held frame takes the place of its row's; where it has none there (it coasted
        unreported: contested, out of view, or longer than report_coasting) and the track says to fill it (its ball met
        again since, placed sharply: tracks/smoothing.hindsight_fills), the smoothed state is its row."""
        for held, (time, position, covariance, fill) in frames_of_hits(self._held, tr.smoothed):
            row = next((row for row in held[2] if row.track_id == tr.track_id), None)  # (ids are unique across targets)
            if row is not None:
                row.position, row.covariance = position, covariance
            elif fill:
                held[2].append(_Row(held[1], time, tr.track_id, position, covariance, 0, tr.target))

    def _flush_oldest(self) -> None:
        rows = self._held.popleft()[2]
        if rows:
            self._file.writelines(row.line() for row in rows)
            self.rows += len(rows)

    def close(self) -> None:
        if self._file.closed:
            return
        if output_kept():  # Ctrl-C keeps what was tracked
            while self._held:
                self._flush_oldest()
            self._out.commit()
        else:
            self._out.abort()


def frames_of_hits(frames: Iterable[tuple], hits: Sequence[tuple]) -> Iterator[tuple[tuple, tuple]]:
    """Each of a track's revisions of earlier frames (its tentative hits, ``TrackEstimate.before``, or its smoothed
    states, ``TrackEstimate.smoothed``: tuples, time first) with the frame of its time among ``frames`` (tuples, time
    first), both in time order. Each hit takes a frame of its own, so two frames of one
    time (a bad recording's repeated timestamp) get a hit each, not both hits in one. A hit with no frame is left out
    (the tracks.csv sink and the viewer hold only their last frames)."""
    frames = iter(frames)
    frame = next(frames, None)
    for hit in hits:
        while frame is not None and frame[0] < hit[0]:
            frame = next(frames, None)
        if frame is None:
            return
        if frame[0] == hit[0]:
            yield frame, hit
            frame = next(frames, None)


def hold_for(settings: TrackSettings) -> float:
    """Seconds a frame's rows wait so every track confirmed later has its first hits written (TracksCsvSink): a track
    is confirmed at its first hit confirm_time after its birth, and its hits are at most tentative_time apart; and so
    every row has its smoothed state (smooth_time later)."""
    return max(settings.confirm_time + settings.tentative_time, settings.smooth_time) + _FRAME_MARGIN


@dataclass(slots=True)
class _Row:
    """A held row of tracks.csv; its position and covariance may still be revised (smoothed) before it is written."""

    index: int
    time: float
    track_id: int
    position: np.ndarray
    covariance: np.ndarray
    n_particles: int
    target: str

    def line(self) -> str:
        sd = np.sqrt(np.clip(np.diag(self.covariance), 0, None))
        x, y, z = self.position
        return (
            f"{self.index},{self.time:.6f},{self.track_id},{x:.5f},{y:.5f},{z:.5f},"
            f"{sd[0]:.5f},{sd[1]:.5f},{sd[2]:.5f},{self.n_particles},{self.target}\n"
        )


def read_tracks(path: str | Path) -> np.ndarray:
    """tracks.csv -> (M x 6) float array: frame, time, track_id, x, y, z (extra columns ignored)."""
    return read_columns(path, HEADER[:6], "tracks file", whole=("frame", "track_id"), nonnegative=("frame",))
