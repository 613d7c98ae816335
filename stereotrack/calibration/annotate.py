"""What the calibration saw, drawn on its images: for people who do not use the viewer (``--save-views DIR``).

Per view and camera one PNG: the detected corners (green circles), where
the fitted model puts them (red crosses), each corner's residual as a yellow
line magnified ``RESIDUAL_SCALE`` times, and a caption with the view's RMS.
Per camera one PNG of the coverage: how many corners fell in each part of
the image over all views (dark: none; add views there).
"""

from __future__ import annotations

import glob
from collections.abc import Callable, Sequence
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING

import cv2
import numpy as np

from ..errors import StereotrackError
from ..files import AtomicOutput, check_output
from .views import coverage_grid

if TYPE_CHECKING:
    from .solve import Calibration

RESIDUAL_SCALE = 20.0  # residual lines are drawn this many times their length (they are fractions of a pixel)
GREEN, RED, YELLOW, WHITE = (60, 200, 60), (40, 40, 230), (0, 220, 255), (255, 255, 255)


def draw_view(image: np.ndarray, detected: np.ndarray, reprojected: np.ndarray, caption: str) -> np.ndarray:
    """A BGR copy of a grey view with its corners, reprojections, magnified residuals and a caption."""
    out = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR) if image.ndim == 2 else image.copy()
    size = max(3, round(out.shape[1] / 200))
    tip = detected + RESIDUAL_SCALE * (reprojected - detected)
    for (x0, y0), (x1, y1) in zip(detected, tip):
        cv2.line(out, (round(x0), round(y0)), (round(x1), round(y1)), YELLOW, 1, cv2.LINE_AA)
    for x, y in detected:
        cv2.circle(out, (round(x), round(y)), size, GREEN, 1, cv2.LINE_AA)
    for x, y in reprojected:
        cv2.drawMarker(out, (round(x), round(y)), RED, cv2.MARKER_CROSS, 2 * size, 1, cv2.LINE_AA)
    _caption(out, [caption, f"green: detected, red: fitted, yellow: residual x{RESIDUAL_SCALE:g}"])
    return out


def draw_coverage(image_size: tuple[int, int], corners: list[np.ndarray], background: np.ndarray | None = None) -> np.ndarray:
    """The coverage heat-map over the image (hot: many corners, dark: none), over a faint first view if given."""
    w, h = image_size
    grid = coverage_grid(corners, image_size)
    heat = cv2.applyColorMap(np.uint8(255 * np.sqrt(grid / max(1, grid.max()))), cv2.COLORMAP_INFERNO)
    heat = cv2.resize(heat, (w, h), interpolation=cv2.INTER_NEAREST)
    if background is not None:
        faint = cv2.cvtColor(background, cv2.COLOR_GRAY2BGR) if background.ndim == 2 else background
        heat = cv2.addWeighted(heat, 0.75, faint, 0.25, 0)
    for pts in corners:
        for x, y in pts:
            cv2.circle(heat, (round(x), round(y)), 1, WHITE, -1)
    share = float((grid > 0).mean())
    _caption(heat, [f"coverage {100 * share:.0f}%: corners per cell over all views (dark cells: add views there)"])
    return heat


def save_views(calibration: Calibration, folder: str | Path, inputs: Sequence[str | Path] = ()) -> list[Path]:
    """Write ``<view>_<camera>.png`` for every view a camera saw and ``coverage_<camera>.png``; returns the files.

    ``inputs``: the image folders or patterns calibrated from. Every file is checked before the first is
    written (never an input image, a link or a file that is not a PNG) and written atomically.
    """
    folder = Path(folder)
    views, fit = calibration.views, calibration.fit
    if not views.images:
        raise StereotrackError("the views' images were not kept: nothing to draw (calibrate with keep_images=True)")
    check_views_folder(folder, inputs)
    drawings: list[tuple[Path, Callable[[], np.ndarray]]] = []
    for v, name in enumerate(views.view_names):
        for c, cam in enumerate(views.camera_names):
            d = fit.detections[v][c]
            if d is None:
                continue
            e = np.linalg.norm(fit.residuals(v, c), axis=1)
            caption = f"view {name} {cam}: RMS {np.sqrt(np.mean(e**2)):.3f} px, worst corner {e.max():.2f} px, {len(d)} corners"
            drawings.append(
                (folder / f"{name}_{cam}.png", partial(draw_view, views.images[v][c], d.corners, fit.reprojected[v][c], caption))
            )
    for c, cam in enumerate(views.camera_names):
        seen = views.seen_by(c)
        corners = [fit.detections[v][c].corners for v in seen]
        background = views.images[seen[0]][c] if seen else None
        drawings.append((folder / f"coverage_{cam}.png", partial(draw_coverage, views.image_sizes[c], corners, background)))
    check_view_files([path for path, _ in drawings], inputs)
    return [_write(path, draw()) for path, draw in drawings]


def view_files(folder: str | Path, view_names: Sequence[str], camera_names: Sequence[str]) -> list[Path]:
    """Every file save_views may write for these views (a view a camera did not see gets none)."""
    folder = Path(folder)
    return [folder / f"{v}_{c}.png" for v in view_names for c in camera_names] + [folder / f"coverage_{c}.png" for c in camera_names]


def check_view_files(paths: Sequence[Path], inputs: Sequence[str | Path] = ()) -> None:
    """Each annotated image may replace only an earlier PNG, never an input image, a link or another file."""
    input_files = _input_files(inputs)
    for path in paths:
        check_output(path, "--save-views", "PNG image", input_files)


def check_views_folder(folder: str | Path, inputs: Sequence[str | Path] = ()) -> None:
    """Refuse a --save-views that is a file, or a folder that holds input images (before any work is done)."""
    folder = Path(folder)
    if folder.is_symlink():
        raise StereotrackError(f"--save-views {folder}: is a symbolic link; give the real path (outputs are never written through links)")
    if folder.exists() and not folder.is_dir():
        raise StereotrackError(f"--save-views {folder}: is a file; give a folder for the annotated images")
    for source in inputs:
        if Path(source).is_dir() and Path(source).resolve() == folder.resolve():
            raise StereotrackError(f"--save-views {folder}: that folder holds input images; give another folder so no input is overwritten")


def _input_files(inputs: Sequence[str | Path]) -> list[Path]:
    files: list[Path] = []
    for source in inputs:
        p = Path(source)
        files += list(p.iterdir()) if p.is_dir() else [Path(f) for f in glob.glob(str(source))]
    return files


def _write(path: Path, image: np.ndarray) -> Path:
    ok, png = cv2.imencode(".png", image)
    if not ok:
        raise StereotrackError(f"{path}: could not encode the image")
    out = AtomicOutput(path, "--save-views")
    f = out.open("wb")
    try:
        f.write(png.tobytes())
    except BaseException:
        out.abort()
        raise
    out.commit()
    return path


def _caption(image: np.ndarray, lines: list[str]) -> None:
    scale = max(0.4, image.shape[1] / 1600)
    step = round(22 * scale / 0.5)
    cv2.rectangle(image, (0, 0), (image.shape[1], step * len(lines) + step // 3), (0, 0, 0), -1)
    for i, text in enumerate(lines):
        cv2.putText(image, text, (6, step * (i + 1) - step // 4), cv2.FONT_HERSHEY_SIMPLEX, scale, WHITE, 1, cv2.LINE_AA)
