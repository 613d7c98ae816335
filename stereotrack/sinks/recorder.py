"""Recording frame pairs as cameras deliver them, in a writer thread (``record``, ``live --record``).

The capture side offers every pair as it forms (``offer``: never blocks). A
writer thread writes the pairs in order to a ``RecordingWriter``; JPEGs that a
camera sent are stored as they are. A pair offered while the queue is full
(the disk is too slow) is refused, and the source then drops that pair for
every consumer, so the recording's frame numbers are the source's pair numbers
and the live tracker's frames can be replayed exactly (``TrackedFramesSink``).
"""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ..camera import Rig
from ..capture.cameras import CapturedPair
from ..console import warn
from ..errors import StereotrackError
from ..frames import FramePair
from ..recording import RecordingWriter

STALL_SECONDS = 10.0  # close() gives up on a writer thread that wrote nothing for this long


class RecordingSink:
    """Writes offered pairs into a recording folder from a thread of its own.

    The queue holds at most ``buffer_seconds`` of pairs (and ``max_bytes``): a slow
    disk is absorbed for that long. ``close()`` writes what is queued, then closes
    the files; call it after the source has stopped.
    """

    def __init__(
        self,
        folder: str | Path,
        camera_names: Sequence[str],
        fps: float,
        rig: Rig | None = None,
        buffer_seconds: float = 2.0,
        max_bytes: int = 512 << 20,
        **writer_options: Any,
    ):
        import av  # noqa: F401  (loaded here, on the command's thread: the writer thread imports nothing, and a stop
        # signal that lands inside an import on the main thread cannot leave it waiting on the import lock)

        self.folder = Path(folder)
        self.camera_names = list(camera_names)
        self.fps = float(fps)
        self.rig = rig
        self.writer_options = writer_options
        self.codec = writer_options.get("codec", "mjpg")

        self.writer: RecordingWriter | None = None
        self.error: BaseException | None = None
        self.refused = 0
        self._max_pairs = max(4, round(buffer_seconds * self.fps))
        self._max_bytes = int(max_bytes)
        self._queued_bytes = 0
        self._queue: deque[CapturedPair] = deque()
        self._cond = threading.Condition()
        self._closing = False
        self._thread: threading.Thread | None = None
        self._marks: deque[int] = deque()  # frames the live tracker stepped, for tracked.csv
        self._marks_file = None

    @property
    def count(self) -> int:
        """Pairs written so far."""
        return self.writer.count if self.writer else 0

    # ------------------------------------------------------------------ capture side

    def offer(self, pair: CapturedPair) -> bool:
        """Queue a pair for writing; False (refused) when the queue is full or the writer failed."""
        with self._cond:
            if self._closing or self.error is not None:
                return False
            if len(self._queue) >= self._max_pairs or self._queued_bytes + pair.nbytes > self._max_bytes:
                self.refused += 1
                return False
            self._queue.append(pair)
            self._queued_bytes += pair.nbytes
            if self._thread is None:
                self._thread = threading.Thread(target=self._run, name="recorder", daemon=True)
                self._thread.start()
            self._cond.notify()
            return True

    def mark_tracked(self, index: int) -> None:
        """Note that the live tracker stepped pair ``index`` (written to tracked.csv by the writer thread)."""
        with self._cond:
            self._marks.append(int(index))
            self._cond.notify()

    def check(self) -> None:
        """Raise the writer thread's error, if any, in the caller's thread."""
        if self.error is not None:
            if isinstance(self.error, StereotrackError):
                raise self.error
            raise StereotrackError(f"recording into {self.folder} failed: {self.error}")

    # ------------------------------------------------------------------ writer thread

    def _run(self) -> None:
        while True:
            with self._cond:
                while not self._queue and not self._closing:
                    self._cond.wait()
                if not self._queue:
                    return
                pair = self._queue.popleft()
                self._queued_bytes -= pair.nbytes
            try:
                self._write(pair)
                self._write_marks()
            except BaseException as exc:  # reported to the main thread by check()
                with self._cond:
                    self.error = exc
                    self._queue.clear()
                return

    def _write(self, pair: CapturedPair) -> None:
        if self.writer is None:
            self.writer = self._open(pair.size())
        self.writer.write(pair.images, pair.timestamps, pair.jpegs)

    def _write_marks(self) -> None:
        if self.writer is None:
            return
        with self._cond:
            marks = list(self._marks)
            self._marks.clear()
        if not marks:
            return
        if self._marks_file is None:
            self._marks_file = open(self.folder / "tracked.csv", "w", newline="")
            self._marks_file.write("frame\n")
        self._marks_file.write("".join(f"{m}\n" for m in marks))
        self._marks_file.flush()

    def _open(self, size: tuple[int, int]) -> RecordingWriter:
        w, h = size
        if self.rig is not None:
            for cam in self.rig.cameras:
                if tuple(cam.image_size) != (w, h):
                    raise StereotrackError(
                        f"calibration camera {cam.name} is {cam.width}x{cam.height} but the cameras deliver {w}x{h} (record at the calibrated size)"
                    )
        return RecordingWriter(self.folder, self.camera_names, (w, h), self.fps, rig=self.rig, **self.writer_options)

    # ------------------------------------------------------------------ pipeline-sink use

    def write(self, result: Any) -> None:
        """As a pipeline sink: record the pair a FrameResult was made from (synchronously)."""
        self.write_pair(result.frame)

    def write_pair(self, pair: FramePair) -> None:
        h, w = pair.images[0].shape[:2]
        for name, img in zip(self.camera_names, pair.images):
            if img.shape[:2] != (h, w):
                raise StereotrackError(
                    f"camera {name} delivers {img.shape[1]}x{img.shape[0]} frames but {self.camera_names[0]} {w}x{h}: set one size for all (--width/--height)"
                )
        if self.writer is None:
            self.writer = self._open((w, h))
        self.writer.write(pair.images, pair.timestamps)

    def close(self, stall_seconds: float = STALL_SECONDS) -> None:
        """Write what is queued, then close the files (after the source has stopped).

        Waits as long as the writer makes progress; one that wrote nothing for ``stall_seconds``
        (a disk that stopped answering) is left behind with one line: every row already in
        frames.csv has its frames, so the folder opens as it is.
        """
        with self._cond:
            self._closing = True
            self._cond.notify_all()
            thread = self._thread
        if thread is not None:
            written, since = self.count, time.monotonic()
            while thread.is_alive():
                thread.join(0.2)
                if self.count != written:
                    written, since = self.count, time.monotonic()
                elif time.monotonic() - since > stall_seconds:
                    warn(
                        f"recording into {self.folder}: the writer wrote nothing for {stall_seconds:g} s (disk not answering?); "
                        f"stopped waiting with {len(self._queue)} pairs unwritten, the {self.count} written are kept"
                    )
                    return
        if self.writer is not None:
            self._write_marks()
            if self._marks_file is not None:
                self._marks_file.close()
            self.writer.close()


class TrackedFramesSink:
    """A pipeline sink for ``live --record``: tells the recorder which pairs the tracker stepped
    (tracked.csv, formats.md section 2), so ``track`` can replay exactly those frames."""

    def __init__(self, recorder: RecordingSink):
        self.recorder = recorder

    def write(self, result: Any) -> None:
        self.recorder.mark_tracked(result.frame.index)

    def close(self) -> None:
        pass
