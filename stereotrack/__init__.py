"""stereotrack: real-time 3D tracking of coloured balls seen by two or more calibrated cameras."""

from . import _compat

__version__ = "0.1.0"

_compat.install()  # the module paths of earlier versions (stereotrack.viz, stereotrack.synth, ...) keep working
