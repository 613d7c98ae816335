"""Calibration boards: the board.yaml description, detection in images, printable images.

Two kinds of board, both counted in *squares* (what you see on the print):

* ``chessboard``: plain black and white squares; OpenCV finds its inner
  corners (squares - 1 in each direction). All corners must be visible.
* ``charuco``: a chessboard with ArUco markers in its white squares; every
  corner has an id, so a partly visible or rotated board is still usable.

Board frame: x along a row of squares, y down the columns, z into the board;
inner corner (c, r) sits at ((c + 1) * square, (r + 1) * square, 0) for both
kinds (OpenCV's ChArUco convention), so the origin is the board's outer corner.
"""

from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import yaml

from ..errors import StereotrackError
from ..files import load_yaml

BOARD_TYPES = ("chessboard", "charuco")
DICTIONARIES = tuple(n for n in dir(cv2.aruco) if n.startswith("DICT_") and n.upper() == n)
# Below this many corners a view says little and ChArUco pose/intrinsics become unstable.
MIN_CORNERS = 6


@dataclass(frozen=True)
class Board:
    """A calibration board as described in ``calib/board.yaml``."""

    type: str  # "chessboard" or "charuco"
    squares: tuple[int, int]  # squares across, squares down
    square: float  # side of one square, metres
    marker: float | None = None  # ChArUco: side of one marker, metres
    dictionary: str | None = None  # ChArUco: ArUco dictionary name, e.g. DICT_5X5_100
    legacy: bool = False  # ChArUco: pattern made by OpenCV < 4.6 (matters for an even number of rows)

    @property
    def inner(self) -> tuple[int, int]:
        """Inner corners (across, down): OpenCV's chessboard ``patternSize``."""
        return (self.squares[0] - 1, self.squares[1] - 1)

    @property
    def n_corners(self) -> int:
        return self.inner[0] * self.inner[1]

    @property
    def size_m(self) -> tuple[float, float]:
        """Physical size of the squares area (width, height), metres."""
        return (self.squares[0] * self.square, self.squares[1] * self.square)

    def object_points(self) -> np.ndarray:
        """Board-frame position (N x 3, metres) of every inner corner, indexed by corner id."""
        cols, rows = self.inner
        r, c = np.divmod(np.arange(cols * rows), cols)
        return np.column_stack([(c + 1) * self.square, (r + 1) * self.square, np.zeros(cols * rows)])

    def describe(self) -> str:
        s = f"{self.type} {self.squares[0]}x{self.squares[1]} squares of {1000 * self.square:g} mm"
        if self.type == "charuco":
            s += f", markers {1000 * self.marker:g} mm, {self.dictionary}"
        return s

    def opencv_charuco(self) -> cv2.aruco.CharucoBoard:
        dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, self.dictionary))
        b = cv2.aruco.CharucoBoard(tuple(self.squares), self.square, self.marker, dictionary)
        b.setLegacyPattern(bool(self.legacy))
        return b


# --------------------------------------------------------------------------- YAML


def board_from_dict(data: Any, path: Path | str = "<board>") -> Board:
    """Validate a parsed board.yaml; every problem names the field and what is expected."""

    def fail(field: str, what: str) -> StereotrackError:
        return StereotrackError(f"{path}: field '{field}': {what}")

    if not isinstance(data, dict):
        raise fail("<top level>", "expected a mapping with type, squares, square (and marker, dictionary for charuco)")
    kind = str(data.get("type", "")).lower()
    if kind not in BOARD_TYPES:
        raise fail("type", f"expected one of {', '.join(BOARD_TYPES)}, got {data.get('type')!r}")
    squares = data.get("squares")
    if not (isinstance(squares, (list, tuple)) and len(squares) == 2 and all(isinstance(v, int) and 3 <= v <= 100 for v in squares)):
        raise fail(
            "squares",
            f"expected [squares across, squares down], whole numbers from 3 to 100 (count squares, not inner corners), got {squares!r}",
        )
    square = data.get("square")
    if not isinstance(square, (int, float)) or not 0.001 <= square <= 1.0:
        raise fail("square", f"expected the side of one square in metres (e.g. 0.04 for 4 cm), got {square!r}")
    if kind == "chessboard":
        return Board("chessboard", (squares[0], squares[1]), float(square))
    marker = data.get("marker")
    if not isinstance(marker, (int, float)) or not 0 < marker < square:
        raise fail("marker", f"expected the side of one marker in metres, smaller than the square ({square}), got {marker!r}")
    dictionary = str(data.get("dictionary", "DICT_5X5_100")).upper()
    if dictionary not in DICTIONARIES:
        raise fail("dictionary", f"unknown ArUco dictionary {dictionary!r}; e.g. DICT_4X4_50, DICT_5X5_100, DICT_6X6_250")
    n_markers = (squares[0] * squares[1]) // 2
    dict_size = int(dictionary.rsplit("_", 1)[-1]) if dictionary.rsplit("_", 1)[-1].isdigit() else None
    if dict_size is not None and dict_size < n_markers:
        raise fail(
            "dictionary",
            f"{dictionary} has {dict_size} markers but a {squares[0]}x{squares[1]} board needs {n_markers}: choose a larger one",
        )
    return Board("charuco", (squares[0], squares[1]), float(square), float(marker), dictionary, bool(data.get("legacy", False)))


