"""Live frame pairs from two or more cameras: capture threads, timestamps, pairing, recording tap.

Every source is an iterable of ``FramePair`` with ``.rig``, ``.fps``,
``.camera_names``, ``.n_frames`` (None when live), ``.stats`` and ``.close()``,
so the tracker never knows whether frames come from webcams or a folder.

One thread per camera grabs frames and stamps each with ``time.monotonic()``
right after the grab (or with the device's own capture time when it reports
one on that clock, as V4L2 does). A camera in MJPG mode hands over the JPEG it
sent, undecoded. A ``Pairer`` matches frames whose timestamps lie within a
tolerance (half a frame period by default); a frame that cannot be matched is
dropped and counted, never paired with a stale one.

Each pair, as it forms, gets the next pair number and goes to the recorder (if
any: it gets every pair; a pair it must refuse because the disk is behind is
dropped for everyone, so recording frame numbers are pair numbers) and to a
bounded queue for the consumer: when the consumer is slow the oldest pair is
skipped and counted, so latency cannot grow. JPEGs are decoded only for the
pairs the consumer takes, in parallel per camera.
"""

from __future__ import annotations

import atexit
import threading
import time
import weakref
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import cv2
import numpy as np

from ..camera import Rig
from ..console import warn
from ..errors import StereotrackError
from ..frames import CameraStats, FramePair, SourceStats
from ..recording import decode_jpeg, encode_jpeg
from .devices import CaptureSettings, VideoDevice, describe, open_device
from .signals import stop_requested


@dataclass(frozen=True, eq=False)
class CapturedPair:
    """A frame pair as captured: per camera a JPEG (as sent, or encoded at capture) or a raw image."""

    index: int
    timestamps: tuple[float, ...]
    images: tuple[np.ndarray | None, ...]
    jpegs: tuple[bytes | None, ...]

    @property
    def nbytes(self) -> int:
        return sum(len(j) if j is not None else (img.nbytes if img is not None else 0) for j, img in zip(self.jpegs, self.images))

    def size(self) -> tuple[int, int]:
        """(width, height) of the first camera's frame."""
        img = self.images[0] if self.images[0] is not None else decode_jpeg(self.jpegs[0])
        if img is None:
            raise StereotrackError("camera cam0 sent a corrupt first frame")
        return img.shape[1], img.shape[0]


# --------------------------------------------------------------------------- pairing (pure logic)


class Pairer:
    """Matches per-camera frame streams by nearest timestamp.

    Frames arrive per camera in time order. Whenever every camera has a frame
    waiting, the oldest waiting frames either lie within ``tolerance`` of each
    other (a pair) or the oldest of them is too old ever to be matched —
    the camera holding the newest head only delivers later frames — so it is
    dropped as unpaired. At most ``max_pending`` frames wait per camera (a
    stalled partner must not let memory grow); overflow counts as unpaired.
    """

    def __init__(self, n_cameras: int, tolerance: float, max_pending: int = 8):
        if n_cameras < 1 or tolerance <= 0:
            raise ValueError("need at least one camera and a positive tolerance")
        self.tolerance = float(tolerance)
        self.max_pending = int(max_pending)
        self._pending: list[deque] = [deque() for _ in range(n_cameras)]
        self.unpaired = [0] * n_cameras

    def push(self, camera: int, timestamp: float, image) -> list[tuple[tuple[float, ...], tuple]]:
        """Add one frame; returns the pairs completed by it as (timestamps, images)."""
        queue = self._pending[camera]
        if queue and timestamp < queue[-1][0]:
            raise ValueError(f"camera {camera}: timestamps must increase")
        if len(queue) >= self.max_pending:
            queue.popleft()
            self.unpaired[camera] += 1
        queue.append((float(timestamp), image))
        pairs = []
        while all(self._pending):
            heads = [q[0][0] for q in self._pending]
            oldest = int(np.argmin(heads))
            if max(heads) - heads[oldest] <= self.tolerance:
                frames = [q.popleft() for q in self._pending]
                pairs.append((tuple(t for t, _ in frames), tuple(img for _, img in frames)))
            else:
                self._pending[oldest].popleft()
                self.unpaired[oldest] += 1
        return pairs


def _as_jpeg(image: np.ndarray) -> bytes | None:
    """The JPEG a camera in MJPG mode sent (a flat byte buffer), or None for a decoded image."""
    flat = image.dtype == np.uint8 and (image.ndim == 1 or (image.ndim == 2 and image.shape[0] == 1))
    if flat and image.size > 2 and image.flat[0] == 0xFF and image.flat[1] == 0xD8:
        return image.tobytes()
    return None


