"""Live cameras as a frame-pair source: one thread per camera, timestamps, pairing.

Every source is an iterable of ``FramePair`` with ``.rig``, ``.fps``,
``.camera_names``, ``.n_frames`` (None when live), ``.stats`` and ``.close()``,
so the tracker never knows whether frames come from webcams or a folder.

Live capture: one thread per camera grabs frames and stamps each with
``time.monotonic()`` right after the grab (or with the device's own capture
time when it reports one on that clock, as V4L2 does: it is not delayed by
a busy interpreter). A ``Pairer`` matches frames whose
timestamps lie within a tolerance (half a frame period by default); a frame
that cannot be matched is dropped and counted, never paired with a stale one.
Pairs wait in a bounded queue: when the consumer is slow the oldest pair is
dropped and counted, so latency cannot grow.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable, Iterator, Sequence

import cv2
import numpy as np

from ..camera import Rig
from ..errors import StereotrackError
from ..frames import CameraStats, FramePair, SourceStats
from .devices import CaptureSettings, VideoDevice, describe, open_device


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


# --------------------------------------------------------------------------- live cameras


class _CameraThread(threading.Thread):
    """Grabs frames from one device, stamps them and hands them to the source."""

    def __init__(self, source: CameraPairSource, slot: int, device: VideoDevice, spec: str):
        super().__init__(name=f"capture-{spec}", daemon=True)  # a hung device must not keep the process alive
        self.source, self.slot, self.device, self.spec = source, slot, device, spec
        self.frames = 0
        self.last_frame: float | None = None
        self.ended = False  # a finite device (file) reached its end
        self.error: str | None = None
        self.recent: deque = deque()  # timestamps of the last two seconds, for fps
        self.stop = threading.Event()

    def run(self) -> None:
        clock = self.source.clock
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
                # clock) is exact, while our stamp waits for the GIL: prefer it when plausible.
                device_time = self.device.get(cv2.CAP_PROP_POS_MSEC) / 1000.0
                if self.source.clock is time.monotonic and stamp - 1.0 < device_time <= stamp:
                    stamp = device_time
                ok, image = self.device.retrieve()
                if not ok or image is None:
                    continue  # a corrupt frame (MJPG decode error): skip it, the next one may be fine
                self.frames += 1
                self.last_frame = stamp
                self.recent.append(stamp)
                while self.recent and stamp - self.recent[0] > 2.0:
                    self.recent.popleft()
                self.source._deliver(self.slot, stamp, image)
        except Exception as exc:  # a driver error: reported by the consumer, not lost in a thread
            self.error = f"camera {self.source.camera_names[self.slot]} ({describe(self.spec)}) failed: {exc}"
        finally:
            self.source._wake()

    def fps(self) -> float:
        r = list(self.recent)
        return (len(r) - 1) / (r[-1] - r[0]) if len(r) > 1 and r[-1] > r[0] else 0.0


class CameraPairSource:
    """Synchronised frame pairs from two or more cameras, as they happen.

    ``devices`` are specs (``"0"``, ``"video.mkv"``, ``"sim:pendulum4"``) or
    already opened ``cv2.VideoCapture``-like objects. ``queue_size`` bounds
    the pairs waiting for the consumer (small for live tracking, larger for
    recording, which can absorb a slow disk for a moment). Iteration raises
    ``StereotrackError`` when a camera delivers nothing for ``stall_timeout``
    seconds (``start_timeout`` for the first frame), and ends when a video
    file ends or ``request_stop()`` was called.
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
    ):
        if len(devices) < 2:
            raise StereotrackError("give at least two cameras (--cam0 and --cam1)")
        self.camera_names = tuple(camera_names or (f"cam{i}" for i in range(len(devices))))
        if rig is not None and len(rig) != len(devices):
            raise StereotrackError(f"the calibration has {len(rig)} cameras but {len(devices)} were given")
        self.rig = rig
        self.clock = clock
        self.n_frames = None
        self.stall_timeout, self.start_timeout = float(stall_timeout), float(start_timeout)
        specs = [d if isinstance(d, str) else type(d).__name__ for d in devices]
        opened: list[VideoDevice] = []
        try:
            for slot, d in enumerate(devices):
                opened.append(open_device(d, slot, settings) if isinstance(d, str) else d)
        except BaseException:
            for dev in opened:
                dev.release()
            raise
        rates = [dev.get(cv2.CAP_PROP_FPS) for dev in opened]
        self.fps = float(settings.fps or max(rates) or 30.0)
        self.tolerance = float(tolerance) if tolerance else 0.5 / self.fps
        self._cond = threading.Condition()
        self._pairer = Pairer(len(opened), self.tolerance)
        self._queue: deque = deque()
        self._queue_size = max(1, int(queue_size))
        self._pairs = 0
        self._pairs_dropped = 0
        self._dropped = [0] * len(opened)
        self._stop_requested = False
        self._closed = False
        self._started = clock()
        self._threads = [_CameraThread(self, i, dev, spec) for i, (dev, spec) in enumerate(zip(opened, specs))]
        for th in self._threads:
            th.start()

    # called from capture threads
    def _deliver(self, slot: int, stamp: float, image: np.ndarray) -> None:
        with self._cond:
            for timestamps, images in self._pairer.push(slot, stamp, image):
                if len(self._queue) >= self._queue_size:
                    self._queue.popleft()  # the consumer is slow: the oldest pair goes, latency stays bounded
                    self._pairs_dropped += 1
                    for i in range(len(self._dropped)):
                        self._dropped[i] += 1
                self._queue.append((timestamps, images))
            self._cond.notify_all()

    def _wake(self) -> None:
        with self._cond:
            self._cond.notify_all()

    def request_stop(self) -> None:
        """Make iteration end at the next wait (safe to call from a signal handler)."""
        self._stop_requested = True

    def __iter__(self) -> Iterator[FramePair]:
        return self

    def __next__(self) -> FramePair:
        while True:
            if self._stop_requested or self._closed:
                raise StopIteration
            with self._cond:
                if self._queue:
                    timestamps, images = self._queue.popleft()
                    index = self._pairs
                    self._pairs += 1
                    return FramePair(index=index, images=images, timestamps=timestamps)
                self._cond.wait(0.05)
                if self._queue:
                    continue
            self._check_cameras()

    def _check_cameras(self) -> None:
        now = self.clock()
        for th in self._threads:
            name = self.camera_names[th.slot]
            if th.error:
                raise StereotrackError(th.error)
            if th.ended:
                raise StopIteration  # a video file ended: no more pairs can form
            if th.last_frame is None:
                if now - self._started > self.start_timeout:
                    raise StereotrackError(
                        f"camera {name} ({describe(th.spec)}) delivered no frame in {self.start_timeout:.0f} s (check the device and its settings)"
                    )
            elif now - th.last_frame > self.stall_timeout:
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
            return SourceStats(cams, self._pairs, self._pairs_dropped)

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        for th in self._threads:
            th.stop.set()
            th.device.release()  # also unblocks a simulated camera that hangs
        for th in self._threads:
            th.join(timeout=0.5)  # a real driver stuck in read() is left to die with the process

    def __enter__(self) -> CameraPairSource:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
