"""Video devices behind the ``cv2.VideoCapture`` interface: webcams, video files, simulated cameras.

A device is anything with ``isOpened, read, grab, retrieve, set, get, release``
(OpenCV's own interface), so the capture threads in ``cameras.py`` cannot tell
a USB webcam from a file played at its real rate or a rendered scene.

Device specs on the command line (``--cam0 SPEC``):

- ``0``, ``2``, ...: a webcam by OpenCV index (V4L2 on Linux: index N is /dev/videoN)
- ``/path/video.mkv``: a video file, played at its own frame rate (ends at its end)
- ``sim:PRESET[,key=value...]``: a simulated camera viewing a synthetic scene
  (``stereotrack synth --list`` names the presets; ``sim:dots`` is a cheap test
  pattern). Keys: ``view`` (camera of the scene's rig, default: the slot, so
  ``--cam0 sim:pendulum4 --cam1 sim:pendulum4`` is a stereo pair), ``jitter``
  (timestamp jitter s.d., seconds, default 0.002), ``drop`` (probability that
  the device loses a frame, default 0.01), ``stop`` (seconds after which the
  camera hangs, like an unplugged webcam), ``seed`` (default: the slot),
  ``loop`` (render that many seconds up front and loop them: a camera that
  costs no CPU, for benchmarks). Asked for MJPG (``--fourcc MJPG``, the
  default), a simulated camera sends JPEGs (quality 90) as a webcam does.
"""

from __future__ import annotations

import math
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import cv2
import numpy as np

from ..errors import StereotrackError


class VideoDevice(Protocol):
    """The subset of ``cv2.VideoCapture`` the capture threads use."""

    def isOpened(self) -> bool: ...
    def read(self) -> tuple[bool, np.ndarray | None]: ...
    def grab(self) -> bool: ...
    def retrieve(self) -> tuple[bool, np.ndarray | None]: ...
    def set(self, prop: int, value: float) -> bool: ...
    def get(self, prop: int) -> float: ...
    def release(self) -> None: ...


@dataclass(frozen=True)
class CaptureSettings:
    """What to ask of each camera. Set by command-line flags only (a rig's cameras differ per machine).

    None means "leave the device's own setting". Manual exposure, gain and white
    balance matter for tracking: auto exposure shifts colours from frame to
    frame and moves balls out of their HSV range.
    """

    width: int | None = 640
    height: int | None = 480
    fps: float | None = 30.0
    fourcc: str | None = "MJPG"  # MJPG lets two USB 2 webcams share one bus
    exposure: float | None = None  # manual exposure, device units (V4L2: 100 µs steps); turns auto exposure off
    gain: float | None = None
    white_balance: float | None = None  # Kelvin; turns auto white balance off


# --------------------------------------------------------------------------- simulated camera


