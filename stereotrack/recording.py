"""Recording folders (formats.md section 2): a writer that a kill cannot corrupt, and a reader.

Videos are AVI files written through PyAV, one per camera. The default codec,
``mjpg``, stores one JPEG per frame: the very bytes a webcam sent in MJPG mode
(no re-encoding), or an image encoded here with libjpeg at quality 95 (raw
sources); ``ffv1`` is lossless but costs about 110 ms per 720p frame
(BENCHMARKS.md "Recording"). Every frame is flushed to its file as it is
written, and the frames.csv row of a pair is written only after all of its
frames are in their files: a killed writer (even SIGKILL) leaves a folder in
which every row has its frames. Timestamps are written with full float
precision, so a replay computes exactly the time steps the live run used.

The reader decodes JPEG frames with ``cv2.imdecode``, the decoder the live
cameras' frames go through, so a replay sees the pixels the live tracker saw.
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from datetime import UTC, datetime
from fractions import Fraction
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import yaml

from .camera import Rig, load_rig, save_rig
from .console import quiet_native_stderr, warn
from .errors import StereotrackError
from .files import MAX_CSV_BYTES, load_yaml, numeric_table, read_columns, read_text
from .frames import FramePair

CODECS = {"mjpg": ".avi", "ffv1": ".avi"}
DEFAULT_CODEC = "mjpg"
JPEG_QUALITY = 95  # raw frames encoded for a recording; BENCHMARKS.md "Recording" has the size/quality trade


def encode_jpeg(image: np.ndarray, quality: int = JPEG_QUALITY) -> bytes:
    """One BGR image as a JPEG file (libjpeg via OpenCV; releases the GIL)."""
    ok, buf = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    if not ok:
        raise StereotrackError(f"cannot encode a {image.shape} image as JPEG")
    return buf.tobytes()


def decode_jpeg(data: bytes | np.ndarray) -> np.ndarray | None:
    """A JPEG file as a BGR image (None when corrupt). Live frames and replays both decode here."""
    buf = np.frombuffer(data, np.uint8) if isinstance(data, (bytes, bytearray, memoryview)) else data.reshape(-1)
    return cv2.imdecode(buf, cv2.IMREAD_COLOR)


def format_time(t: float) -> str:
    """A timestamp as written to frames.csv: the shortest text that reads back as the same float."""
    return repr(float(t))


# --------------------------------------------------------------------------- writer


class _VideoOut:
    """One camera's AVI file: packets muxed by PyAV and handed to the OS after every frame."""

    def __init__(self, path: Path, codec: str, size: tuple[int, int], fps: float):
        import av  # imported here: only writers need it, and it takes half a second

        self.path = path
        self.codec = codec
        self.count = 0
        # flush_packets: each frame is written to the file at once, not held in a 32 kB buffer
        self._container = av.open(str(path), "w", format="avi", options={"flush_packets": "1"})
        rate = Fraction(fps).limit_denominator(1001)
        if codec == "mjpg":
            self._stream = self._container.add_stream("mjpeg", rate=rate)
            self._stream.pix_fmt = "yuvj420p"
        else:
            self._stream = self._container.add_stream("ffv1", rate=rate, options={"g": "1"})  # every frame a keyframe
            self._stream.pix_fmt = "bgr0"
        self._stream.width, self._stream.height = size
        self._time_base = Fraction(1) / rate
        self._av = av

    def write_jpeg(self, data: bytes) -> None:
        packet = self._av.Packet(data)
        packet.stream = self._stream
        packet.pts = packet.dts = self.count
        packet.time_base = self._time_base
        packet.is_keyframe = True
        self._container.mux(packet)
        self.count += 1

    def write_image(self, image: np.ndarray) -> None:
        if self.codec == "mjpg":
            self.write_jpeg(encode_jpeg(image))
            return
        frame = self._av.VideoFrame.from_ndarray(np.ascontiguousarray(image), format="bgr24")
        frame.pts = self.count
        for packet in self._stream.encode(frame):  # FFV1 has no encoder delay: one packet per frame, now
            self._container.mux(packet)
        self.count += 1

    def close(self) -> None:
        if self.codec != "mjpg":
            for packet in self._stream.encode():
                self._container.mux(packet)
        self._container.close()  # writes the AVI index and header counts


