"""Reading YAML files a user wrote, with one clear error for a missing or malformed file."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from .errors import StereotrackError


def load_yaml(path: str | Path, missing: str = "file not found") -> Any:
    """Parse a YAML file with the safe loader; ``missing`` is the message when the file is absent."""
    path = Path(path)
    if not path.is_file():
        raise StereotrackError(f"{path}: {missing}")
    try:
        return yaml.safe_load(path.read_text())
    except yaml.YAMLError as exc:
        raise StereotrackError(f"{path}: not valid YAML ({str(exc).splitlines()[0]})") from None
