"""Recording folders (formats.md section 2): a writer that survives being killed, and a reader.

The writer appends one row to ``frames.csv`` per frame pair and flushes it at
once, after the frames went to the video writers, so a killed writer leaves a
folder that the reader opens up to the last complete pair.
"""

from __future__ import annotations

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
from .files import MAX_CSV_BYTES, load_yaml, read_columns, read_text
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


MAX_TIMESTAMP = 1e10  # seconds: a monotonic clock (or even the epoch) stays far below; beyond it the motion model overflows


def _read_frames_csv(path: Path, names: list[str]) -> np.ndarray:
    """frames.csv -> n_frames x n_cameras timestamps, columns in ``names`` order (matched by the header's t_NAME).

    Only the last line may be malformed (a writer killed mid-line); anywhere
    else a bad line, a frame number out of sequence, a non-finite timestamp or
    one that goes backwards is refused with its line number.
    """
    text = read_text(path, "frames.csv", missing="frames.csv is missing (is this a recording folder?)", max_bytes=MAX_CSV_BYTES)
    lines = text.splitlines()
    expected = ["frame"] + [f"t_{n}" for n in names]
    header = [h.strip() for h in lines[0].split(",")] if lines else []
    if not header or header[0] != "frame" or sorted(header[1:]) != sorted(expected[1:]):
        got = lines[0][:80] if lines else "an empty file"
        raise StereotrackError(
            f"{path}: line 1: the header must be {','.join(expected)} (a t_NAME column per camera of meta.yaml), got {got!r}"
        )
    columns = [header.index(f"t_{n}") for n in names]
    for body in (lines[1:], lines[1:-1]):  # every line whole, or all but a last one cut short by a killed writer
        table = _numeric_table(body, len(header))
        if table is not None and np.array_equal(table[:, 0], np.arange(len(table))) and (np.abs(table) < MAX_TIMESTAMP).all():
            return _checked_order(path, table[:, columns], names)
    # Something is wrong: find the first bad line, one by one.
    rows: list[list[float]] = []
    for line_no, line in enumerate(lines[1:], start=2):
        fields = line.split(",")
        try:
            if len(fields) != len(header):
                raise ValueError(f"expected {len(header)} values, got {len(fields)}")
            frame = float(fields[0])  # '3' or '3.0', as the fast path reads it
            times = [float(fields[c]) for c in columns]
        except ValueError as exc:
            if line_no == len(lines):
                break  # a partial last line from an interrupted writer
            raise StereotrackError(
                f"{path}: line {line_no}: not a frame row ({str(exc).splitlines()[0][:60]}); "
                f"expected {','.join(expected)} (only the last line may be cut short)"
            ) from None
        if frame != len(rows):
            raise StereotrackError(f"{path}: line {line_no}: frame numbers must count up from 0 (expected {len(rows)}, got {fields[0]})")
        if not all(abs(t) < MAX_TIMESTAMP for t in times):  # also false for NaN
            raise StereotrackError(
                f"{path}: line {line_no}: timestamps must be finite numbers of seconds (below 1e10), got {','.join(fields[1:])[:60]}"
            )
        rows.append(times)
    return _checked_order(path, np.asarray(rows, dtype=float).reshape(-1, len(names)), names)


def _numeric_table(lines: list[str], width: int) -> np.ndarray | None:
    """Lines of ``width`` comma-separated numbers as an array, or None (the fast path: no Python loop per line)."""
    if not lines:
        return np.zeros((0, width))
    fields = ",".join(lines).split(",")
    if len(fields) != len(lines) * width:
        return None
    try:
        return np.asarray(fields, dtype=float).reshape(len(lines), width)
    except ValueError:
        return None


def _checked_order(path: Path, timestamps: np.ndarray, names: list[str]) -> np.ndarray:
    back = np.argwhere(np.diff(timestamps, axis=0) < 0)
    if len(back):
        row, cam = back[0]
        raise StereotrackError(
            f"{path}: line {row + 3}: the timestamp of {names[cam]} goes backwards ({timestamps[row + 1, cam]:.6f} after {timestamps[row, cam]:.6f}); "
            "timestamps are seconds on one monotonic clock"
        )
    return timestamps


def _inside(folder: Path, meta_path: Path, field: str, value: Any) -> Path:
    """A file named in meta.yaml: a relative path that stays inside the recording folder."""
    if not isinstance(value, str) or not value.strip():
        raise StereotrackError(f"{meta_path}: field '{field}': expected a file name inside the recording folder, got {value!r:.60}")
    rel = Path(value)
    if rel.is_absolute() or ".." in rel.parts:
        raise StereotrackError(
            f"{meta_path}: field '{field}': {value!r} is outside the recording folder; name a file inside it (relative to meta.yaml)"
        )
    return folder / rel


@dataclass(frozen=True)
class _Meta:
    names: list[str]
    videos: list[Path]
    fps: float
    image_size: tuple[int, int] | None
    targets: Path | None


