"""Reading the files a user wrote: YAML (safe loader) and numeric CSV, with one clear error each; generated doc sections."""

from __future__ import annotations

import os
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


def replace_section(path: str | Path, name: str, body: str) -> None:
    """Put ``body`` between ``<!-- section: NAME -->`` and ``<!-- /section: NAME -->`` in a markdown file.

    A file without the section gets it appended at its end. The file is replaced in one rename, so a
    failure leaves it as it was; the text outside the section is kept byte for byte.
    """
    path = Path(path)
    text = path.read_text() if path.is_file() else ""
    start, end = f"<!-- section: {name} -->", f"<!-- /section: {name} -->"
    block = f"{start}\n{body.strip()}\n{end}"
    if start in text and end in text.split(start, 1)[1]:
        head, rest = text.split(start, 1)
        text = head + block + rest.split(end, 1)[1]
    else:
        text = text.rstrip("\n") + ("\n\n" if text else "") + block + "\n"
    write_atomic(path, text)


def write_atomic(path: str | Path, text: str) -> None:
    """Write ``text`` to ``path`` in one rename: a reader (or a run killed half-way) sees the old file or the new one."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    try:
        tmp.write_text(text)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def read_section(path: str | Path, name: str) -> str | None:
    """The text of a section written by ``replace_section`` (without its markers), or None."""
    path = Path(path)
    if not path.is_file():
        return None
    text = path.read_text()
    start, end = f"<!-- section: {name} -->", f"<!-- /section: {name} -->"
    if start not in text or end not in text.split(start, 1)[1]:
        return None
    return text.split(start, 1)[1].split(end, 1)[0].strip("\n")
