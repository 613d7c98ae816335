"""Capture: frame-pair sources (live cameras paired by capture time, recordings replayed) and clean stopping.

- ``devices.py``: webcams, video files and simulated cameras behind one device interface.
- ``cameras.py``: one thread per camera, frames paired by timestamp (``CameraPairSource``).
- ``replay.py``: a recording as a source, optionally at its recorded pace.
- ``signals.py``: SIGINT / SIGTERM end the loop cleanly.

The names below load on first use: ``stereotrack`` imports ``capture.signals`` before
anything slow (OpenCV, numpy), so a signal in a command's first moments is handled too.
"""

from __future__ import annotations

import importlib

_WHERE = {
    "CameraPairSource": "cameras",
    "CameraStats": "..frames",
    "Pairer": "cameras",
    "SourceStats": "..frames",
    "RecordingSource": "replay",
    "paced": "replay",
    "StopOnSignals": "signals",
}

__all__ = sorted(_WHERE)


def __getattr__(name: str):
    if name in _WHERE:
        where = _WHERE[name]
        return getattr(importlib.import_module(where if where.startswith(".") else f".{where}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
