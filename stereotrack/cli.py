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
    "board",
    "calibrate",
]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="stereotrack",
        description="Real-time 3D tracking of coloured balls seen by two or more calibrated cameras.",
    )
    parser.add_argument("--debug", action="store_true", help="show full tracebacks on errors")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in COMMANDS:
        module = importlib.import_module(f"stereotrack.commands.{name}")
        p = sub.add_parser(name, help=module.HELP, description=module.__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
        p.add_argument("--debug", action="store_true", default=argparse.SUPPRESS, help="show full tracebacks on errors")
        module.add_arguments(p)
        if not p.get_default("_run"):
            p.set_defaults(_run=module.run)
    return parser


def main(argv: list[str] | None = None) -> int:
    from .capture.signals import act_on_pending, install

    install()  # first: SIGINT/SIGTERM handled explicitly from here on, even if a script started us with SIGINT ignored
    try:
        act_on_pending()  # a signal while the package loaded (stereotrack/__init__.py) stops us here
        return _main(argv)
    except KeyboardInterrupt as exc:  # a stop signal outside a capture/tracking loop (see capture/signals.py)
        if getattr(exc, "debug", False):
            raise
        return interrupted(exc)


def interrupted(exc: BaseException) -> int:
    """One line for a stop signal; the exit status says which (128 + signal number)."""
    print(f"interrupted by {getattr(exc, 'signal_name', 'SIGINT')}", file=sys.stderr)
    return getattr(exc, "exit_status", 130)


def _main(argv: list[str] | None) -> int:
    from .errors import StereotrackError

    parser = build_parser()
    args = parser.parse_args(argv)
    debug = getattr(args, "debug", False)
    try:
        return int(args._run(args) or 0)
    except StereotrackError as exc:
        if debug:
            raise
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:
        exc.debug = debug
        raise
    except Exception as exc:  # a bug, not a user error: still one line unless --debug
        if debug:
            raise
        print(f"internal error: {type(exc).__name__}: {exc} (run again with --debug for the traceback and report it)", file=sys.stderr)
        return 3


if __name__ == "__main__":
    sys.exit(main())
