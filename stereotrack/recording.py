"""Recording folders (formats.md section 2): a writer that survives being killed, and a reader.

The writer appends one row to ``frames.csv`` per frame pair and flushes it at
once, after the frames went to the video writers, so a killed writer leaves a
folder that the reader opens up to the last complete pair.
"""

from __future__ import annotations

import csv
import os
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import yaml

from .camera import Rig, load_rig, save_rig
from .console import warn
from .errors import StereotrackError
from .files import load_yaml, read_columns
from .frames import FramePair

CODECS = {"ffv1": ("FFV1", ".mkv"), "mjpg": ("MJPG", ".avi")}


# --------------------------------------------------------------------------- writer


class RecordingWriter:
    """Writes a recording folder frame pair by frame pair.

    >>> with RecordingWriter("recordings/x", ["cam0", "cam1"], (640, 480), 30.0, rig=rig) as w:
    ...     w.write([img0, img1], [t0, t1])
    """

    def __init__(
        self,
        folder: str | Path,
        camera_names: Sequence[str],
        image_size: tuple[int, int],
        fps: float,
        rig: Rig | None = None,
        codec: str = "ffv1",
        source: str = "live",
        targets: dict[str, Any] | None = None,
        extra_meta: dict[str, Any] | None = None,
        overwrite: bool = False,
        truth_fields: Sequence[str] = (),
    ):
        if codec not in CODECS:
            raise StereotrackError(f"unknown codec {codec!r}: choose one of {', '.join(CODECS)}")
        self.folder = Path(folder)
        if self.folder.exists() and any(self.folder.iterdir()):
            if not overwrite:
                raise StereotrackError(f"{self.folder}: folder exists and is not empty (choose another --out or remove it)")
            for p in self.folder.iterdir():
                if p.is_file():
                    p.unlink()
        self.folder.mkdir(parents=True, exist_ok=True)
        self.camera_names = list(camera_names)
        self.image_size = (int(image_size[0]), int(image_size[1]))
        self.fps = float(fps)
        fourcc, ext = CODECS[codec]
        videos = {name: f"{name}{ext}" for name in self.camera_names}
        meta: dict[str, Any] = {
            "version": 1,
            "cameras": self.camera_names,
            "videos": videos,
            "fps": self.fps,
            "image_size": list(self.image_size),
            "created": datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
            "source": source,
        }
        if targets is not None:
            (self.folder / "config.yaml").write_text(yaml.safe_dump(targets, sort_keys=False))
            meta["targets"] = "config.yaml"
        if extra_meta:
            meta.update(extra_meta)
        if rig is not None:
            save_rig(rig, self.folder / "calib.yaml")
        (self.folder / "meta.yaml").write_text(yaml.safe_dump(meta, sort_keys=False))
        self._writers = []
        for name in self.camera_names:
            w = cv2.VideoWriter(str(self.folder / videos[name]), cv2.VideoWriter_fourcc(*fourcc), self.fps, self.image_size)
            if not w.isOpened():
                raise StereotrackError(f"cannot open a {codec} video writer for {self.folder / videos[name]} (try --codec mjpg)")
            self._writers.append(w)
        self._frames_file = open(self.folder / "frames.csv", "w", newline="")
        self._frames_file.write("frame," + ",".join(f"t_{n}" for n in self.camera_names) + "\n")
        self._frames_file.flush()
        self._truth_file = None
        self._truth_fields = tuple(truth_fields)  # optional extra truth.csv columns after x,y,z
        self.count = 0

    def write(self, images: Sequence[np.ndarray], timestamps: Sequence[float]) -> int:
        """Append one frame pair; returns its frame index."""
        if len(images) != len(self._writers) or len(timestamps) != len(self._writers):
            raise ValueError("one image and one timestamp per camera")
        w, h = self.image_size
        for img, writer in zip(images, self._writers):
            if img.shape[:2] != (h, w):
                raise StereotrackError(f"frame of size {img.shape[1]}x{img.shape[0]} does not match the recording's {w}x{h}")
            writer.write(np.ascontiguousarray(img))
        index = self.count
        self._frames_file.write(f"{index}," + ",".join(f"{t:.6f}" for t in timestamps) + "\n")
        self._frames_file.flush()
        self.count += 1
        return index

    def write_truth(self, frame: int, rows: Sequence[tuple]) -> None:
        """Append ground-truth rows (object_id, x, y, z, *truth_fields) for one frame."""
        if self._truth_file is None:
            self._truth_file = open(self.folder / "truth.csv", "w", newline="")
            self._truth_file.write(",".join(("frame", "object_id", "x", "y", "z") + self._truth_fields) + "\n")
        n = 4 + len(self._truth_fields)
        for row in rows:
            if len(row) != n:
                raise ValueError(f"truth rows need {n} values (object_id, x, y, z{''.join(', ' + f for f in self._truth_fields)})")
            oid, x, y, z = row[:4]
            extra = "".join(f",{v}" for v in row[4:])
            self._truth_file.write(f"{frame},{int(oid)},{x:.6f},{y:.6f},{z:.6f}{extra}\n")
        self._truth_file.flush()

    def close(self) -> None:
        for w in self._writers:
            w.release()
        self._writers = []
        for f in (self._frames_file, self._truth_file):
            if f is not None and not f.closed:
                f.flush()
                os.fsync(f.fileno())
                f.close()

    def __enter__(self) -> RecordingWriter:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