class RecordingWriter:
    """Writes a recording folder frame pair by frame pair.

    >>> with RecordingWriter("recordings/x", ["cam0", "cam1"], (640, 480), 30.0, rig=rig) as w:
    ...     w.write([img0, img1], [t0, t1])            # raw images (encoded here)
    ...     w.write([None, None], [t0, t1], [jpeg0, jpeg1])  # JPEGs as a camera sent them (mjpg)
    """

    def __init__(
        self,
        folder: str | Path,
        camera_names: Sequence[str],
        image_size: tuple[int, int],
        fps: float,
        rig: Rig | None = None,
        codec: str = DEFAULT_CODEC,
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
        self.codec = codec
        videos = {name: f"{name}{CODECS[codec]}" for name in self.camera_names}
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
        self._videos: list[_VideoOut] = []
        try:
            for name in self.camera_names:
                self._videos.append(_VideoOut(self.folder / videos[name], codec, self.image_size, self.fps))
        except Exception as exc:
            for v in self._videos:
                v.close()
            raise StereotrackError(f"cannot open a {codec} video writer in {self.folder}: {exc}") from None
        self._frames_file = open(self.folder / "frames.csv", "w", newline="")
        self._frames_file.write("frame," + ",".join(f"t_{n}" for n in self.camera_names) + "\n")
        self._frames_file.flush()
        self._truth_file = None
        self._truth_fields = tuple(truth_fields)  # optional extra truth.csv columns after x,y,z
        self.count = 0

    def write(self, images: Sequence[np.ndarray | None], timestamps: Sequence[float], jpegs: Sequence[bytes | None] | None = None) -> int:
        """Append one frame pair; returns its frame index.

        ``jpegs`` (mjpg only) are the frames as a camera sent them, stored as they are;
        cameras without one give their image instead.
        """
        n = len(self._videos)
        jpegs = list(jpegs) if jpegs is not None and self.codec == "mjpg" else [None] * n
        if len(images) != n or len(timestamps) != n or len(jpegs) != n:
            raise ValueError("one image (or JPEG) and one timestamp per camera")
        w, h = self.image_size
        for img, jpeg in zip(images, jpegs):
            if jpeg is None and img is None:
                raise ValueError("a camera gave neither an image nor a JPEG")
            if jpeg is None and img.shape[:2] != (h, w):
                raise StereotrackError(f"frame of size {img.shape[1]}x{img.shape[0]} does not match the recording's {w}x{h}")
        for video, img, jpeg in zip(self._videos, images, jpegs):
            if jpeg is not None:
                video.write_jpeg(jpeg)
            else:
                video.write_image(img)
        # Only now, with every frame of the pair in its file, the row that lists it.
        index = self.count
        self._frames_file.write(f"{index}," + ",".join(format_time(t) for t in timestamps) + "\n")
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
        for v in self._videos:
            v.close()
            if v.path.is_file():  # PyAV creates the file with the first frame
                with open(v.path, "rb") as f:
                    os.fsync(f.fileno())
        self._videos = []
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
        table = numeric_table(body, len(header))
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


def read_tracked_frames(path: Path) -> np.ndarray | None:
    """tracked.csv (written by ``live --record``): the frames the live tracker stepped, in order; None if absent."""
    if not path.is_file():
        return None
    frames = []
    with open(path, newline="") as f:
        lines = f.read().split("\n")
    if lines[0].strip() != "frame":
        raise StereotrackError(f"{path}: header must be 'frame'")
    for line in lines[1:-1]:  # the last piece is '' or a line cut short by a kill
        try:
            frames.append(int(line))
        except ValueError:
            raise StereotrackError(f"{path}: {line!r} is not a frame number") from None
    return np.asarray(frames, dtype=int)


class _VideoIn:
    """One video's frames in order. JPEG frames (MJPG) are read as packets and decoded by
    ``decode_jpeg``; other codecs (FFV1 of older recordings) by OpenCV's video decoder."""

    def __init__(self, path: Path):
        self.path = path
        self._cap = cv2.VideoCapture(str(path))
        fourcc = int(self._cap.get(cv2.CAP_PROP_FOURCC))
        self.jpeg = fourcc.to_bytes(4, "little").upper() == b"MJPG"
        if self.jpeg:
            self.jpeg = bool(self._cap.set(cv2.CAP_PROP_FORMAT, -1))  # raw packets, undecoded

    def skip(self) -> bool:
        return self._cap.grab()

    def read(self) -> np.ndarray | None:
        ok, data = self._cap.read()
        if not ok or data is None:
            return None
        return decode_jpeg(data) if self.jpeg else data

    def release(self) -> None:
        self._cap.release()


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
    tracked_frames: np.ndarray | None = None  # the frames a live run tracked (tracked.csv), if any

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

    def frames(self, start: int = 0, stop: int | None = None, only: Sequence[int] | None = None) -> Iterator[FramePair]:
        """Decode frame pairs in order, up to the last complete pair; ``only``: just these frames.

        The cameras' frames of a pair are decoded in parallel, and the next pair is
        decoded while the caller works on this one (JPEG decoding releases the GIL).
        """
        from concurrent.futures import ThreadPoolExecutor

        stop = self.n_frames if stop is None else min(stop, self.n_frames)
        wanted = range(start, stop) if only is None else [int(i) for i in only if start <= i < stop]
        videos = [_VideoIn(p) for p in self.video_paths]
        pool = ThreadPoolExecutor(len(videos), thread_name_prefix="decode")
        position = 0  # next frame index every video is at

        def submit(index: int):
            nonlocal position
            skip = index - position
            position = index + 1
            return [pool.submit(_skip_then_read, v, skip) for v in videos]

        try:
            queue = iter(wanted)
            nxt = next(queue, None)
            pending = submit(nxt) if nxt is not None else None
            while pending is not None:
                index = nxt
                images = [f.result() for f in pending]
                nxt = next(queue, None)
                pending = submit(nxt) if nxt is not None and all(img is not None for img in images) else None
                if any(img is None for img in images):
                    warn(f"{self.folder}: videos end at frame {index} of {self.n_frames} (interrupted recording?); stopping there")
                    return
                yield FramePair(index=index, images=tuple(images), timestamps=tuple(float(v) for v in self.timestamps[index]))
        finally:
            pool.shutdown(wait=True, cancel_futures=True)  # no decoder may still be reading a video we release
            for v in videos:
                v.release()


def _skip_then_read(video: _VideoIn, skip: int) -> np.ndarray | None:
    for _ in range(skip):
        if not video.skip():
            return None
    return video.read()


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
        with quiet_native_stderr():  # OpenCV's AVI reader prints its own complaint about a broken file
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
        tracked_frames=read_tracked_frames(folder / "tracked.csv"),
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
    return read_truth_and_views(path)[0]


def read_truth_and_views(path: str | Path) -> tuple[np.ndarray, np.ndarray | None]:
    """truth.csv -> its rows (``read_truth``) and, per row, how many cameras see its ball, or None when the file does
    not say, from one read of the file. The count is the optional ``clear`` column (the cameras that show a quarter of
    the ball or more) where the file has one, else the optional ``visible`` (the cameras that show some of it)."""
    columns, optional = ["frame", "object_id", "x", "y", "z"], ("visible", "clear")
    data = read_columns(
        path, columns, "ground-truth file", whole=("frame", "object_id") + optional, nonnegative=("frame",) + optional, optional=optional
    )
    return data[:, :5], (data[:, -1] if data.shape[1] > 5 else None)


def __getattr__(name: str):
    """Names that moved out of this module (``RecordingSink``, now in sinks/recorder.py) still import from here."""
    from ._compat import moved_name

    return moved_name(__name__, name)
