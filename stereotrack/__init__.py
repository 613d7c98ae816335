"""stereotrack: real-time 3D tracking of coloured balls seen by two or more calibrated cameras."""

import sys

if sys.argv[:1] == ["-m"] or sys.argv[0].rpartition("/")[2] == "stereotrack":
    # This is the command line starting (python -m stereotrack, or the stereotrack script): handle
    # SIGINT/SIGTERM before anything slow loads, so a signal in its first moments stops it cleanly too.
    from .capture.signals import install as _install_stop_signals

    _install_stop_signals(starting=True)

from . import _compat  # noqa: E402

__version__ = "0.1.0"

_compat.install()  # the module paths of earlier versions (stereotrack.viz, stereotrack.synth, ...) keep working