# --------------------------------------------------------------------------- reader


def _read_frames_csv(path: Path, names: list[str]) -> np.ndarray:
    if not path.is_file():
        raise StereotrackError(f"{path}: frames.csv is missing (is this a recording folder?)")
    with open(path, newline="") as f:
        reader = csv.reader(f)
        header = next(reader, None)
        expected = ["frame"] + [f"t_{n}" for n in names]
        if header != expected:
            raise StereotrackError(f"{path}: header must be {','.join(expected)}, got {','.join(header or [])}")
        rows = []
        for line_no, row in enumerate(reader, start=2):
            if len(row) != len(expected):
                break  # a partial last line from an interrupted writer
            try:
                rows.append([float(v) for v in row[1:]])
            except ValueError:
                break
            if int(row[0]) != len(rows) - 1:
                raise StereotrackError(f"{path}: line {line_no}: frame numbers must count up from 0")
    return np.asarray(rows, dtype=float).reshape(-1, len(names))


@dataclass(frozen=True, eq=False)
class Recording:
    """An opened recording folder. ``frames()`` yields FramePairs."""

    folder: Path
    meta: dict[str, Any]
    camera_names: tuple[str, ...]
    image_size: tuple[int, int]
    fps: float
    timestamps: np.ndarray  # n_frames x n_cameras (complete pairs only)
    rig: Rig | None
    video_paths: tuple[Path, ...]

    @property
    def n_frames(self) -> int:
        return len(self.timestamps)

    @property
    def truth_path(self) -> Path | None:
        p = self.folder / "truth.csv"
        return p if p.is_file() else None

    @property
    def targets_path(self) -> Path | None:
        name = self.meta.get("targets")
        return (self.folder / name) if name else None

    def require_rig(self) -> Rig:
        if self.rig is None:
            raise StereotrackError(f"{self.folder}: no calib.yaml in the recording; pass --calib FILE")
        return self.rig

    def frames(self, start: int = 0, stop: int | None = None) -> Iterator[FramePair]:
        """Decode frame pairs in order, up to the last complete pair."""
        stop = self.n_frames if stop is None else min(stop, self.n_frames)
        caps = [cv2.VideoCapture(str(p)) for p in self.video_paths]
        try:
            if start:
                for cap in caps:
                    cap.set(cv2.CAP_PROP_POS_FRAMES, start)
            for index in range(start, stop):
                images = []
                for cap in caps:
                    ok, img = cap.read()
                    if not ok:
                        warn(f"{self.folder}: videos end at frame {index} of {self.n_frames} (interrupted recording?); stopping there")
                        return
                    images.append(img)
                yield FramePair(index=index, images=tuple(images), timestamps=tuple(float(v) for v in self.timestamps[index]))
        finally:
            for cap in caps:
                cap.release()