# --------------------------------------------------------------------------- live cameras

_open_sources: weakref.WeakSet = weakref.WeakSet()


@atexit.register
def _close_open_sources() -> None:
    """A script that never closed its source: stop the capture threads before the interpreter tears down
    the devices they are reading (FFmpeg aborts the process otherwise)."""
    for source in list(_open_sources):
        source.close()


class _CameraThread(threading.Thread):
    """Grabs frames from one device, stamps them and hands them to the source; releases the
    device itself when it ends, so no other thread ever releases a device in use."""

    def __init__(self, source: CameraPairSource, slot: int, device: VideoDevice, spec: str):
        super().__init__(name=f"capture-{spec}", daemon=True)  # a hung device must not keep the process alive
        self.source, self.slot, self.device, self.spec = source, slot, device, spec
        self.frames = 0
        self.last_frame: float | None = None  # capture time of the last frame
        self.last_seen: float | None = None  # clock time it was delivered (a late file frame has an old capture time)
        self.ended = False  # a finite device (file) reached its end
        self.error: str | None = None
        self.recent: deque = deque()  # timestamps of the last two seconds, for fps
        self.stop = threading.Event()

    def run(self) -> None:
        clock = self.source.clock
        quality = self.source.jpeg_quality
        try:
            while not self.stop.is_set():
                if not self.device.grab():
                    if getattr(self.device, "finite", False):
                        self.ended = True
                    elif not self.stop.is_set():
                        self.error = (
                            f"camera {self.source.camera_names[self.slot]} ({describe(self.spec)}) stopped delivering frames (unplugged?)"
                        )
                    break
                stamp = clock()
                # The device's own capture time (V4L2 buffer timestamp, on the same monotonic
                # clock) is exact, while our stamp waits for the GIL: prefer it when plausible
                # (a file's due time always: a frame read late on a starved host keeps its own time).
                device_time = self.device.get(cv2.CAP_PROP_POS_MSEC) / 1000.0
                exact = getattr(self.device, "exact_time", False) or stamp - 1.0 < device_time
                if self.source.clock is time.monotonic and exact and device_time <= stamp:
                    stamp = device_time
                ok, image = self.device.retrieve()
                if not ok or image is None:
                    continue  # a corrupt frame (MJPG decode error): skip it, the next one may be fine
                jpeg = _as_jpeg(image)
                if jpeg is not None:
                    image = None
                elif quality is not None:
                    jpeg, image = encode_jpeg(image, quality), None  # recorded as JPEG: everyone sees the same pixels
                self.frames += 1
                self.last_frame = stamp
                self.last_seen = clock()
                self.recent.append(stamp)
                while self.recent and stamp - self.recent[0] > 2.0:
                    self.recent.popleft()
                self.source._deliver(self.slot, stamp, (image, jpeg))
        except Exception as exc:  # a driver error: reported by the consumer, not lost in a thread
            self.error = f"camera {self.source.camera_names[self.slot]} ({describe(self.spec)}) failed: {exc}"
        finally:
            self.device.release()
            self.source._wake()

    def fps(self) -> float:
        r = list(self.recent)
        return (len(r) - 1) / (r[-1] - r[0]) if len(r) > 1 and r[-1] > r[0] else 0.0


