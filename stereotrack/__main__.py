import sys

from .capture.signals import install

install()  # before anything slow is imported: a signal in the first moments is handled too
try:
    from .cli import main
except KeyboardInterrupt as exc:  # a stop signal while the command line itself loads
    print(f"interrupted by {getattr(exc, 'signal_name', 'SIGINT')}", file=sys.stderr)
    sys.exit(getattr(exc, "exit_status", 130))

sys.exit(main())
