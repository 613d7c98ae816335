"""Write a printable calibration board at its true physical size, then re-detect it as a self-check.

The board is described by a small YAML file (see calib/board.yaml):

  type: charuco            # or chessboard
  squares: [7, 5]          # squares across, squares down (count squares, not corners)
  square: 0.03             # side of one square, metres
  marker: 0.022            # charuco: side of one marker, metres
  dictionary: DICT_5X5_100 # charuco: ArUco dictionary

The PNG carries its dpi, and the settings are printed below the board. Print
it at 100% scale ("actual size", no "fit to page"), then measure a few squares
with a ruler: if they are not the stated size, write the measured size into
'square' (and scale 'marker' alike) before calibrating.

examples:
  stereotrack board calib/board.yaml --out board.png --dpi 300
"""

from __future__ import annotations

import argparse

HELP = "write a printable calibration board (PNG at true size) and check that it is detected"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("board", metavar="BOARD_YAML", help="board description (e.g. calib/board.yaml)")
    parser.add_argument("--out", default="board.png", metavar="PNG", help="image to write (default board.png)")
    from ..argtypes import number

    parser.add_argument("--dpi", type=number(50, 2400), default=300.0, help="printer resolution in dots per inch (default 300)")


def run(args: argparse.Namespace) -> int:
    from ..calibration.boards import load_board, printable, write_png_with_dpi
    from ..errors import StereotrackError
    from ..files import AtomicOutput, check_output

    if not str(args.out).lower().endswith(".png"):
        raise StereotrackError(f"--out must be a .png file (it stores the dpi for printing), got {args.out}")
    check_output(args.out, "--out", "PNG image", [args.board])
    board = load_board(args.board)
    page = printable(board, args.dpi)
    # Written under a temporary name; it replaces --out only once the self-check found every corner.
    out = AtomicOutput(args.out, "--out")
    out.open("wb").close()
    try:
        write_png_with_dpi(out.temp, page.image, args.dpi)
        ok = _self_check(out.temp, board, args.dpi, page, args.out)
    except BaseException:
        out.abort()
        raise
    if not ok:
        out.abort()
        raise StereotrackError(
            f"self-check failed: not every one of the {board.n_corners} corners was found in the image; use a larger --dpi or larger squares"
        )
    out.commit()
    print(f"self-check: all {board.n_corners} corners found in the written image")
    print("print at 100% scale (no 'fit to page') and check a few squares with a ruler")
    return 0


def _self_check(path, board, dpi: float, page, shown) -> bool:
    """Read the file back and find every corner, at a camera-like resolution."""
    import cv2

    from ..calibration.boards import BoardDetector

    img = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    scale = min(1.0, 1600 / max(img.shape))
    small = cv2.resize(img, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA) if scale < 1 else img
    det = BoardDetector(board).detect(small)
    found = 0 if det is None else len(det)
    h_mm, w_mm = (25.4 * n / dpi for n in img.shape)
    print(
        f"wrote {shown}: {img.shape[1]}x{img.shape[0]} px = {w_mm:.0f} x {h_mm:.0f} mm at {dpi:g} dpi; "
        f"{board.describe()}; one square prints as {1000 * page.square_printed_m:.2f} mm"
    )
    return found == board.n_corners
