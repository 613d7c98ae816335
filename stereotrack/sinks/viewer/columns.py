"""Per-frame data gathered for the sink's column batches: fading trails, time series, pending frames."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np


class Trail:
    """One track's recent positions in growing arrays, trimmed to the trail's length in seconds.

    Points are only ever appended (growing copies them into new arrays), so
    the views ``arrays()`` hands out stay valid while they wait for a batch.
    """

    def __init__(self) -> None:
        self.times = np.zeros(64)
        self.points = np.zeros((64, 3))
        self.start = self.end = 0

    def add(self, t: float, position: np.ndarray, seconds: float) -> None:
        if self.end == len(self.times):  # full: drop what is trimmed, grow if still needed
            n = self.end - self.start
            size = max(64, 2 * n)
            times, points = np.zeros(size), np.zeros((size, 3))
            times[:n], points[:n] = self.times[self.start : self.end], self.points[self.start : self.end]
            self.times, self.points, self.start, self.end = times, points, 0, n
        self.times[self.end] = t
        self.points[self.end] = position
        self.end += 1
        self.start += int(np.searchsorted(self.times[self.start : self.end], t - seconds, side="left"))

    def __len__(self) -> int:
        return self.end - self.start

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        return self.times[self.start : self.end], self.points[self.start : self.end]


class SeriesBuffer:
    """Time-series values gathered per entity and sent as columns with the sink's batches.

    One ``send_columns`` per series per batch instead of one ``log`` call per
    value and frame: the time series are most of the log calls, and each call
    costs more than the numbers it carries.
    """

    def __init__(self, rr: Any, send_rows: Any):
        self.rr, self.send_rows = rr, send_rows  # send_rows: RerunSink._rows
        self.series: dict[str, tuple[list[int], list[float], list[float]]] = {}

    def add(self, path: str, frame: int, t: float, value: float) -> None:
        frames, times, values = self.series.setdefault(path, ([], [], []))
        frames.append(frame)
        times.append(t)
        values.append(float(value))

    def flush(self) -> None:
        rr = self.rr
        index: dict[tuple[int, ...], list[Any]] = {}  # most series share the batch's frames: build their time columns once
        for path, (frames, times, values) in self.series.items():
            if frames:
                key = tuple(frames)
                if key not in index:
                    index[key] = [
                        rr.TimeColumn("frame", sequence=np.array(frames, dtype=np.int64)),
                        rr.TimeColumn("capture_time", duration=np.array(times)),
                    ]
                self.send_rows(path, index[key], np.ones(len(values), dtype=np.int64), rr.Scalars, scalars=np.array(values))
        self.series.clear()


@dataclass
class Pending:
    """One logged frame waiting for its batch: references and the few things that cannot wait (JPEGs, trails)."""

    index: int  # frame number
    time: float  # capture_time, s
    objects: tuple  # Object3D
    tracks: tuple  # the confirmed TrackEstimates
    jpegs: list  # per camera, the encoded image (uint8 array)
    particles: list  # per target: (target, positions, labels, abductive, index of its first object)
    trails: list  # per confirmed track with a trail: (its index in tracks, times, points)