def open_recording(folder: str | Path, calib: str | Path | None = None) -> Recording:
    """Open and check a recording folder; ``calib`` overrides its calib.yaml."""
    folder = Path(folder)
    if not folder.is_dir():
        raise StereotrackError(f"{folder}: recording folder not found")
    meta = load_yaml(folder / "meta.yaml", "meta.yaml is missing")
    if not isinstance(meta, dict) or "cameras" not in meta or "videos" not in meta:
        raise StereotrackError(f"{folder / 'meta.yaml'}: expected 'cameras' and 'videos' fields")
    names = [str(n) for n in meta["cameras"]]
    videos = meta["videos"]
    paths = []
    for n in names:
        if n not in videos:
            raise StereotrackError(f"{folder / 'meta.yaml'}: field 'videos' has no entry for camera {n!r}")
        p = folder / str(videos[n])
        if not p.is_file():
            raise StereotrackError(f"{p}: video for camera {n!r} is missing")
        paths.append(p)
    timestamps = _read_frames_csv(folder / "frames.csv", names)

    # What the videos hold: size and (where the container knows it) length.
    sizes, counts = [], []
    for p in paths:
        cap = cv2.VideoCapture(str(p))
        if not cap.isOpened():
            raise StereotrackError(f"{p}: OpenCV cannot open this video")
        sizes.append((int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)), int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT))))
        counts.append(int(cap.get(cv2.CAP_PROP_FRAME_COUNT)))
        cap.release()
    size = tuple(meta.get("image_size") or sizes[0])
    for n, s in zip(names, sizes):
        if s != (0, 0) and tuple(s) != tuple(size):
            raise StereotrackError(f"{folder}: video of {n} is {s[0]}x{s[1]} but meta.yaml says {size[0]}x{size[1]}")
    n = len(timestamps)
    known = [c for c in counts if c > 0]
    if known and min(known) != n:
        warn(
            f"{folder}: frames.csv has {n} rows but the videos hold {min(known)} frames (interrupted recording?); reading {min(n, min(known))} complete pairs"
        )
        n = min(n, min(known))
    rig = None
    calib_path = Path(calib) if calib else folder / "calib.yaml"
    if calib or calib_path.is_file():
        rig = load_rig(calib_path)
        if len(rig) != len(names):
            raise StereotrackError(f"{calib_path}: has {len(rig)} cameras but the recording has {len(names)}")
        for cam in rig.cameras:
            if tuple(cam.image_size) != tuple(size):
                raise StereotrackError(
                    f"{calib_path}: camera {cam.name} is calibrated for {cam.width}x{cam.height} but the recording's videos are {size[0]}x{size[1]} "
                    f"(calibrate at the recording's resolution)"
                )
    return Recording(
        folder=folder,
        meta=meta,
        camera_names=tuple(names),
        image_size=(int(size[0]), int(size[1])),
        fps=float(meta.get("fps", 30.0)),
        timestamps=timestamps[:n],
        rig=rig,
        video_paths=tuple(paths),
    )


def read_truth(path: str | Path) -> np.ndarray:
    """truth.csv -> structured rows as an (M x 5) float array: frame, object_id, x, y, z."""
    return read_columns(path, ["frame", "object_id", "x", "y", "z"], "ground-truth file")


def __getattr__(name: str):
    """Names that moved out of this module (``RecordingSink``, now in sinks/recorder.py) still import from here."""
    from ._compat import moved_name

    return moved_name(__name__, name)
