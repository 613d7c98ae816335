"""Console output for long jobs: progress lines and warnings on stderr."""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager


def warn(message: str) -> None:
    """One warning line on stderr."""
    print("warning: " + str(message).replace("\r", "\\r").replace("\n", "\\n"), file=sys.stderr, flush=True)


def info(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


@contextmanager
def notice_if_slow(message: str, after: float = 1.0) -> Iterator[None]:
    """Say ``message`` on stderr if the block is still running after ``after`` seconds (a one-off wait
    the user should not mistake for a hang)."""
    timer = threading.Timer(after, info, args=(message,))
    timer.daemon = True
    timer.start()
    try:
        yield
    finally:
        timer.cancel()


class Progress:
    """A single-line progress bar on stderr, redrawn at most every 0.2 s.

    Shows done/total, percentage, rate and time left; on a non-terminal it
    prints a line every 10% instead so logs stay short.
    """

    def __init__(self, total: int | None, label: str = "", unit: str = "frames", enabled: bool = True):
        self.total = total
        self.label = label
        self.unit = unit
        self.enabled = enabled
        self.done = 0
        self.start = time.perf_counter()
        self._last_draw = 0.0
        self._tty = sys.stderr.isatty()
        self._last_decile = -1
        self.extra = ""

    def update(self, n: int = 1, extra: str | None = None) -> None:
        self.done += n
        if extra is not None:
            self.extra = extra
        if not self.enabled:
            return
        now = time.perf_counter()
        if self._tty:
            if now - self._last_draw >= 0.2 or (self.total and self.done >= self.total):
                self._last_draw = now
                sys.stderr.write("\r" + self._line(now) + "\033[K")
                sys.stderr.flush()
        elif self.total:
            decile = int(10 * self.done / self.total)
            if decile != self._last_decile:
                self._last_decile = decile
                print(self._line(now), file=sys.stderr, flush=True)

    def say(self, status: str) -> None:
        """A status worth a line of its own (a calibration view taken): the bar's text on a terminal,
        a plain line elsewhere, so a log shows it as it happens rather than at the end."""
        self.extra = status
        if not self.enabled:
            return
        if self._tty:
            self.update(0)
        else:
            print(self._line(time.perf_counter()), file=sys.stderr, flush=True)

    def rate(self) -> float:
        elapsed = time.perf_counter() - self.start
        return self.done / elapsed if elapsed > 0 else 0.0

    def _line(self, now: float) -> str:
        elapsed = now - self.start
        rate = self.done / elapsed if elapsed > 0 else 0.0
        parts = [self.label] if self.label else []
        if self.total:
            frac = min(1.0, self.done / self.total)
            bar = "#" * int(20 * frac) + "-" * (20 - int(20 * frac))
            left = (self.total - self.done) / rate if rate > 0 else 0.0
            parts.append(f"[{bar}] {self.done}/{self.total} {self.unit} {100 * frac:3.0f}% {rate:5.1f}/s eta {left:4.0f}s")
        else:
            parts.append(f"{self.done} {self.unit} {rate:5.1f}/s")
        if self.extra:
            parts.append(self.extra)
        return " ".join(parts)

    def close(self) -> None:
        if self.enabled and self._tty:
            sys.stderr.write("\n")
            sys.stderr.flush()


@contextmanager
def quiet_native_stderr() -> Iterator[None]:
    """Silence what C libraries print on stderr (file descriptor 2) during the block; our own message says
    what went wrong instead. Only for short calls in the main thread."""
    import os

    sys.stderr.flush()
    saved = os.dup(2)
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)
        os.close(devnull)