class _StandInScene:
    """A cheap moving-dots pattern: used for ``sim:dots`` (fast tests) and when no renderer exists."""

    n_frames = 1 << 30

    def __init__(self, width: int, height: int, fps: float, n_views: int = 4):
        self.width, self.height, self.fps, self.n_views = width, height, fps, n_views
        yy, xx = np.mgrid[0:height, 0:width]
        self._background = (60 + 40 * (xx / width) + 20 * (yy / height)).astype(np.uint8)

    def render(self, frame_index: int) -> tuple[tuple[np.ndarray, ...], list]:
        t = frame_index / self.fps
        images = []
        for view in range(self.n_views):
            img = cv2.merge([self._background] * 3)
            for k, colour in enumerate(((180, 60, 230), (60, 200, 60))):
                cx = self.width * (0.5 + 0.3 * np.cos(2 * np.pi * (0.25 + 0.1 * k) * t + k)) - 6 * view
                cy = self.height * (0.5 + 0.3 * np.sin(2 * np.pi * 0.2 * t + k))
                cv2.circle(img, (int(cx), int(cy)), max(3, self.width // 40), colour, -1)
            # the frame number in the corner, so a test can read which frame a video holds
            cv2.putText(img, str(frame_index), (4, self.height - 6), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (255, 255, 255), 1)
            images.append(img)
        return tuple(images), []


JPEG_QUALITY = 90  # what a simulated camera in MJPG mode sends (webcams send 80-95)


class _SharedScene:
    """One scene rendered once per frame for every simulated camera that views it.

    Frames are kept as the cameras send them (images, or JPEGs in MJPG mode).
    Without ``loop`` only the last few frames are kept (the views of one frame
    are taken within moments of each other), by render order, so memory stays
    flat however often the cameras run through the scene.
    """

    _registry: dict[tuple, _SharedScene] = {}
    _registry_lock = threading.Lock()
    KEEP = 8  # frames kept without loop

    def __init__(self, preset: str, width: int, height: int, fps: float, loop: float | None = None, jpeg: bool = False):
        self.preset = preset
        self.jpeg = jpeg
        self.renderer = _make_renderer(preset, width, height, fps)
        self.n_frames = int(getattr(self.renderer, "n_frames", 0) or 1 << 30)
        self._lock = threading.Lock()
        self._cache: dict[int, tuple] = {}  # insertion order is render order: the oldest go first
        self._keep_all = loop is not None
        if loop is not None:
            # Render the first seconds up front and loop them: the camera then costs no CPU,
            # like a real webcam, so benchmarks measure the tracker, not the renderer.
            self.n_frames = max(1, min(self.n_frames, round(loop * fps)))
            for k in range(self.n_frames):
                self._cache[k] = self._render(k)
        else:
            # The first frame also loads the compiled projection (kernels.py): a real camera is warm
            # when opened, so take that one-off second here, before any camera's clock starts.
            self._cache[0] = self._render(0)

    def _render(self, k: int) -> tuple:
        images = self.renderer.render(k)[0]
        if self.jpeg:
            from ..recording import encode_jpeg

            return tuple(encode_jpeg(img, JPEG_QUALITY) for img in images)
        return tuple(images)

    @classmethod
    def get(cls, preset: str, width: int, height: int, fps: float, loop: float | None = None, jpeg: bool = False) -> _SharedScene:
        key = (preset, width, height, fps, loop, jpeg)
        with cls._registry_lock:
            if key not in cls._registry:
                cls._registry[key] = cls(preset, width, height, fps, loop, jpeg)
            return cls._registry[key]

    def frame(self, frame_index: int, view: int):
        """The view's image (JPEG bytes in MJPG mode) of a frame; shared: do not modify."""
        k = frame_index % self.n_frames  # scenes are finite; a camera runs for ever
        with self._lock:
            frames = self._cache.get(k)
            if frames is None:
                frames = self._render(k)
                self._cache[k] = frames
                while not self._keep_all and len(self._cache) > self.KEEP:
                    del self._cache[next(iter(self._cache))]
        if view >= len(frames):
            raise StereotrackError(
                f"sim:{self.preset} has {len(frames)} cameras; view={view} does not exist (use view=0..{len(frames) - 1})"
            )
        return frames[view]


def _make_renderer(preset: str, width: int, height: int, fps: float):
    if preset == "dots":
        return _StandInScene(width, height, fps)
    try:
        from .. import simulation as synth
    except ImportError:
        return _StandInScene(width, height, fps)
    try:
        spec = synth.make_preset(preset, width=width, height=height, fps=fps)
    except StereotrackError:
        raise
    except Exception as exc:
        raise StereotrackError(f"sim:{preset}: cannot build this scene ({exc}); see `stereotrack synth --list`") from None
    return synth.SceneRenderer(spec)


class SimulatedCamera:
    """A fake webcam: frames of a synthetic scene at a nominal fps, with jitter and lost frames.

    ``grab`` blocks until the next frame is due (like a real device), skipping
    frames the host was too slow to take (a real camera overwrites its buffer);
    ``retrieve`` renders it. With ``stop_after`` the camera hangs after that
    many seconds, like an unplugged webcam whose ``read`` never returns
    (``interrupt()`` ends the hang). Set to MJPG (CAP_PROP_FOURCC) it sends
    JPEGs: decoded by ``retrieve``, or as the raw byte buffer when
    CAP_PROP_CONVERT_RGB is 0, as OpenCV's V4L2 backend does for webcams.
    """

    finite = False

    def __init__(
        self,
        preset: str = "dots",
        view: int = 0,
        jitter: float = 0.002,
        drop: float = 0.01,
        stop_after: float | None = None,
        seed: int = 0,
        width: int = 640,
        height: int = 480,
        fps: float = 30.0,
        loop: float | None = None,
    ):
        self.preset, self.view, self.loop = preset, int(view), loop
        self.jitter, self.drop, self.stop_after = float(jitter), float(drop), stop_after
        self._props = {cv2.CAP_PROP_FRAME_WIDTH: float(width), cv2.CAP_PROP_FRAME_HEIGHT: float(height), cv2.CAP_PROP_FPS: float(fps)}
        self._rng = np.random.default_rng(seed)
        self._scene: _SharedScene | None = None
        self._start: float | None = None
        self._next = 0
        self._grabbed: int | None = None
        self._grab_time = 0.0
        self._released = threading.Event()
        self._props[cv2.CAP_PROP_CONVERT_RGB] = 1.0

    def isOpened(self) -> bool:
        return not self._released.is_set()

    def set(self, prop: int, value: float) -> bool:
        if prop in (cv2.CAP_PROP_FRAME_WIDTH, cv2.CAP_PROP_FRAME_HEIGHT, cv2.CAP_PROP_FPS) and self._scene is None:
            self._props[prop] = float(value)
            return True
        if prop in (cv2.CAP_PROP_FOURCC, cv2.CAP_PROP_CONVERT_RGB) and self._scene is not None:
            return False  # fixed once the scene is built, like a streaming webcam's format
        if prop in (
            cv2.CAP_PROP_FOURCC,
            cv2.CAP_PROP_CONVERT_RGB,
            cv2.CAP_PROP_EXPOSURE,
            cv2.CAP_PROP_AUTO_EXPOSURE,
            cv2.CAP_PROP_GAIN,
            cv2.CAP_PROP_AUTO_WB,
            cv2.CAP_PROP_WB_TEMPERATURE,
            cv2.CAP_PROP_BUFFERSIZE,
        ):
            self._props[prop] = float(value)
            return True
        return False

    def get(self, prop: int) -> float:
        if prop == cv2.CAP_PROP_POS_MSEC:
            return self._grab_time * 1000.0  # like V4L2's buffer timestamp: when the frame was taken
        return float(self._props.get(prop, 0.0))

    @property
    def fps(self) -> float:
        return self._props[cv2.CAP_PROP_FPS]

    @property
    def sends_jpeg(self) -> bool:
        return int(self._props.get(cv2.CAP_PROP_FOURCC, 0)) == cv2.VideoWriter_fourcc(*"MJPG")

    def prepare(self) -> None:
        """Build (and with ``loop``, pre-render) the scene now, before the clock starts; size and fps are then fixed."""
        if self._scene is None:
            w, h = int(self._props[cv2.CAP_PROP_FRAME_WIDTH]), int(self._props[cv2.CAP_PROP_FRAME_HEIGHT])
            self._scene = _SharedScene.get(self.preset, w, h, self.fps, self.loop, self.sends_jpeg)

    def start_at(self, t: float) -> None:
        """Frame 0 is due at ``t`` (time.monotonic): the cameras of one rig share one clock, so
        frame k of each view is one moment of the scene however late each thread starts."""
        self._start = t

    def grab(self) -> bool:
        if self._released.is_set():
            return False
        if self._scene is None:
            self.prepare()
        if self._start is None:
            self._start = time.monotonic()
        period = 1.0 / self.fps
        while True:
            k = self._next
            self._next += 1
            # draw both numbers every frame so the stream of choices does not depend on timing
            lost = self._rng.random() < self.drop
            offset = float(np.clip(self._rng.normal(0.0, self.jitter), -0.4 * period, 0.4 * period))
            if lost:
                continue
            due = self._start + k * period + offset
            if self.stop_after is not None and k * period >= self.stop_after:
                self._released.wait()  # unplugged: hang until someone gives up on us
                return False
            now = time.monotonic()
            if due > now:
                time.sleep(due - now)
            elif now - due > period:
                continue  # the host was too slow: this frame was overwritten in the device
            self._grabbed = k
            self._grab_time = due
            return True

    def retrieve(self) -> tuple[bool, np.ndarray | None]:
        if self._grabbed is None or self._scene is None:
            return False, None
        frame = self._scene.frame(self._grabbed, self.view)
        if not self._scene.jpeg:
            return True, frame.copy()
        if self._props[cv2.CAP_PROP_CONVERT_RGB]:
            from ..recording import decode_jpeg

            return True, decode_jpeg(frame)
        return True, np.frombuffer(frame, np.uint8).reshape(1, -1).copy()

    def read(self) -> tuple[bool, np.ndarray | None]:
        return self.retrieve() if self.grab() else (False, None)

    def interrupt(self) -> None:
        """End a hang (``stop``): the current or next ``grab`` returns False."""
        self._released.set()

    def release(self) -> None:
        self._released.set()


# --------------------------------------------------------------------------- video file at its real rate


class VideoFileCamera:
    """A video file that delivers its frames at the file's frame rate, as a camera would.

    Each frame is stamped with the moment it was due (CAP_PROP_POS_MSEC, on the
    monotonic clock, like a webcam's buffer timestamp), and a frame more than
    ``BUFFERED`` periods late is skipped, as a camera's driver overwrites frames
    nobody took: two files played together stay in step however busy the host is.
    Files of one source share their start (``start_at``), so frame k of each is due
    at the same moment and only frames of one index can pair, whenever each thread
    first ran; the stamp is the due time however late the frame is delivered.
    """

    BUFFERED = 2  # frames a webcam's driver holds (open_webcam asks for 2 buffers)

    finite = True  # its end is the end of the input, not an unplugged camera
    exact_time = True  # CAP_PROP_POS_MSEC is the frame's due time on time.monotonic, however late it is read

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self._cap = cv2.VideoCapture(str(self.path))
        self._fps = self._cap.get(cv2.CAP_PROP_FPS) or 30.0
        self._start: float | None = None
        self._k = 0
        self.skipped = 0  # frames skipped because the host took them too late
        self._due = 0.0
        self._interrupted = threading.Event()

    def isOpened(self) -> bool:
        return self._cap.isOpened()

    def set(self, prop: int, value: float) -> bool:
        return False  # a file's size and rate are what they are

    def get(self, prop: int) -> float:
        if prop == cv2.CAP_PROP_POS_MSEC:
            return self._due * 1000.0  # when the frame was due: the capture time a camera would report
        return self._fps if prop == cv2.CAP_PROP_FPS else self._cap.get(prop)

    def start_at(self, t: float) -> None:
        """Frame 0 is due at ``t`` (time.monotonic); by default, when it is first grabbed."""
        self._start = t

    def grab(self) -> bool:
        now = time.monotonic()
        if self._start is None:
            self._start = now
        period = 1.0 / self._fps
        # Late by more than the driver's buffers: those frames were overwritten. At most that many go per
        # frame delivered, so a host that decodes slower than the frame rate still gets frames, not the end.
        for _ in range(self.BUFFERED):
            if time.monotonic() - (self._start + self._k * period) <= self.BUFFERED * period:
                break
            if self._interrupted.is_set() or not self._cap.grab():
                return False
            self._k += 1
            self.skipped += 1
        due = self._start + self._k * period
        if due > now and self._interrupted.wait(due - now):
            return False
        self._k += 1
        self._due = due
        return self._cap.grab()

    def retrieve(self) -> tuple[bool, np.ndarray | None]:
        return self._cap.retrieve()

    def read(self) -> tuple[bool, np.ndarray | None]:
        return self.retrieve() if self.grab() else (False, None)

    def interrupt(self) -> None:
        """Make the current or next ``grab`` return False at once (the capture thread is stopping)."""
        self._interrupted.set()

    def release(self) -> None:
        self._cap.release()


# --------------------------------------------------------------------------- opening a spec


def _parse_sim(spec: str, slot: int) -> dict[str, Any]:
    body = spec[len("sim:") :]
    preset, *options = body.split(",")
    if not preset:
        raise StereotrackError(f"{spec!r}: name a scene after 'sim:', e.g. sim:pendulum4 (see `stereotrack synth --list`)")
    kwargs: dict[str, Any] = {"preset": preset, "view": slot, "seed": slot}
    casts = {
        "view": ("view", int),
        "jitter": ("jitter", float),
        "drop": ("drop", float),
        "stop": ("stop_after", float),
        "seed": ("seed", int),
        "loop": ("loop", float),
    }
    for opt in options:
        key, _, value = opt.partition("=")
        if key not in casts:
            raise StereotrackError(f"{spec!r}: unknown option {key!r} (options: {', '.join(casts)})")
        name, cast = casts[key]
        try:
            kwargs[name] = cast(value)
        except ValueError:
            raise StereotrackError(f"{spec!r}: option {key} needs a {cast.__name__}, got {value!r}") from None
    limits = {"view": (0, 63), "jitter": (0, 1), "drop": (0, 0.999), "stop_after": (0, 1e6), "seed": (0, 2**32 - 1), "loop": (0.001, 10)}
    option = {name: key for key, (name, _) in casts.items()}
    for name, (lo, hi) in limits.items():
        value = kwargs.get(name)
        if value is not None and not (math.isfinite(value) and lo <= value <= hi):
            what = "a probability" if name == "drop" else "a number"
            raise StereotrackError(f"{spec!r}: option {option[name]} must be {what} from {lo:g} to {hi:g}, got {value!r}")
    return kwargs


def describe(spec: str) -> str:
    """A short human description of a device spec for messages."""
    return f"device {spec}" if spec.isdigit() else spec


def open_device(spec: str, slot: int = 0, settings: CaptureSettings = CaptureSettings()) -> VideoDevice:
    """Open a device spec (see the module docstring) and apply the capture settings."""
    spec = str(spec).strip()
    if spec.startswith("sim:"):
        kwargs = _parse_sim(spec, slot)
        cam = SimulatedCamera(**kwargs)
        if settings.width:
            cam.set(cv2.CAP_PROP_FRAME_WIDTH, settings.width)
        if settings.height:
            cam.set(cv2.CAP_PROP_FRAME_HEIGHT, settings.height)
        if settings.fps:
            cam.set(cv2.CAP_PROP_FPS, settings.fps)
        if settings.fourcc:
            cam.set(cv2.CAP_PROP_FOURCC, cv2.VideoWriter_fourcc(*settings.fourcc[:4].ljust(4)))
            cam.set(cv2.CAP_PROP_CONVERT_RGB, 0)  # the JPEGs undecoded, as open_webcam asks of webcams
        cam.prepare()
        return cam
    if spec.lstrip("-").isdigit():
        return open_webcam(int(spec), settings)
    path = Path(spec)
    if not path.is_file():
        raise StereotrackError(
            f"camera {spec!r}: not a device index, an existing video file or sim:SCENE (run `stereotrack cameras` to list devices)"
        )
    cam = VideoFileCamera(path)
    if not cam.isOpened():
        raise StereotrackError(f"{path}: OpenCV cannot open this video")
    return cam


def open_webcam(index: int, settings: CaptureSettings = CaptureSettings(), quiet: bool = False) -> cv2.VideoCapture:
    """A real webcam by index (V4L2 on Linux), configured; raises StereotrackError if it does not open."""
    backend = cv2.CAP_V4L2 if sys.platform.startswith("linux") else cv2.CAP_ANY
    cap = cv2.VideoCapture(index, backend)
    if not cap.isOpened():
        cap.release()
        raise StereotrackError(f"cannot open camera {index} (run `stereotrack cameras` to list the devices OpenCV can open)")
    # Order matters on V4L2: pixel format before size, size before rate.
    if settings.fourcc:
        cap.set(cv2.CAP_PROP_FOURCC, cv2.VideoWriter_fourcc(*settings.fourcc[:4].ljust(4)))
    if settings.width:
        cap.set(cv2.CAP_PROP_FRAME_WIDTH, settings.width)
    if settings.height:
        cap.set(cv2.CAP_PROP_FRAME_HEIGHT, settings.height)
    if settings.fps:
        cap.set(cv2.CAP_PROP_FPS, settings.fps)
    cap.set(cv2.CAP_PROP_BUFFERSIZE, 2)  # few buffers in the driver: old frames never queue up there
    if settings.exposure is not None:
        cap.set(cv2.CAP_PROP_AUTO_EXPOSURE, 1)  # V4L2: 1 = manual, 3 = aperture-priority auto
        cap.set(cv2.CAP_PROP_EXPOSURE, settings.exposure)
    if settings.gain is not None:
        cap.set(cv2.CAP_PROP_GAIN, settings.gain)
    if settings.white_balance is not None:
        cap.set(cv2.CAP_PROP_AUTO_WB, 0)
        cap.set(cv2.CAP_PROP_WB_TEMPERATURE, settings.white_balance)
    if fourcc_text(cap.get(cv2.CAP_PROP_FOURCC)) == "MJPG":
        # The JPEGs as the camera sent them (OpenCV's V4L2 backend then returns the raw buffer):
        # a recording stores them as they are, and only the frames tracked are decoded.
        cap.set(cv2.CAP_PROP_CONVERT_RGB, 0)
    return cap


def fourcc_text(value: float) -> str:
    """CAP_PROP_FOURCC as text ('MJPG', 'YUYV'); '' when the device does not say."""
    code = int(value)
    text = "".join(chr((code >> (8 * i)) & 0xFF) for i in range(4))
    return text if text.isprintable() and code else ""
