"""Stopping on SIGINT and SIGTERM, cleanly, from the first moment to the last.

``install()`` (the first thing ``stereotrack`` does) sets explicit handlers for
both signals, as ffmpeg does: a program started in the background by a script
inherits SIGINT ignored, and Python's default for SIGTERM is to die without
closing any file. Outside a ``StopOnSignals`` block a signal raises
``Interrupted`` (a KeyboardInterrupt): ``finally`` blocks close files and the
command line prints one line. Inside one (the capture and tracking loops) the
first signal only asks the loop to stop: the loop ends after the frame in hand,
sources stop, sinks are finalised. Setup before a loop runs inside the block
too, so a signal during it ends the command as soon as its loop starts, with
nothing half-written. A second signal interrupts at once.

The handler never raises inside an ``import``: an exception there can leave the
module half-imported or its import lock held for ever (another thread importing
it then waits for ever). A stop that would raise there is noted and the handler
runs again ``RETRY_SECONDS`` later, until it lands outside the import.
"""

from __future__ import annotations

import _thread
import signal
import sys
import threading
import time
from collections.abc import Callable

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)
RETRY_SECONDS = 0.01  # a stop deferred because it came inside an import is handled again this much later


class Interrupted(KeyboardInterrupt):
    """Raised by a stop signal outside a StopOnSignals block (or by a second one inside)."""

    def __init__(self, signal_name: str = "SIGINT"):
        super().__init__(signal_name)
        self.signal_name = signal_name

    @property
    def exit_status(self) -> int:
        return 128 + int(signal.Signals[self.signal_name])


class _State:
    installed = False
    starting = False  # the command line is still loading: note a signal, act on it once main() runs
    pending: str | None = None  # a stop noted but not yet acted on (while starting, or inside an import)
    retrying = False  # a thread will run the handler again for the pending stop
    previous: dict = {}
    scopes: list[StopOnSignals] = []


def _handle(signum, frame) -> None:
    name = _State.pending or signal.Signals(signum).name  # a retry is the stop that was deferred
    if _State.starting:
        _State.pending = name
        return
    if _State.scopes and not _State.scopes[-1].requested:
        _State.pending = None
        for scope in list(_State.scopes):  # nested blocks (a command's and its loop's) all learn of it
            if not scope.requested:
                scope._request(name)
        return
    if _inside_import(frame):
        _State.pending = name
        _retry_later(signum)
        return
    _State.pending = None
    raise Interrupted(name)


def _inside_import(frame) -> bool:
    """Whether the main thread is running an import (importlib's frames are on its stack)."""
    while frame is not None:
        if frame.f_code.co_filename.startswith("<frozen importlib."):
            return True
        frame = frame.f_back
    return False


def _retry_later(signum: int) -> None:
    """Run the handler again in a moment. From a bare thread (``_thread``, not ``threading``, whose locks the
    interrupted code may hold), with ``interrupt_main``: Python's own flag, not a real signal, so no library
    in the middle of loading sees more interrupted system calls than the one signal the user sent."""
    if _State.retrying:
        return
    _State.retrying = True

    def retry() -> None:
        time.sleep(RETRY_SECONDS)
        _State.retrying = False
        if _State.pending is not None and _State.installed:
            _thread.interrupt_main(signum)

    _thread.start_new_thread(retry, ())


def install(starting: bool = False) -> bool:
    """Handle SIGINT and SIGTERM explicitly (main thread only); True if installed now.

    ``starting`` (the package loading as the command line): a signal is only noted
    until ``act_on_pending()`` runs, so no half-imported module raises it.
    """
    if starting and not _State.installed:
        _State.starting = True
    if _State.installed or threading.current_thread() is not threading.main_thread():
        return False
    for sig in STOP_SIGNALS:
        _State.previous[sig] = signal.signal(sig, _handle)
    _State.installed = True
    return True


def act_on_pending() -> None:
    """End the start-up phase: a signal that came while the command line loaded interrupts now."""
    _State.starting = False
    if _State.pending is not None:
        name, _State.pending = _State.pending, None
        raise Interrupted(name)


def uninstall() -> None:
    for sig, handler in _State.previous.items():
        signal.signal(sig, handler)
    _State.previous = {}
    _State.installed = False
    _State.pending = None


def leave_to_parent() -> None:
    """In a command's worker process: Ctrl-C (sent to the whole process group) is the parent's to handle, so
    ignore it, and let SIGTERM end the worker at once; StopOnSignals blocks in the worker then leave both alone."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    _State.starting, _State.pending, _State.previous = False, None, {}
    _State.installed = True  # install() (and so StopOnSignals) sees them handled and changes nothing


def interrupt_in(exc: BaseException | None) -> KeyboardInterrupt | None:
    """The stop (a KeyboardInterrupt) that ``exc`` is, or that caused it; None when no stop did. A stop raised inside a
    compiled library's call back into Python (numba loading a kernel's constants, many times a frame) comes out of the
    library as a SystemError caused by it: still the user's Ctrl-C, not a bug. An error merely raised while a stop was
    handled (a disk that failed as a file was closed) is that error: only causes count, not contexts."""
    for _ in range(100):  # (a chain of causes is short; none is followed for ever)
        if exc is None or isinstance(exc, KeyboardInterrupt):
            return exc
        exc = exc.__cause__
    return None


def output_kept() -> bool:
    """Called while closing an output: keep what it wrote? Yes when no error is on its way out, or when the one that is
    is a stop (``interrupt_in``): Ctrl-C keeps what was tracked or recorded, a failure leaves the previous output."""
    failing = sys.exc_info()[1]
    return failing is None or interrupt_in(failing) is not None


def stop_requested() -> bool:
    """Whether a stop signal arrived inside any active StopOnSignals block (the run is ending on it)."""
    return any(scope.requested for scope in _State.scopes)


class StopOnSignals:
    """While active, the first SIGINT/SIGTERM asks the loop to stop instead of interrupting it.

    ``callbacks`` (e.g. a source's ``request_stop``) are called from the handler;
    loops poll ``requested``. ``signal_name`` says which signal it was.
    """

    def __init__(self, *callbacks: Callable[[], None]):
        self.callbacks = list(callbacks)
        self.signal_name: str | None = None
        self._installed_here = False

    @property
    def requested(self) -> bool:
        return self.signal_name is not None

    def add(self, callback: Callable[[], None]) -> None:
        """Also call ``callback`` on a stop (at once if a stop was already asked)."""
        self.callbacks.append(callback)
        if self.requested:
            callback()

    def _request(self, name: str) -> None:
        self.signal_name = name
        for cb in self.callbacks:
            cb()

    def __enter__(self) -> StopOnSignals:
        self._installed_here = install()
        _State.scopes.append(self)
        return self

    def __exit__(self, *exc) -> None:
        if self in _State.scopes:
            _State.scopes.remove(self)
        if self._installed_here:
            uninstall()
