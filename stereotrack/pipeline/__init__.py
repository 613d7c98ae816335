"""The pipeline: the stages wired into a tracker, and a source run through it into sinks.

- ``tracker.py``: ``Tracker.step``: one frame pair -> one FrameResult.
- ``baseline.py``: the classic OpenCV pipeline, a peer of the particle tracker.
- ``run.py``: ``run_pipeline``: source -> tracker -> sinks.
"""

from .run import RunSummary, run_pipeline
from .tracker import Tracker

__all__ = ["RunSummary", "Tracker", "run_pipeline"]
