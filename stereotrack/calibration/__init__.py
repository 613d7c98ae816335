"""Rig calibration from board views: collect views, calibrate, judge the result.

- ``boards.py``: board definitions, detection, printable boards.
- ``views.py``: one image per camera for each moment the board was held still.
- ``solve.py``: starts per camera and per pair, then the joint fit.
- ``bundle.py``: the joint fit of every camera's lens and pose and every board pose.
- ``measures.py``: the options and intrinsics, board points and poses, residuals.
- ``report.py``: residuals, baselines, coverage and a verdict in plain words.
- ``annotate.py``: the views drawn with their corners and residuals (PNGs).
"""

from .boards import MIN_CORNERS
from .measures import CalibrationOptions, Intrinsics, epipolar_errors
from .report import format_report, report_path, save_report
from .solve import Calibration, calibrate, calibrate_intrinsics
from .views import IMAGE_SUFFIXES, MIN_VIEWS, RECOMMENDED_VIEWS, ViewSet, coverage, match_image_files, views_from_frames, views_from_images

__all__ = [
    "IMAGE_SUFFIXES", "MIN_CORNERS", "MIN_VIEWS", "RECOMMENDED_VIEWS", "Calibration", "CalibrationOptions", "Intrinsics", "ViewSet",
    "calibrate", "calibrate_intrinsics", "coverage", "epipolar_errors", "format_report", "match_image_files", "report_path",
    "save_report", "views_from_frames", "views_from_images",
]  # fmt: skip
