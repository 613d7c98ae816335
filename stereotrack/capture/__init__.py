"""Capture: frame-pair sources (live cameras paired by capture time, recordings replayed) and clean stopping.

- ``devices.py``: webcams, video files and simulated cameras behind one device interface.
- ``cameras.py``: one thread per camera, frames paired by timestamp (``CameraPairSource``).
- ``replay.py``: a recording as a source, optionally at its recorded pace.
- ``signals.py``: SIGINT / SIGTERM end the loop cleanly.
"""

from ..frames import CameraStats, SourceStats
from .cameras import CameraPairSource, Pairer
from .replay import RecordingSource, paced
from .signals import StopOnSignals

__all__ = ["CameraPairSource", "CameraStats", "Pairer", "RecordingSource", "SourceStats", "StopOnSignals", "paced"]