def _read_meta(folder: Path) -> tuple[dict[str, Any], _Meta]:
    """meta.yaml, checked field by field (formats.md section 2); unknown fields are kept and ignored."""
    path = folder / "meta.yaml"
    meta = load_yaml(path, "meta.yaml is missing (is this a recording folder?)", what="meta.yaml")

    def fail(field: str, what: str) -> StereotrackError:
        return StereotrackError(f"{path}: field '{field}': {what}")

    if not isinstance(meta, dict):
        raise fail("<top level>", "expected a mapping with cameras, videos, fps, image_size")
    cameras = meta.get("cameras")
    if not isinstance(cameras, list) or len(cameras) < 2:
        raise fail("cameras", f"expected a list of two or more camera names, got {cameras!r:.60}")
    names = []
    for n in cameras:
        if isinstance(n, bool) or not isinstance(n, (str, int)) or not str(n).strip() or any(c in str(n) for c in ",\n\r"):
            raise fail("cameras", f"expected camera names (text without commas), got {n!r:.60}")
        names.append(str(n))
    if len(set(names)) != len(names):
        raise fail("cameras", f"camera names must be unique, got {names}")
    videos = meta.get("videos")
    if not isinstance(videos, dict):
        raise fail("videos", f"expected a mapping from camera name to video file, got {videos!r:.60}")
    by_name = {str(k): v for k, v in videos.items()}
    paths = []
    for n in names:
        if n not in by_name:
            raise fail("videos", f"no entry for camera {n!r}")
        p = _inside(folder, path, f"videos.{n}", by_name[n])
        if not p.is_file():
            raise StereotrackError(f"{p}: video for camera {n!r} is " + ("not a regular file" if p.exists() else "missing"))
        paths.append(p)
    fps = meta.get("fps", 30.0)
    if isinstance(fps, bool) or not isinstance(fps, (int, float)) or not 0 < fps <= 10_000:
        raise fail("fps", f"expected frames per second, a number above 0, got {fps!r:.60}")
    size = meta.get("image_size")
    if size is not None and not (
        isinstance(size, list) and len(size) == 2 and all(isinstance(v, int) and not isinstance(v, bool) and 0 < v <= 100_000 for v in size)
    ):
        raise fail("image_size", f"expected [width, height] in whole pixels, got {size!r:.60}")
    targets = None
    if meta.get("targets") is not None:
        targets = _inside(folder, path, "targets", meta["targets"])
        if targets.name in ("meta.yaml", "frames.csv", "calib.yaml", "truth.csv") and targets.parent == folder or targets in paths:
            raise fail("targets", f"{meta['targets']!r} is one of the recording's own files; name a config file such as config.yaml")
    return meta, _Meta(names, paths, float(fps), tuple(size) if size else None, targets)


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

    targets_file: Path | None = None  # meta.yaml's 'targets', checked to lie inside the folder

    @property
    def targets_path(self) -> Path | None:
        return self.targets_file

    @property
    def own_files(self) -> tuple[Path, ...]:
        """The files that make up the recording: no command writes over them (the targets file aside)."""
        files = [
            self.folder / "meta.yaml",
            self.folder / "frames.csv",
            self.folder / "calib.yaml",
            self.folder / "truth.csv",
            *self.video_paths,
        ]
        return tuple(files)

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
    """Open and check a recording folder; ``calib`` overrides its calib.yaml (its cameras are matched by name)."""
    folder = Path(folder)
    if not folder.is_dir():
        raise StereotrackError(f"{folder}: recording folder not found")
    meta, m = _read_meta(folder)
    names, paths = m.names, m.videos
    timestamps = _read_frames_csv(folder / "frames.csv", names)

    # What the videos hold: size and (where the container knows it) length.
    sizes, counts = [], []
    for p in paths:
        cap = cv2.VideoCapture(str(p))
        if not cap.isOpened():
            raise StereotrackError(f"{p}: OpenCV cannot open this video (not a video file, or cut short)")
        sizes.append((int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)), int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT))))
        counts.append(int(cap.get(cv2.CAP_PROP_FRAME_COUNT)))
        cap.release()
    size = m.image_size or sizes[0]
    for n, s in zip(names, sizes):
        if s != (0, 0) and tuple(s) != tuple(size):
            raise StereotrackError(f"{folder}: video of {n} is {s[0]}x{s[1]} but meta.yaml says {size[0]}x{size[1]}")
    n = len(timestamps)
    known = [c for c in counts if c > 0]
    if known and min(known) != n and n > 0:
        warn(
            f"{folder}: frames.csv has {n} rows but the videos hold {min(known)} frames (interrupted recording?); reading {min(n, min(known))} complete pairs"
        )
        n = min(n, min(known))
    rig = None
    calib_path = Path(calib) if calib else folder / "calib.yaml"
    if calib or calib_path.is_file():
        rig = _matched_rig(load_rig(calib_path), calib_path, names, folder)
        if rig.names != names:  # the calibration's order wins: camera i of the rig sees video i
            order = [names.index(name) for name in rig.names]
            names, paths, timestamps = list(rig.names), [paths[i] for i in order], timestamps[:, order]
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
        fps=m.fps,
        timestamps=timestamps[:n],
        rig=rig,
        video_paths=tuple(paths),
        targets_file=m.targets,
    )


def _matched_rig(rig: Rig, calib_path: Path, names: list[str], folder: Path) -> Rig:
    """The calibration, once its cameras match the recording's by name (never by position)."""
    if len(rig) != len(names):
        raise StereotrackError(f"{calib_path}: has {len(rig)} cameras but the recording has {len(names)}")
    if sorted(rig.names) != sorted(names):
        raise StereotrackError(
            f"{calib_path}: calibrates cameras {', '.join(rig.names)} but the recording {folder} has {', '.join(names)} (meta.yaml): "
            "the names must match (rename them in one of the files, or calibrate with --names)"
        )
    return rig


def read_truth(path: str | Path) -> np.ndarray:
    """truth.csv -> structured rows as an (M x 5) float array: frame, object_id, x, y, z."""
    return read_columns(
        path, ["frame", "object_id", "x", "y", "z"], "ground-truth file", whole=("frame", "object_id"), nonnegative=("frame",)
    )


def __getattr__(name: str):
    """Names that moved out of this module (``RecordingSink``, now in sinks/recorder.py) still import from here."""
    from ._compat import moved_name

    return moved_name(__name__, name)
