"""The `stereotrack` command: argument parsing and error reporting only.

Each command lives in ``stereotrack/commands/<name>.py`` with ``HELP``,
``add_arguments(parser)`` and ``run(args) -> int``; those modules import
their heavy dependencies inside ``run`` so ``--help`` stays instant.
"""

from __future__ import annotations

import argparse
import importlib
import sys

# Order is the order in `stereotrack --help`.
COMMANDS: list[str] = [
    "demo",
    "track",
    "eval",
    "colour",
    "bench",
    "record",
    "cameras",
    "live",
    "synth",
    "stress",
    "board",
    "calibrate",
]


class UsageError(Exception):
    """A command line argparse refused; printed on one line like every other user error."""


class _Parser(argparse.ArgumentParser):
    """argparse, but a usage error is one line naming the command and pointing at its --help."""

    def error(self, message: str):
        message = message[len("argument ") :] if message.startswith("argument ") else message
        raise UsageError(f"{message} (see '{self.prog} --help')")

    def _get_values(self, action, arg_strings):
        if action.option_strings and action.nargs is None and not [a for a in arg_strings if a != "--"]:
            self.error(f"{action.option_strings[0]}: expected one value")  # '--dpi=--': argparse would drop the value
        return super()._get_values(action, arg_strings)


def _version() -> str:
    from . import __version__

    return f"stereotrack {__version__}"


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="stereotrack",
        description="Real-time 3D tracking of coloured balls seen by two or more calibrated cameras.",
    )
    parser.add_argument("--debug", action="store_true", help="show full tracebacks on errors")
    parser.add_argument("--version", action="version", version=_version())
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in COMMANDS:
        module = importlib.import_module(f"stereotrack.commands.{name}")
        p = sub.add_parser(name, help=module.HELP, description=module.__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
        add_debug_flag(p)
        module.add_arguments(p)
        if not p.get_default("_run"):
            p.set_defaults(_run=module.run)
    return parser


def add_debug_flag(parser: argparse.ArgumentParser) -> None:
    """--debug after the command name too (sub-commands such as `colour learn` add it to theirs)."""
    parser.add_argument("--debug", action="store_true", default=argparse.SUPPRESS, help="show full tracebacks on errors")


def one_line(message: object) -> str:
    """A message on one line whatever the user's file and camera names hold."""
    return str(message).replace("\r", "\\r").replace("\n", "\\n")


def quiet_native_libraries() -> None:
    """FFmpeg, OpenCV and rerun print their own warnings on stderr (a video they cannot open, a missing webcam);
    our error says what to do instead. Set before their first use; a user's own setting wins."""
    import os

    os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")  # AV_LOG_QUIET
    os.environ.setdefault("OPENCV_LOG_LEVEL", "SILENT")
    if "RUST_LOG" not in os.environ:  # rerun's log lines repeat what our one-line message says; RUST_LOG=warn shows them
        os.environ["RUST_LOG"] = "off"
        os.environ["STEREOTRACK_SET_RUST_LOG"] = "1"  # the viewers we start get their own (process.child_env)
    if "cv2" in sys.modules and os.environ["OPENCV_LOG_LEVEL"] == "SILENT":
        cv2 = sys.modules["cv2"]
        cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_SILENT)


def main(argv: list[str] | None = None) -> int:
    from .capture.signals import act_on_pending, install

    install()  # first: SIGINT/SIGTERM handled explicitly from here on, even if a script started us with SIGINT ignored
    try:
        # The heavy libraries every command loads, while a signal is still only noted: a stop raised in the middle
        # of numpy's or OpenCV's import breaks it (numpy reports a failed import of 'datetime', exit 1).
        import cv2  # noqa: F401
        import numpy  # noqa: F401

        act_on_pending()  # a signal while the package loaded (stereotrack/__init__.py) stops us here
        rc = _main(argv)
    except KeyboardInterrupt as exc:  # a stop signal outside a capture/tracking loop (see capture/signals.py)
        if getattr(exc, "debug", False):
            raise
        rc = interrupted(exc)
    if argv is None:  # the program itself (not a test calling main): its exit is bounded too
        end_within(EXIT_SECONDS, rc)
    return rc


EXIT_SECONDS = 10.0  # after the command returns, the interpreter's exit (library hooks included) gets this long


def end_within(seconds: float, rc: int) -> None:
    """End the process with ``rc`` if its exit takes longer than ``seconds``: a library's exit hook (rerun
    flushing to a viewer that went away) must not keep a finished command alive for ever."""
    import os
    import threading

    def force() -> None:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(rc)

    timer = threading.Timer(seconds, force)
    timer.daemon = True
    timer.start()


def interrupted(exc: BaseException) -> int:
    """One line for a stop signal; the exit status says which (128 + signal number)."""
    print(f"interrupted by {getattr(exc, 'signal_name', 'SIGINT')}", file=sys.stderr)
    return getattr(exc, "exit_status", 130)


def _main(argv: list[str] | None) -> int:
    from .capture.signals import interrupt_in
    from .errors import StereotrackError

    quiet_native_libraries()
    try:
        args = build_parser().parse_args(argv)
    except UsageError as exc:
        print(f"error: {one_line(exc)}", file=sys.stderr)
        return 2
    debug = getattr(args, "debug", False)
    try:
        return int(args._run(args) or 0)
    except StereotrackError as exc:
        if debug:
            raise
        print(f"error: {one_line(exc)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:
        exc.debug = debug
        raise
    except Exception as exc:  # a bug, not a user error: still one line unless --debug
        stop = interrupt_in(exc)
        if stop is not None:  # a stop signal a compiled library wrapped (capture/signals.py)
            stop.debug = debug
            raise stop from exc
        if debug:
            raise
        print(
            f"internal error: {type(exc).__name__}: {one_line(exc)} (run again with --debug for the traceback and report it)",
            file=sys.stderr,
        )
        return 3


if __name__ == "__main__":
    sys.exit(main())
