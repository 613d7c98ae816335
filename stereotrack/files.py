"""Reading the files a user gives us (YAML, CSV) and writing outputs so that a failed run harms nothing.

Reading: every way a file can be wrong -- missing, a folder or a device,
unreadable, too large, not UTF-8, not valid YAML, an alias bomb, nested too
deeply, a non-finite number -- is one StereotrackError line that names the
file, the field where there is one, and what was expected.

Writing: an output is checked before anything is opened (not a folder, not
a symbolic link, not one of the run's inputs, and an existing file there is
replaced only if it is an earlier output of the same kind), written to a
temporary name beside it and renamed into place when complete.

Generated documents: ``replace_section`` rewrites one marked section of a markdown file (atomically).
"""

from __future__ import annotations

import io
import math
import os
import stat
import warnings
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from .errors import StereotrackError

MAX_YAML_BYTES = 4 << 20  # a stereotrack YAML file is a few kB; this bounds the parse at well under a second
MAX_YAML_VALUES = 1_000_000  # values after aliases are expanded: an alias bomb is refused before it is walked
MAX_CSV_BYTES = 2 << 30

_Loader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)  # libyaml: 80x faster, and a nesting limit of its own


# --------------------------------------------------------------------------- reading


def read_text(path: str | Path, what: str, missing: str | None = None, max_bytes: int | None = None) -> str:
    """A user's text file, decoded as UTF-8 (a byte-order mark is allowed)."""
    path = Path(path)
    try:
        st = path.stat()
    except FileNotFoundError:
        raise StereotrackError(f"{path}: {missing or what + ' not found'}") from None
    except OSError as exc:
        raise StereotrackError(f"{path}: cannot read the {what} ({exc.strerror or exc})") from None
    if stat.S_ISDIR(st.st_mode):
        raise StereotrackError(f"{path}: is a folder; expected the {what}")
    if not stat.S_ISREG(st.st_mode):
        raise StereotrackError(f"{path}: is not a regular file (a device or a pipe); expected the {what}")
    if max_bytes is not None and st.st_size > max_bytes:
        raise StereotrackError(f"{path}: {st.st_size / 1e6:.0f} MB is too large for a {what} (at most {max_bytes / 1e6:.0f} MB)")
    try:
        with open(path, "rb") as f:
            data = f.read() if max_bytes is None else f.read(max_bytes + 1)
    except OSError as exc:
        raise StereotrackError(f"{path}: cannot read the {what} ({exc.strerror or exc})") from None
    if max_bytes is not None and len(data) > max_bytes:
        raise StereotrackError(f"{path}: too large for a {what} (at most {max_bytes / 1e6:.0f} MB)")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = data[: exc.start].count(b"\n") + 1
        raise StereotrackError(f"{path}: line {line}: not UTF-8 text; expected the {what} as a UTF-8 text file") from None


def load_yaml(path: str | Path, missing: str = "file not found", what: str = "YAML file") -> Any:
    """Parse a YAML file with the safe loader; ``missing`` is the message when the file is absent."""
    path = Path(path)
    text = read_text(path, what, missing, MAX_YAML_BYTES)
    loader = _Loader(text)
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        _check_expanded_size(path, node)
        return loader.construct_document(node)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"line {mark.line + 1}: " if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise StereotrackError(f"{path}: not valid YAML ({where}{problem})") from None
    except RecursionError:
        raise StereotrackError(f"{path}: nested too deeply to be a {what}") from None
    finally:
        loader.dispose()


def _check_expanded_size(path: Path, root: yaml.Node) -> None:
    """Count the values the document holds once its aliases are expanded; refuse bombs and self-references."""
    sizes: dict[int, int] = {}
    on_path: set[int] = set()
    stack: list[tuple[yaml.Node, bool]] = [(root, False)]
    while stack:
        node, done = stack.pop()
        key = id(node)
        if done:
            on_path.discard(key)
            children = _children(node)
            sizes[key] = 1 + sum(sizes[id(c)] for c in children)
            if sizes[key] > MAX_YAML_VALUES:
                raise StereotrackError(f"{path}: its aliases expand to more than {MAX_YAML_VALUES:,} values (a YAML alias bomb?)")
            continue
        if key in sizes:
            continue
        if key in on_path:
            raise StereotrackError(f"{path}: a YAML alias refers to a value that contains it (a loop)")
        on_path.add(key)
        stack.append((node, True))
        stack.extend((c, False) for c in _children(node) if id(c) not in sizes)