def board_to_dict(board: Board) -> dict[str, Any]:
    d: dict[str, Any] = {"type": board.type, "squares": list(board.squares), "square": board.square}
    if board.type == "charuco":
        d.update(marker=board.marker, dictionary=board.dictionary)
        if board.legacy:
            d["legacy"] = True
    return d


def load_board(path: str | Path) -> Board:
    data = load_yaml(path, "board file not found (write one like calib/board.yaml: type, squares, square, marker, dictionary)")
    return board_from_dict(data, Path(path))


def save_board(board: Board, path: str | Path) -> None:
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    Path(path).write_text(yaml.safe_dump(board_to_dict(board), sort_keys=False, default_flow_style=None))


# --------------------------------------------------------------------------- detection


@dataclass(frozen=True, eq=False)
class Detection:
    """Board corners found in one image: ids into ``Board.object_points()`` and pixels."""

    ids: np.ndarray  # (n,) int, increasing
    corners: np.ndarray  # (n, 2) float64 pixels

    def __len__(self) -> int:
        return len(self.ids)


def to_grey(image: np.ndarray) -> np.ndarray:
    return cv2.cvtColor(image, cv2.COLOR_BGR2GRAY) if image.ndim == 3 else image


class BoardDetector:
    """Finds a board in images. ``subpix_window`` is the half-size of the corner
    refinement window (None: a quarter of the corner spacing, 2..11 px)."""

    def __init__(self, board: Board, subpix_window: int | None = None):
        self.board = board
        self.subpix_window = subpix_window
        if board.type == "charuco":
            self._charuco = cv2.aruco.CharucoDetector(board.opencv_charuco())

    def detect(self, image: np.ndarray) -> Detection | None:
        """The board's corners in ``image`` (BGR or grey), or None if not found."""
        grey = to_grey(image)
        if self.board.type == "chessboard":
            flags = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE | cv2.CALIB_CB_FAST_CHECK
            found, corners = cv2.findChessboardCorners(grey, self.board.inner, flags=flags)
            if not found or corners is None:
                return None
            corners = corners.reshape(-1, 1, 2).astype(np.float32)
            self._refine(grey, corners)
            return Detection(np.arange(self.board.n_corners), corners.reshape(-1, 2).astype(np.float64))
        corners, ids, _, _ = self._charuco.detectBoard(grey)
        if ids is None or len(ids) < MIN_CORNERS:
            return None
        ids = ids.ravel().astype(int)
        order = np.argsort(ids)
        pts = corners.reshape(-1, 2).astype(np.float64)[order]
        if _collinear(self.board, ids[order]):
            return None
        return Detection(ids[order], pts)

    def _refine(self, grey: np.ndarray, corners: np.ndarray) -> None:
        half = self.subpix_window
        if half is None:
            cols = self.board.inner[0]
            spacing = np.median(np.linalg.norm(np.diff(corners.reshape(-1, cols, 2), axis=1), axis=2))
            half = int(np.clip(round(spacing / 4), 2, 11))
        criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 30, 0.01)
        cv2.cornerSubPix(grey, corners, (half, half), (-1, -1), criteria)


def _collinear(board: Board, ids: np.ndarray) -> bool:
    """Corners all on one row or one column give no pose: reject them."""
    r, c = np.divmod(ids, board.inner[0])
    return len(np.unique(r)) < 2 or len(np.unique(c)) < 2


def flipped(board: Board, det: Detection) -> Detection:
    """The same corners labelled as if the board were turned by 180 degrees.

    A chessboard looks the same (or nearly) after a half turn, so two cameras
    may number its corners from opposite ends; this relabelling undoes that.
    """
    ids = board.n_corners - 1 - det.ids
    order = np.argsort(ids)
    return Detection(ids[order], det.corners[order])


# --------------------------------------------------------------------------- what is in the image, if not our board


