"""Stopping cleanly: SIGINT and SIGTERM ask a source to stop, so the loop ends and closes its files."""

from __future__ import annotations

import threading


class StopOnSignals:
    """While active, SIGINT and SIGTERM ask ``source`` to stop instead of killing the program.

    The loop consuming the source then ends normally and closes its files. A
    second signal restores the default behaviour (a second Ctrl-C interrupts).
    """

    def __init__(self, source):
        self.source = source
        self.signal_name: str | None = None
        self._previous: dict = {}

    def _handle(self, signum, frame) -> None:
        import signal

        self.signal_name = signal.Signals(signum).name
        self.source.request_stop()
        for sig, handler in self._previous.items():
            signal.signal(sig, handler)

    def __enter__(self) -> StopOnSignals:
        import signal

        if threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGINT, signal.SIGTERM):
                self._previous[sig] = signal.signal(sig, self._handle)
        return self

    def __exit__(self, *exc) -> None:
        import signal

        for sig, handler in self._previous.items():
            signal.signal(sig, handler)
        self._previous = {}
