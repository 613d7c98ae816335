"""argparse types for the commands' numeric options: finite numbers in a stated range.

``type=number(0, 600)`` accepts 0 <= x <= 600 and refuses nan, inf and text
with a message argparse prints as ``argument --seconds: expected ...``.
Kept free of heavy imports: it runs while building ``--help``.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable


def number(
    lo: float | None = None, hi: float | None = None, *, integer: bool = False, above: float | None = None, what: str | None = None
) -> Callable[[str], float | int]:
    """A parser for a finite number with ``lo <= x <= hi`` (or ``x > above``); ``integer`` for whole numbers."""
    kind = what or ("a whole number" if integer else "a number")
    if lo is not None and hi is not None:
        expected = f"{kind} from {lo:g} to {hi:g}"
    else:
        bounds = [f"above {above:g}"] if above is not None else [f"at least {lo:g}"] if lo is not None else []
        bounds += [f"at most {hi:g}"] if hi is not None else []
        expected = f"{kind} " + " and ".join(bounds) if bounds else kind

    def parse(text: str) -> float | int:
        try:
            value: float | int = int(text, 10) if integer else float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {expected}, got {text!r}") from None
        if (
            not math.isfinite(value)
            or (above is not None and not value > above)
            or (lo is not None and value < lo)
            or (hi is not None and value > hi)
        ):
            raise argparse.ArgumentTypeError(f"expected {expected}, got {text!r}")
        return value

    parse.__name__ = "integer" if integer else "number"
    return parse


def port(text: str) -> int:
    """A TCP port, 1..65535."""
    return number(1, 65535, integer=True, what="a port number")(text)