def diagnose(board: Board, images: list[np.ndarray]) -> str | None:
    """Explain why ``board`` is not found in these images, if another board is.

    Returns a sentence naming what was found (another square count, another
    dictionary, the other kind of board), or None if no board was found at all.
    """
    for image in images:
        grey = to_grey(image)
        if board.type == "charuco":
            msg = _diagnose_charuco(board, grey)
            if msg:
                return msg
        else:  # markers first: a ChArUco board also contains chessboard-like patches
            name, count = _best_dictionary(grey)
            if name:
                return (
                    f"found {count} ArUco markers ({name.split('_')[1]} family, e.g. {name}): this looks like a ChArUco board but board.yaml says chessboard; "
                    f"set type: charuco and its dictionary, marker and square sizes"
                )
        found = _chessboard_any_size(grey)
        if found is not None:
            inner = found
            squares = (inner[0] + 1, inner[1] + 1)
            if board.type == "charuco":
                return (
                    f"found a plain chessboard with {squares[0]}x{squares[1]} squares but board.yaml describes a ChArUco board: "
                    f"set type: chessboard, squares: [{squares[0]}, {squares[1]}]"
                )
            if sorted(inner) != sorted(board.inner):
                return (
                    f"found a chessboard with {squares[0]}x{squares[1]} squares ({inner[0]}x{inner[1]} inner corners) "
                    f"but board.yaml says squares: [{board.squares[0]}, {board.squares[1]}]: fix 'squares' in board.yaml (count squares, not corners)"
                )
    return None


def _chessboard_any_size(grey: np.ndarray) -> tuple[int, int] | None:
    """Inner-corner counts of the largest chessboard in the image, whatever its size."""
    scale = min(1.0, 1200 / max(grey.shape))
    small = cv2.resize(grey, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA) if scale < 1 else grey
    found, corners, meta = cv2.findChessboardCornersSBWithMeta(small, (3, 3), cv2.CALIB_CB_LARGER)
    if not found or meta is None:
        return None
    rows, per_row = meta.shape[:2]  # in OpenCV's corner order, which may run down the image
    grid = corners.reshape(rows, per_row, 2)
    dx, dy = np.abs(grid[0, -1] - grid[0, 0])
    return (int(per_row), int(rows)) if dx >= dy else (int(rows), int(per_row))


def _best_dictionary(grey: np.ndarray) -> tuple[str | None, int]:
    best, best_n = None, 0
    for name in ("DICT_4X4_50", "DICT_5X5_50", "DICT_6X6_50", "DICT_7X7_50", "DICT_ARUCO_ORIGINAL", "DICT_APRILTAG_36h11"):
        det = cv2.aruco.ArucoDetector(cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, name)))
        _, ids, _ = det.detectMarkers(grey)
        n = 0 if ids is None else len(ids)
        if n > best_n:
            best, best_n = name, n
    return (best, best_n) if best_n >= 3 else (None, 0)


def _diagnose_charuco(board: Board, grey: np.ndarray) -> str | None:
    ob = board.opencv_charuco()
    det = cv2.aruco.ArucoDetector(ob.getDictionary())
    _, ids, _ = det.detectMarkers(grey)
    n_markers = len(ob.getIds())
    if ids is not None and len(ids) >= 3:
        ids = ids.ravel()
        if ids.max() >= n_markers:
            return (
                f"found markers with ids up to {ids.max()} but a {board.squares[0]}x{board.squares[1]} board has ids 0..{n_markers - 1}: "
                f"the printed board has more squares than board.yaml says; fix 'squares'"
            )
        if board.squares[1] % 2 == 0:
            other = replace(board, legacy=not board.legacy)
            d = BoardDetector(other).detect(grey)
            if d is not None:
                return (
                    f"the board was printed with {'the old' if other.legacy else 'the new'} "
                    f"ChArUco layout: set legacy: {str(other.legacy).lower()} in board.yaml"
                )
        return (
            f"found {len(ids)} {board.dictionary} markers but too few board corners: check 'squares', 'square' and 'marker' "
            f"in board.yaml against the print, and that the whole board is in view"
        )
    name, count = _best_dictionary(grey)
    if name and name.split("_")[1] != board.dictionary.split("_")[1]:
        family = name.split("_")[1]
        return f"found {count} ArUco markers of the {family} family (e.g. {name}) but board.yaml says {board.dictionary}: fix 'dictionary'"
    return None


# --------------------------------------------------------------------------- printable image

_WHITE = 255


def board_image(board: Board, px_per_square: int) -> np.ndarray:
    """Grey image of the squares area only, ``px_per_square`` pixels per square."""
    w, h = board.squares[0] * px_per_square, board.squares[1] * px_per_square
    if board.type == "charuco":
        img = board.opencv_charuco().generateImage((w, h), marginSize=0, borderBits=1)
        return np.ascontiguousarray(img)
    parity = np.add.outer(np.arange(board.squares[1]), np.arange(board.squares[0])) % 2
    cells = np.where(parity == 0, 0, _WHITE).astype(np.uint8)  # top-left square black, as OpenCV draws it
    return np.kron(cells, np.ones((px_per_square, px_per_square), np.uint8))


@dataclass(frozen=True, eq=False)
class PrintableBoard:
    image: np.ndarray  # grey uint8, the whole page
    dpi: float
    px_per_square: int
    square_printed_m: float  # the square side this image gives at ``dpi`` (after rounding to whole pixels)


