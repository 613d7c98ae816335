"""A pipeline sink that records the frame pairs it sees as a recording folder (``live --record DIR``)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ..camera import Rig
from ..errors import StereotrackError
from ..frames import FramePair
from ..recording import RecordingWriter


class RecordingSink:
    """A pipeline sink that records the raw frame pairs it sees (``live --record DIR``).

    The writer opens at the first pair, when the image size is known. ``write``
    takes a ``FrameResult`` (anything with a ``.frame`` FramePair); ``write_pair``
    takes the pair itself.
    """

    def __init__(self, folder: str | Path, camera_names: Sequence[str], fps: float, rig: Rig | None = None, **writer_options: Any):
        self.folder = Path(folder)
        self.camera_names = list(camera_names)
        self.fps = fps
        self.rig = rig
        self.writer_options = writer_options
        self.writer: RecordingWriter | None = None

    @property
    def count(self) -> int:
        return self.writer.count if self.writer else 0

    def write(self, result: Any) -> None:
        self.write_pair(result.frame)

    def write_pair(self, pair: FramePair) -> None:
        if self.writer is None:
            h, w = pair.images[0].shape[:2]
            for name, img in zip(self.camera_names, pair.images):
                if img.shape[:2] != (h, w):
                    raise StereotrackError(
                        f"camera {name} delivers {img.shape[1]}x{img.shape[0]} frames but "
                        f"{self.camera_names[0]} {w}x{h}: set one size for all (--width/--height)"
                    )
            if self.rig is not None:
                for cam in self.rig.cameras:
                    if tuple(cam.image_size) != (w, h):
                        raise StereotrackError(
                            f"calibration camera {cam.name} is {cam.width}x{cam.height} but the cameras deliver {w}x{h} (record at the calibrated size)"
                        )
            self.writer = RecordingWriter(self.folder, self.camera_names, (w, h), self.fps, rig=self.rig, **self.writer_options)
        self.writer.write(pair.images, pair.timestamps)

    def close(self) -> None:
        if self.writer is not None:
            self.writer.close()
