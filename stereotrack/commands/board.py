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
    parser.add_argument(
        "--paper", choices=["A4", "letter", "A3"], help="refuse a board that does not fit on this paper (default: say which fits)"
    )


def run(args: argparse.Namespace) -> int:
    from ..calibration.boards import load_board, printable, write_png_with_dpi
    from ..errors import StereotrackError
    from ..files import AtomicOutput, check_output

    if not str(args.out).lower().endswith(".png"):
        raise StereotrackError(f"--out must be a .png file (it stores the dpi for printing), got {args.out}")
    check_output(args.out, "--out", "PNG image", [args.board])
    board = load_board(args.board)
    page = printable(board, args.dpi)
    paper_line = _check_paper(board, page, args.paper, args.dpi)
    # Written under a temporary name; it replaces --out only once the self-check found every corner.
    out = AtomicOutput(args.out, "--out")
    out.open("wb").close()
    try:
        write_png_with_dpi(out.temp, page.image, args.dpi)
        found = _self_check(out.temp, board, args.dpi, page, args.out)
    except BaseException:
        out.abort()
        raise
    if found != board.n_corners:
        out.abort()
        raise StereotrackError(
            f"self-check failed: only {found} of {board.n_corners} corners were found in the image; use a larger --dpi or larger squares"
        )
    out.commit()
    print(paper_line)
    print(f"self-check: all {found} corners found in the written image")
    print("print at 100% scale (no 'fit to page') and check a few squares with a ruler")
    return 0


def _self_check(path, board, dpi: float, page, shown) -> int:
    """Read the file back and count the corners found, at a camera-like resolution."""
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
    return found


def _check_paper(board, page, paper: str | None, dpi: float) -> str:
    """Which paper the page fits (and how to turn it); refuse when it does not fit the paper asked for."""
    from ..calibration.boards import PAPER_MM, largest_square_for, page_mm, paper_fit
    from ..console import warn
    from ..errors import StereotrackError

    w, h = page_mm(page)
    fits = {name: paper_fit((w, h), name) for name in PAPER_MM}
    if paper is not None and not fits[paper]:
        smaller = largest_square_for(board, paper, dpi)
        other = next((name for name, how in fits.items() if how), None)
        raise StereotrackError(
            f"the board ({board.describe()}) needs a page of {w:.0f} x {h:.0f} mm, which does not fit on {paper}"
            + (f" (squares of {1000 * smaller:.0f} mm or less do)" if smaller else "")
            + (f"; it fits on {other}" if other else "")
        )
    if paper is not None:
        return f"paper: fits on {paper} in {fits[paper]}" + (" (turn the page: print landscape)" if fits[paper] == "landscape" else "")
    usable = [f"{name} ({how})" for name, how in fits.items() if how]
    if not usable:
        warn(f"the page is {w:.0f} x {h:.0f} mm: larger than A3; print it in parts or use smaller squares")
        return "paper: larger than A3"
    if not fits["A4"] and not fits["letter"]:
        warn(f"the page is {w:.0f} x {h:.0f} mm: it does not fit on A4 or letter; print on {usable[0]} or use smaller squares")
    return "paper: fits on " + ", ".join(usable)