def printable(board: Board, dpi: float = 300.0) -> PrintableBoard:
    """The board at its true physical size at ``dpi``, with a white quiet zone and the settings below it."""
    px_per_m = dpi / 0.0254
    pps = int(round(board.square * px_per_m))
    if pps < 10:
        raise StereotrackError(f"at {dpi:g} dpi one square is only {pps} px: raise --dpi or the square size")
    w_px, h_px = board.squares[0] * pps, board.squares[1] * pps
    if w_px * h_px > 150e6:  # a printable page is a few dozen megapixels; beyond this the image itself runs out of memory
        raise StereotrackError(f"at {dpi:g} dpi the board is {w_px} x {h_px} px: lower --dpi or use fewer or smaller squares")
    squares = board_image(board, pps)
    h, w = squares.shape
    margin = max(pps // 2, int(round(0.005 * px_per_m)))  # a white quiet zone (half a square, 5 mm at least) helps detection
    lines = [
        f"stereotrack board: {board.describe()}",
        f"print at 100% scale (no 'fit to page'), {dpi:g} dpi; check with a ruler: "
        f"{min(board.squares[0], 5)} squares = {1000 * min(board.squares[0], 5) * pps / px_per_m:.1f} mm",
        "board.yaml: " + yaml.safe_dump(board_to_dict(board), default_flow_style=True, width=1000).strip(),
    ]
    scale = max(0.4, dpi / 300.0 * 0.9)
    thickness = max(1, int(round(dpi / 150)))
    line_h = int(40 * scale)
    text_h = line_h * (len(lines) + 1)
    page = np.full((h + 2 * margin + text_h, w + 2 * margin), _WHITE, np.uint8)
    page[margin : margin + h, margin : margin + w] = squares
    for i, text in enumerate(lines):
        y = margin + h + margin // 2 + line_h * (i + 1)
        cv2.putText(page, text, (margin, y), cv2.FONT_HERSHEY_SIMPLEX, scale * 0.9, 0, thickness, cv2.LINE_AA)
    return PrintableBoard(page, float(dpi), pps, pps / px_per_m)


# Paper (width, height) in mm, and the edge most printers cannot print on.
PAPER_MM = {"A4": (210.0, 297.0), "letter": (215.9, 279.4), "A3": (297.0, 420.0)}
PRINTER_MARGIN_MM = 5.0


def page_mm(page: PrintableBoard) -> tuple[float, float]:
    """The printed page's (width, height) in mm: squares, quiet zone and the settings below them."""
    h, w = page.image.shape[:2]
    return 25.4 * w / page.dpi, 25.4 * h / page.dpi


def paper_fit(size_mm: tuple[float, float], paper: str) -> str | None:
    """'portrait' or 'landscape' if a page of ``size_mm`` fits on the paper within the printer's margins, else None."""
    pw, ph = (x - 2 * PRINTER_MARGIN_MM for x in PAPER_MM[paper])
    w, h = size_mm
    if w <= pw and h <= ph:
        return "portrait"
    if w <= ph and h <= pw:
        return "landscape"
    return None


def largest_square_for(board: Board, paper: str, dpi: float) -> float:
    """The largest square side (metres, whole mm) whose page fits on ``paper``; 0 if none from 5 mm up does."""
    for mm in range(int(1000 * board.square), 4, -1):
        trial = replace(board, square=mm / 1000, marker=None if board.marker is None else board.marker * mm / 1000 / board.square)
        if paper_fit(page_mm(printable(trial, dpi)), paper):
            return mm / 1000
    return 0.0


def write_png_with_dpi(path: str | Path, image: np.ndarray, dpi: float) -> None:
    """PNG with a pHYs chunk so printing programs know the true size."""
    ok, buf = cv2.imencode(".png", image)
    if not ok:
        raise StereotrackError(f"{path}: could not encode the PNG")
    data = buf.tobytes()
    ppm = int(round(dpi / 0.0254))
    body = b"pHYs" + struct.pack(">IIB", ppm, ppm, 1)
    chunk = struct.pack(">I", 9) + body + struct.pack(">I", zlib.crc32(body) & 0xFFFFFFFF)
    ihdr_end = 8 + 4 + 4 + 13 + 4  # signature, IHDR length, type, data, crc
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(data[:ihdr_end] + chunk + data[ihdr_end:])


def png_dpi(path: str | Path) -> float | None:
    """The dpi stored in a PNG's pHYs chunk (None if absent)."""
    data = Path(path).read_bytes()
    i = data.find(b"pHYs")
    if i < 0:
        return None
    ppx, _, unit = struct.unpack(">IIB", data[i + 4 : i + 13])
    return ppx * 0.0254 if unit == 1 else None
