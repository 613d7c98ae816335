"""Reading the files a user wrote: YAML (safe loader) and numeric CSV, with one clear error each."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from .errors import StereotrackError


def read_columns(path: str | Path, columns: Sequence[str], what: str) -> np.ndarray:
    """The leading ``columns`` of a CSV with a header (extra columns ignored) as an M x len(columns) array."""
    path = Path(path)
    if not path.is_file():
        raise StereotrackError(f"{path}: {what} not found")
    with open(path) as f:
        header = f.readline().strip().split(",")
    if header[: len(columns)] != list(columns):
        raise StereotrackError(f"{path}: header must start with {','.join(columns)}")
    try:
        data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2, usecols=range(len(columns)))
    except ValueError as exc:
        raise StereotrackError(f"{path}: not a readable {what} ({exc})") from None
    return data.reshape(-1, len(columns))


def load_yaml(path: str | Path, missing: str = "file not found") -> Any:
    """Parse a YAML file with the safe loader; ``missing`` is the message when the file is absent."""
    path = Path(path)
    if not path.is_file():
        raise StereotrackError(f"{path}: {missing}")
    try:
        return yaml.safe_load(path.read_text())
    except yaml.YAMLError as exc:
        raise StereotrackError(f"{path}: not valid YAML ({str(exc).splitlines()[0]})") from None
