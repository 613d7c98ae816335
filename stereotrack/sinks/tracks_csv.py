"""The tracks CSV (formats.md section 3): a sink that writes it, flushed every frame, and a reader."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from ..files import AtomicOutput, read_columns
from ..results import FrameResult

HEADER = ["frame", "time", "track_id", "x", "y", "z", "sx", "sy", "sz", "n_particles", "target"]


class TracksCsvSink:
    """Writes one row per confirmed track per frame, flushed every frame, into a temporary file beside
    ``path`` that replaces it when the run ends or is stopped with Ctrl-C; a run that fails leaves the
    previous file as it was (check the path first with ``files.check_output``)."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self._out = AtomicOutput(self.path, "tracks file")
        self._file = self._out.open("w", newline="")
        self._file.write(",".join(HEADER) + "\n")
        self.rows = 0

    def write(self, result: FrameResult) -> None:
        f = result.frame
        lines = []
        for tr in result.confirmed:
            sd = np.sqrt(np.clip(np.diag(tr.covariance), 0, None))
            x, y, z = tr.position
            lines.append(
                f"{f.index},{f.time:.6f},{tr.track_id},{x:.5f},{y:.5f},{z:.5f},{sd[0]:.5f},{sd[1]:.5f},{sd[2]:.5f},{tr.n_particles},{tr.target}\n"
            )
        if lines:
            self._file.writelines(lines)
            self.rows += len(lines)
        self._file.flush()

    def close(self) -> None:
        if self._file.closed:
            return
        failing = sys.exc_info()[0]
        if failing is None or issubclass(failing, KeyboardInterrupt):  # Ctrl-C keeps what was tracked
            self._out.commit()
        else:
            self._out.abort()


def read_tracks(path: str | Path) -> np.ndarray:
    """tracks.csv -> (M x 6) float array: frame, time, track_id, x, y, z (extra columns ignored)."""
    return read_columns(path, HEADER[:6], "tracks file", whole=("frame", "track_id"), nonnegative=("frame",))