def _children(node: yaml.Node) -> list[yaml.Node]:
    if isinstance(node, yaml.SequenceNode):
        return list(node.value)
    if isinstance(node, yaml.MappingNode):
        return [n for pair in node.value for n in pair]
    return []


def read_columns(
    path: str | Path,
    columns: Sequence[str],
    what: str,
    whole: Sequence[str] = (),
    nonnegative: Sequence[str] = (),
    optional: Sequence[str] = (),
) -> np.ndarray:
    """The leading ``columns`` of a numeric CSV with a header (extra columns ignored) as an M x len(columns) array, and
    after them those of the ``optional`` columns the header names next, in their order (an earlier version's file may
    lack them).

    Every value must be a finite number; the ``whole`` columns whole numbers, the ``nonnegative`` ones >= 0.
    """
    path = Path(path)
    text = read_text(path, what, max_bytes=MAX_CSV_BYTES)
    first, _, body = text.partition("\n")
    header = [h.strip() for h in first.strip().split(",")]
    if header[: len(columns)] != list(columns):
        raise StereotrackError(f"{path}: line 1: the header must start with {','.join(columns)}; got {first.strip()[:80]!r}")
    for name in optional:
        if header[len(columns) : len(columns) + 1] != [name]:
            break
        columns = [*columns, name]
    if not body.strip():
        return np.zeros((0, len(columns)))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            data = np.loadtxt(io.StringIO(body), delimiter=",", ndmin=2, usecols=range(len(columns)), comments=None)
    except ValueError:
        raise StereotrackError(f"{path}: {_first_unreadable_line(body, columns)}") from None
    data = data.reshape(-1, len(columns))
    bad = ~np.isfinite(data)
    for i, name in enumerate(columns):
        col = data[:, i]
        if name in whole:
            bad[:, i] |= np.isfinite(col) & (col != np.round(col))
        if name in nonnegative:
            bad[:, i] |= col < 0
    if bad.any():
        row, col = np.argwhere(bad)[0]
        name = columns[col]
        kind = "a whole number >= 0" if name in whole and name in nonnegative else "a whole number" if name in whole else "a finite number"
        raise StereotrackError(f"{path}: line {row + 2}: '{name}' must be {kind}, got {data[row, col]:g}")
    return data


def numeric_table(lines: list[str], width: int) -> np.ndarray | None:
    """Lines of ``width`` comma-separated numbers as an array, or None (the fast path: no Python loop per line)."""
    if not lines:
        return np.zeros((0, width))
    fields = ",".join(lines).split(",")
    if len(fields) != len(lines) * width:
        return None
    try:
        return np.asarray(fields, dtype=float).reshape(len(lines), width)
    except ValueError:
        return None


def _first_unreadable_line(body: str, columns: Sequence[str]) -> str:
    """Where numpy gave up: the first line without ``columns`` numbers (only run on the error path)."""
    for i, line in enumerate(body.splitlines(), start=2):
        fields = line.split(",")
        if len(fields) < len(columns):
            return f"line {i}: expected {len(columns)} values ({','.join(columns)}), got {len(fields)}"
        for name, text in zip(columns, fields):
            try:
                float(text)
            except ValueError:
                return f"line {i}: '{name}' must be a number, got {text.strip()[:40]!r}"
    return "not a readable numeric CSV file"


def finite(value: Any, where: str, lo: float = -math.inf, hi: float = math.inf, integer: bool = False) -> float | int:
    """A number from a parsed file: a real finite number (not a bool) in [lo, hi]; ``where`` names it in the error."""
    kind = "a whole number" if integer else "a number"
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise StereotrackError(f"{where}: expected {kind}, got {value!r:.60}")
    if not math.isfinite(value) or (integer and value != int(value)):
        raise StereotrackError(f"{where}: expected {kind}, got {value!r}")
    if not lo <= value <= hi:
        raise StereotrackError(f"{where}: expected {kind} from {lo:g} to {hi:g}, got {value!r}")
    return int(value) if integer else float(value)