class CameraPairSource:
    """Synchronised frame pairs from two or more cameras, as they happen.

    ``devices`` are specs (``"0"``, ``"video.mkv"``, ``"sim:pendulum4"``) or
    already opened ``cv2.VideoCapture``-like objects. ``queue_size`` bounds
    the pairs waiting for the consumer (0: no consumer, e.g. ``record``).
    ``recorder`` (a ``RecordingSink``) is offered every pair as it forms;
    ``jpeg_quality`` makes the capture threads encode raw frames as JPEG (what
    an mjpg recording stores), so the consumer sees the recorded pixels.
    ``seconds`` ends the source once its pairs span that long. Iteration
    raises ``StereotrackError`` when a camera delivers nothing for
    ``stall_timeout`` seconds (``start_timeout`` for the first frame), and ends
    when a video file ends or ``request_stop()`` was called.
    """

    def __init__(
        self,
        devices: Sequence[str | VideoDevice],
        camera_names: Sequence[str] | None = None,
        settings: CaptureSettings = CaptureSettings(),
        rig: Rig | None = None,
        tolerance: float | None = None,
        queue_size: int = 2,
        stall_timeout: float = 2.0,
        start_timeout: float = 5.0,
        clock: Callable[[], float] = time.monotonic,
        recorder=None,
        jpeg_quality: int | None = None,
        seconds: float | None = None,
    ):
        if len(devices) < 2:
            raise StereotrackError("give at least two cameras (--cam0 and --cam1)")
        self.camera_names = tuple(camera_names or (f"cam{i}" for i in range(len(devices))))
        if rig is not None and len(rig) != len(devices):
            raise StereotrackError(f"the calibration has {len(rig)} cameras but {len(devices)} were given")
        self.rig = rig
        self.clock = clock
        self.n_frames = None
        self.recorder = recorder
        self.jpeg_quality = jpeg_quality
        self.stall_timeout, self.start_timeout = float(stall_timeout), float(start_timeout)
        specs = [d if isinstance(d, str) else type(d).__name__ for d in devices]
        opened: list[VideoDevice] = []
        try:
            for slot, d in enumerate(devices):
                opened.append(open_device(d, slot, settings) if isinstance(d, str) else d)
            _check_sizes(opened, self.camera_names, specs, rig)
        except BaseException:
            for dev in opened:
                dev.release()  # no thread runs yet
            raise
        rates = [dev.get(cv2.CAP_PROP_FPS) for dev in opened]
        self.fps = float(settings.fps or max(rates) or 30.0)
        self.tolerance = float(tolerance) if tolerance else 0.5 / self.fps
        self.seconds = seconds
        self._cond = threading.Condition()
        self._pairer = Pairer(len(opened), self.tolerance)
        self._queue: deque = deque()
        self._queue_size = max(0, int(queue_size))
        self._formed = 0
        self._first_time: float | None = None
        self._pairs = 0
        self._pairs_dropped = 0
        self._not_recorded = 0
        self._dropped = [0] * len(opened)
        self._stop_requested = False
        self._span_reached = False
        self._closed = False
        self._decoder = ThreadPoolExecutor(len(opened), thread_name_prefix="decode")
        self._started = clock()
        now = time.monotonic()
        for dev in opened:
            if hasattr(dev, "start_at"):
                dev.start_at(now)  # files and simulated views: frame k of each is due at one moment, however late a thread starts
        self._threads = [_CameraThread(self, i, dev, spec) for i, (dev, spec) in enumerate(zip(opened, specs))]
        for th in self._threads:
            th.start()
        _open_sources.add(self)

    # called from capture threads
    def _deliver(self, slot: int, stamp: float, frame: tuple) -> None:
        with self._cond:
            for timestamps, frames in self._pairer.push(slot, stamp, frame):
                if self._span_reached or self.stopping:
                    break
                t = float(np.mean(timestamps))
                self._first_time = t if self._first_time is None else self._first_time
                if self.seconds is not None and t - self._first_time > self.seconds - 0.5 / self.fps:
                    self._span_reached = True  # n pairs span n - 1 periods: this one would be pair n + 1
                    break
                images = tuple(f[0] for f in frames)
                jpegs = tuple(f[1] for f in frames)
                if self.recorder is not None:
                    if not self.recorder.offer(CapturedPair(self._formed, timestamps, images, jpegs)):
                        self._not_recorded += 1  # dropped for everyone: frame numbers stay pair numbers
                        continue
                index = self._formed
                self._formed += 1
                if self._queue_size == 0:
                    continue
                if len(self._queue) >= self._queue_size:
                    self._queue.popleft()  # the consumer is slow: the oldest pair goes, latency stays bounded
                    self._pairs_dropped += 1
                    for i in range(len(self._dropped)):
                        self._dropped[i] += 1
                self._queue.append((index, timestamps, images, jpegs))
            self._cond.notify_all()

    def _wake(self) -> None:
        with self._cond:
            self._cond.notify_all()

    def request_stop(self) -> None:
        """Make iteration end at the next wait (safe to call from a signal handler)."""
        self._stop_requested = True

    def __iter__(self) -> Iterator[FramePair]:
        return self

    @property
    def stopping(self) -> bool:
        """Asked to stop (``request_stop``, or a stop signal in any StopOnSignals block: a signal always reaches it)."""
        return self._stop_requested or self._closed or stop_requested()

    def __next__(self) -> FramePair:
        while True:
            if self.stopping:
                raise StopIteration
            with self._cond:
                item = self._queue.popleft() if self._queue else None
                if item is None:
                    self._cond.wait(0.05)
            if item is not None:
                self._pairs += 1
                return self._decode(*item)
            self._check()

    def _decode(self, index: int, timestamps, images, jpegs) -> FramePair:
        """JPEGs decoded in parallel (OpenCV releases the GIL); the same decoder a replay uses."""
        todo = [self._decoder.submit(decode_jpeg, j) if img is None else None for img, j in zip(images, jpegs)]
        out = []
        for slot, (img, job) in enumerate(zip(images, todo)):
            img = job.result() if job is not None else img
            if img is None:
                raise StereotrackError(f"camera {self.camera_names[slot]} sent a corrupt JPEG frame")
            out.append(img)
        return FramePair(index=index, images=tuple(out), timestamps=timestamps)

    def wait(self, timeout: float = 0.1) -> bool:
        """For consumers that take no pairs (``record``): wait a little; False once the source has ended."""
        if self.stopping:
            return False
        with self._cond:
            self._cond.wait(timeout)
        try:
            self._check()
        except StopIteration:
            return False
        return not (self.stopping or self._span_reached)

    def _check(self) -> None:
        """Raise a camera's or the recorder's error; StopIteration when the source has ended."""
        if self.recorder is not None:
            self.recorder.check()
        if self._span_reached:
            raise StopIteration
        now = self.clock()
        for th in self._threads:
            name = self.camera_names[th.slot]
            if th.error:
                raise StereotrackError(th.error)
            if th.ended:
                raise StopIteration  # a video file ended: no more pairs can form
            if th.last_seen is None:
                if now - self._started > self.start_timeout:
                    raise StereotrackError(
                        f"camera {name} ({describe(th.spec)}) delivered no frame in {self.start_timeout:.0f} s (check the device and its settings)"
                    )
            elif now - th.last_seen > self.stall_timeout:
                raise StereotrackError(
                    f"camera {name} ({describe(th.spec)}) delivered no frame for {self.stall_timeout:.1f} s (unplugged or stalled?)"
                )

    @property
    def stats(self) -> SourceStats:
        with self._cond:
            cams = tuple(
                CameraStats(
                    self.camera_names[th.slot], th.spec, th.frames, th.fps(), self._dropped[th.slot], self._pairer.unpaired[th.slot]
                )
                for th in self._threads
            )
            return SourceStats(cams, self._pairs, self._pairs_dropped, self._formed, self._not_recorded)

    def close(self, timeout: float = 2.0) -> None:
        """Stop the capture threads and wait for them: each releases its own device as it ends.

        A thread still stuck in a driver call after ``timeout`` keeps its device (released
        when the process ends): releasing a device another thread is reading crashes FFmpeg.
        """
        if self._closed:
            return
        self._closed = True
        for th in self._threads:
            th.stop.set()
            interrupt = getattr(th.device, "interrupt", None)
            if interrupt is not None:
                interrupt()  # e.g. a simulated camera hanging like an unplugged webcam
        deadline = time.monotonic() + timeout
        for th in self._threads:
            # a file always returns from a grab (a webcam's driver may not): give it longer on a starved machine
            extra = 8.0 if getattr(th.device, "finite", False) else 0.0
            th.join(max(0.0, deadline - time.monotonic() + extra))
            if th.is_alive():
                warn(
                    f"camera {self.camera_names[th.slot]} ({describe(th.spec)}) did not stop within {timeout + extra:g} s "
                    "(stuck in its driver); it is released when the program ends"
                )
        self._decoder.shutdown(wait=True, cancel_futures=True)  # a decode is one imdecode: bounded

    def __enter__(self) -> CameraPairSource:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _check_sizes(devices: Sequence[VideoDevice], names: Sequence[str], specs: Sequence[str], rig: Rig | None) -> None:
    """Cameras of different image sizes, or of another size than their calibration: say so before starting."""
    sizes = [(int(d.get(cv2.CAP_PROP_FRAME_WIDTH)), int(d.get(cv2.CAP_PROP_FRAME_HEIGHT))) for d in devices]
    known = [(n, s, spec) for n, s, spec in zip(names, sizes, specs) if s[0] > 0 and s[1] > 0]
    if rig is not None:
        for cam, (n, s, spec) in zip(rig.cameras, zip(names, sizes, specs)):
            if s[0] > 0 and s[1] > 0 and tuple(cam.image_size) != s:
                raise StereotrackError(
                    f"calibration camera {cam.name} is {cam.width}x{cam.height} but camera {n} ({describe(spec)}) delivers {s[0]}x{s[1]} "
                    f"(record at the calibrated size: --width {cam.width} --height {cam.height})"
                )
    for n, s, spec in known[1:]:
        if s != known[0][1]:
            n0, s0, spec0 = known[0]
            raise StereotrackError(
                f"camera {n} ({describe(spec)}) delivers {s[0]}x{s[1]} frames but {n0} ({describe(spec0)}) {s0[0]}x{s0[1]}: "
                f"use cameras (or video files) of one size (--width/--height for webcams)"
            )
