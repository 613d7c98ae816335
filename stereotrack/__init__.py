"""stereotrack: real-time 3D tracking of coloured balls from calibrated cameras."""

__version__ = "0.1.0"