# --------------------------------------------------------------------------- writing


class _Dumper(yaml.SafeDumper):
    """Quotes strings a YAML 1.2 reader would take for numbers (view names like 08, 1e3, 0x10)."""


def _represent_str(dumper: yaml.SafeDumper, value: str) -> yaml.Node:
    import re

    node = dumper.represent_str(value)
    if re.fullmatch(r"[-+]?(\d[\d_]*(\.\d*)?|\.\d+)([eE][-+]?\d+)?|0[xXoObB][0-9a-fA-F_]+", value):
        node.style = "'"
    return node


_Dumper.add_representer(str, _represent_str)


def dump_yaml(data: Any, **options: Any) -> str:
    options.setdefault("sort_keys", False)
    options.setdefault("default_flow_style", None)
    return yaml.dump(data, Dumper=_Dumper, allow_unicode=True, **options)


OUTPUT_KINDS: dict[str, Callable[[bytes], bool]] = {
    "tracks CSV": lambda head: head.startswith(b"frame,time,track_id"),
    "rerun recording": lambda head: head.startswith(b"RRF"),
    "PNG image": lambda head: head.startswith(b"\x89PNG"),
    "calibration file": lambda head: b"cameras:" in head,
    "calibration report": lambda head: b"calibration:" in head,
    "colour model": lambda head: b"kind: stereotrack colour model" in head,
    "config file": lambda head: True,  # read and validated as a config before it is updated
}


def check_output(path: str | Path, flag: str, kind: str, inputs: Iterable[str | Path] = ()) -> Path:
    """Refuse an output path before anything is opened: returns it as a Path.

    Not empty, not a folder, not a symbolic link, not one of this run's ``inputs``;
    its folder can be created; an existing file there is replaced only if it is
    an earlier output of the same ``kind`` (an empty file counts as one).
    """
    if not str(path).strip():
        raise StereotrackError(f"{flag}: give a file name")
    path = Path(path)
    if path.is_symlink():
        raise StereotrackError(f"{flag} {path}: is a symbolic link; give the real path (outputs are never written through links)")
    if path.is_dir():
        raise StereotrackError(f"{flag} {path}: is a folder; give a file name such as {path / ('out' + path.suffix)}")
    for other in inputs:
        if other is not None and _same_file(path, Path(other)):
            raise StereotrackError(f"{flag} {path}: is one of this run's inputs; choose another name")
    if _recording_file(path):
        raise StereotrackError(f"{flag} {path}: is a file of the recording in {path.parent}; outputs never replace a recording's own files")
    if path.exists():
        if not path.is_file():
            raise StereotrackError(f"{flag} {path}: is not a regular file")
        try:
            with open(path, "rb") as f:
                head = f.read(4096)
        except OSError as exc:
            raise StereotrackError(f"{flag} {path}: cannot replace it ({exc.strerror or exc})") from None
        if head and not OUTPUT_KINDS[kind](head):
            raise StereotrackError(f"{flag} {path}: exists and is not a {kind}; remove it or choose another name")
    _check_writable(path, flag)
    return path


def _check_writable(path: Path, flag: str) -> None:
    """Create and remove a scratch file where ``path`` will go (its first existing folder): /proc, a read-only
    disk or a missing permission is found before any work is done."""
    import tempfile

    parent = _first_existing(path.parent)
    if not parent.is_dir():
        raise StereotrackError(f"{flag} {path}: {parent} is not a folder")
    try:
        with tempfile.TemporaryFile(dir=parent, prefix=".stereotrack-probe-"):
            pass
    except OSError as exc:
        raise StereotrackError(f"{flag} {path}: cannot write in {parent} ({exc.strerror or exc})") from None


def _recording_file(path: Path) -> bool:
    """Whether ``path`` is one of the files that make up a recording folder (formats.md section 2)."""
    meta_path = path.parent / "meta.yaml"
    if path.name in ("meta.yaml", "frames.csv") and (path.parent / "frames.csv").is_file():
        return True
    if not meta_path.is_file():
        return False
    if path.name in ("frames.csv", "calib.yaml", "truth.csv", "meta.yaml"):
        return True
    try:
        meta = load_yaml(meta_path)
        videos = meta.get("videos") if isinstance(meta, dict) else None
        return isinstance(videos, dict) and path.name in {str(v) for v in videos.values()}
    except StereotrackError:
        return False


def _same_file(a: Path, b: Path) -> bool:
    if os.path.abspath(a) == os.path.abspath(b):
        return True
    try:
        return a.exists() and b.exists() and os.path.samefile(a, b)
    except OSError:
        return False


def _first_existing(folder: Path) -> Path:
    folder = folder.absolute()
    while not folder.exists() and folder != folder.parent:
        folder = folder.parent
    return folder


class AtomicOutput:
    """A file written under a temporary name beside ``path`` and renamed over it by ``commit()``.

    ``abort()`` (or a failed ``open``) removes the temporary file: the previous
    file at ``path``, if any, stays as it was. Folders it had to create are
    removed again on abort if they are still empty.
    """

    def __init__(self, path: str | Path, flag: str = "output"):
        self.path = Path(path)
        self.flag = flag
        self.temp = self.path.with_name(f".{self.path.name}.{os.getpid()}.partial")
        self._created: list[Path] = []
        self.file: io.IOBase | None = None

    def open(self, mode: str = "w", **kwargs: Any):
        try:
            missing = []
            folder = self.path.parent
            while not folder.exists():
                missing.append(folder)
                folder = folder.parent
            for d in reversed(missing):
                d.mkdir()
                self._created.append(d)
            self.file = open(self.temp, mode, **kwargs)
        except OSError as exc:
            self.abort()
            raise StereotrackError(f"{self.flag} {self.path}: cannot write it ({exc.strerror or exc})") from None
        return self.file

    def commit(self) -> None:
        if self.file is not None and not self.file.closed:
            self.file.flush()
            os.fsync(self.file.fileno())
            self.file.close()
        try:
            if self.path.exists():
                os.chmod(self.temp, stat.S_IMODE(self.path.stat().st_mode))
            os.replace(self.temp, self.path)
        except OSError as exc:
            self.abort()
            raise StereotrackError(f"{self.flag} {self.path}: cannot put the finished file in place ({exc.strerror or exc})") from None

    def abort(self) -> None:
        if self.file is not None and not self.file.closed:
            self.file.close()
        try:
            self.temp.unlink()
        except OSError:
            pass
        for d in reversed(self._created):
            try:
                d.rmdir()
            except OSError:
                break
        self._created = []


def write_text_atomic(path: str | Path, text: str, flag: str = "output") -> None:
    out = AtomicOutput(path, flag)
    f = out.open("w", encoding="utf-8")
    try:
        f.write(text)
    except BaseException:
        out.abort()
        raise
    out.commit()


def check_output_folder(path: str | Path, flag: str, overwrite: bool = False) -> Path:
    """A recording folder to create: not a file or a link; an existing one must be empty, or with ``overwrite``
    an earlier recording (it holds meta.yaml): --overwrite never empties a folder of other files."""
    if not str(path).strip():
        raise StereotrackError(f"{flag}: give a folder name")
    path = Path(path)
    if path.is_symlink():
        raise StereotrackError(f"{flag} {path}: is a symbolic link; give the real path")
    if path.exists() and not path.is_dir():
        raise StereotrackError(f"{flag} {path}: exists and is not a folder; choose another name")
    if path.is_dir() and any(path.iterdir()) and not overwrite:
        raise StereotrackError(f"{flag} {path}: folder exists and is not empty (choose another {flag} or add --overwrite)")
    if path.is_dir() and any(path.iterdir()) and not (path / "meta.yaml").is_file():
        raise StereotrackError(
            f"{flag} {path}: folder is not a recording (no meta.yaml); --overwrite replaces only a recording, choose another {flag}"
        )
    _check_writable(path / "x", flag)
    return path


def replace_folder(finished: Path, path: Path) -> None:
    """Put a completely written folder in place of ``path`` (which may exist): the old one goes only after."""
    import shutil

    old = path.with_name(f".{path.name}.{os.getpid()}.old")
    if path.exists():
        os.replace(path, old)
    os.replace(finished, path)
    shutil.rmtree(old, ignore_errors=True)


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
    write_text_atomic(path, text)


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
