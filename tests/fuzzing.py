"""Property-based fuzzing of every file format and every command's options (hypothesis).

The invariant, for any input: the command exits 0, or exits 2 with exactly one
line on stderr; no traceback; no file changed unless it is the command's own
output and the command succeeded; and it ends within 30 s.

Commands run in this process through ``stereotrack.cli.main(argv)`` (fast: no
interpreter start, the compiled kernels stay loaded), with stdout and stderr
captured at the file-descriptor level (OpenCV and FFmpeg write there too) and
a 30 s alarm. Where a valid value means more work (--frames, --seconds) the
strategies draw it small: the fuzzing is about refusals and quick runs, not
long jobs. Shared by tests/test_fuzz.py (a few dozen examples per property)
and benchmarks/fuzz.py (thousands; it reports the counts).
"""

from __future__ import annotations

import contextlib
import copy
import hashlib
import io
import os
import re
import shutil
import signal
import stat
import sys
import tempfile
import time
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

import yaml
from hypothesis import strategies as st

# As `stereotrack` sets them at start (cli.quiet_native_libraries): FFmpeg reads its level once, at its first use,
# which in this process may come before the first command.
os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")
os.environ.setdefault("OPENCV_LOG_LEVEL", "SILENT")

LIMIT_SECONDS = 30.0
PROGRESS_LINE = re.compile(r"^[a-z ]+ \[[#-]{20}\] \d+/\d+ ")  # console.Progress on a non-terminal: a line every 10%
COUNTS: Counter = Counter()  # (property, outcome) -> examples run, for benchmarks/fuzz.py


class FuzzTimeout(BaseException):
    """Raised by the alarm in the command's thread; a BaseException so no `except Exception` swallows it."""


@dataclass
class Outcome:
    argv: list[str]
    rc: int | None
    out: str
    err: str
    seconds: float
    changed: list[str]
    new: list[str]

    @property
    def err_lines(self) -> list[str]:
        return [ln for ln in self.err.splitlines() if ln.strip()]

    def problems(self, outputs: tuple[str, ...] = ()) -> list[str]:
        """What breaks the invariant (empty: it holds)."""
        bad = []
        if self.rc not in (0, 2):
            bad.append(f"exit {self.rc}")
        if "Traceback (most recent call last)" in self.out + self.err:
            bad.append("traceback")
        # A run that stopped after it started (a camera stalled mid-recording) may have logged progress before its
        # one error line, and keeps what it recorded (it says so): a refusal of bad input does neither.
        error = [ln for ln in self.err_lines[:-1] if not PROGRESS_LINE.match(ln)] + self.err_lines[-1:]
        if self.rc == 2 and len(error) != 1:
            bad.append(f"{len(self.err_lines)} lines on stderr")
        kept = self.rc == 2 and " kept in " in self.err_lines[-1]
        allowed = set(outputs) if self.rc == 0 or kept else set()
        for rel in self.changed + self.new:
            if rel not in allowed and not any(rel.startswith(a.rstrip("*")) for a in allowed if a.endswith("*")):
                bad.append(f"{'changed' if rel in self.changed else 'left'} {rel}")
        if self.seconds > LIMIT_SECONDS:
            bad.append(f"took {self.seconds:.0f} s")
        return bad

    def describe(self) -> str:
        return f"stereotrack {' '.join(map(repr, self.argv))}: exit {self.rc} in {self.seconds:.1f} s; stderr: {self.err.strip()[-800:]!r}"


def snapshot(root: Path) -> dict[str, str]:
    """Every file under root -> a content hash (links by target; pipes and devices by kind)."""
    out = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for name in filenames + [n for n in dirnames if os.path.islink(os.path.join(dirpath, n))]:
            p = os.path.join(dirpath, name)
            st_ = os.lstat(p)
            if stat.S_ISLNK(st_.st_mode):
                out[os.path.relpath(p, root)] = "link:" + os.readlink(p)
            elif stat.S_ISREG(st_.st_mode):
                with open(p, "rb") as f:
                    out[os.path.relpath(p, root)] = hashlib.sha256(f.read()).hexdigest()
            else:
                out[os.path.relpath(p, root)] = "special"
    return out


@contextlib.contextmanager
def captured() -> io.StringIO:
    """Capture fds 1 and 2 (Python, OpenCV and FFmpeg output alike) into two strings."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = (os.dup(1), os.dup(2))
    files = (tempfile.TemporaryFile(), tempfile.TemporaryFile())
    old = (sys.stdout, sys.stderr)
    result = {"out": "", "err": ""}
    try:
        os.dup2(files[0].fileno(), 1)
        os.dup2(files[1].fileno(), 2)
        sys.stdout = io.TextIOWrapper(os.fdopen(os.dup(1), "wb"), write_through=True)
        sys.stderr = io.TextIOWrapper(os.fdopen(os.dup(2), "wb"), write_through=True)
        yield result
    finally:
        for stream in (sys.stdout, sys.stderr):
            stream.flush()
            stream.close()
        sys.stdout, sys.stderr = old
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        os.close(saved[0])
        os.close(saved[1])
        for key, f in zip(("out", "err"), files, strict=True):
            f.seek(0)
            result[key] = f.read().decode(errors="replace")
            f.close()


@contextlib.contextmanager
def time_limit(seconds: float):
    def alarm(signum, frame):
        raise FuzzTimeout(f"still running after {seconds:.0f} s")

    previous = signal.signal(signal.SIGALRM, alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def run_cli(argv: list[str], cwd: Path, name: str = "") -> Outcome:
    """Run ``stereotrack ARGV`` in this process, in ``cwd``; what it printed, its exit status, what it changed."""
    from stereotrack import cli

    before = snapshot(cwd)
    here = os.getcwd()
    t0 = time.monotonic()
    rc: int | None
    with captured() as cap:
        os.chdir(cwd)
        try:
            with time_limit(LIMIT_SECONDS + 5):
                rc = cli.main(list(argv))
        except SystemExit as exc:  # argparse's --help and --version
            rc = exc.code if isinstance(exc.code, int) else 2
        except FuzzTimeout as exc:
            rc = None
            print(f"fuzz: {exc}", file=sys.stderr)
        finally:
            os.chdir(here)
    seconds = time.monotonic() - t0
    after = snapshot(cwd)
    outcome = Outcome(
        list(argv),
        rc,
        cap["out"],
        cap["err"],
        seconds,
        sorted(k for k in before if before[k] != after.get(k)),
        sorted(k for k in after if k not in before),
    )
    if name:
        COUNTS[(name, "ok" if rc == 0 else "refused" if rc == 2 else "other")] += 1
    return outcome


def check(outcome: Outcome, outputs: tuple[str, ...] = ()) -> None:
    problems = outcome.problems(outputs)
    assert not problems, f"{'; '.join(problems)}: {outcome.describe()}"


# --------------------------------------------------------------------------- the workspace


def make_workspace(fixture: Path) -> Path:
    """A fresh copy of the fixture folder (a small recording and the files the commands read)."""
    work = Path(tempfile.mkdtemp(prefix="fuzz_"))
    shutil.copytree(fixture, work / "w", symlinks=True)
    return work / "w"


def build_fixture(folder: Path) -> Path:
    """A 6-frame 96x72 recording with truth and a tracks file, a board, a scene and three real chessboard pairs."""
    from stereotrack.simulation.presets import make_preset
    from stereotrack.simulation.write import render_scene

    folder.mkdir(parents=True, exist_ok=True)
    rec = render_scene(make_preset("pendulum4", n_frames=6, width=96, height=72), folder / "rec", progress=False)
    (folder / "calib.yaml").write_bytes((rec / "calib.yaml").read_bytes())
    (folder / "config.yaml").write_bytes((rec / "config.yaml").read_bytes())
    (folder / "truth.csv").write_bytes((rec / "truth.csv").read_bytes())
    (folder / "board.yaml").write_text("type: charuco\nsquares: [7, 5]\nsquare: 0.03\nmarker: 0.022\ndictionary: DICT_5X5_100\n")
    (folder / "chess.yaml").write_text("type: chessboard\nsquares: [10, 7]\nsquare: 0.03\n")
    (folder / "scene.yaml").write_text("preset: pendulum4\nn_frames: 2\nrig: {width: 64, height: 48}\n")
    real = Path(__file__).parent / "data" / "opencv-stereo-chessboard"
    for side in ("left", "right"):
        (folder / side).mkdir(exist_ok=True)
        for i in (1, 2, 3):
            shutil.copy(real / f"{side}0{i}.jpg", folder / side / f"{side}0{i}.jpg")
    with captured():
        from stereotrack import cli

        cli.main(["track", str(rec), "--quiet", "--out", str(folder / "tracks.csv")])
    (rec / "tracks.csv").write_bytes((folder / "tracks.csv").read_bytes())  # a user's earlier result in the recording
    return folder


# --------------------------------------------------------------------------- strategies

BOUNDARY_NUMBERS = [0, -1, 1, 2**31, 2**63, -(2**63), 10**30, 1e308, -1e308, 1e-308, float("nan"), float("inf"), float("-inf"), 0.5, -0.0]
BOUNDARY_STRINGS = [
    "nan",
    "inf",
    "-inf",
    "1e308",
    "-1",
    "0",
    "-0",
    "1e-9",
    "1e9",
    str(10**30),
    "",
    " ",
    "abc",
    "1,2",
    "0x10",
    "1_0",
    "٣",
    "1e",
    "--",
]

scalars = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(min_value=-(2**70), max_value=2**70),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=12),
    st.sampled_from(BOUNDARY_NUMBERS),
)
values = st.recursive(
    scalars, lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=6), inner, max_size=3), max_leaves=10
)
option_values = st.one_of(
    st.sampled_from(BOUNDARY_STRINGS),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(min_value=-(10**12), max_value=10**12).map(str),
    st.text(alphabet=st.characters(blacklist_categories=("Cs",), blacklist_characters="\x00"), max_size=8),
)


def _paths(doc, prefix=()) -> list[tuple]:
    out = [prefix]
    if isinstance(doc, dict):
        for k, v in doc.items():
            out += _paths(v, (*prefix, k))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            out += _paths(v, (*prefix, i))
    return out


def _set(doc, path, value):
    if not path:
        return value
    target = doc
    for key in path[:-1]:
        target = target[key]
    target[path[-1]] = value
    return doc


@st.composite
def yaml_documents(draw, valid_text: str) -> bytes:
    """A hostile variant of a valid YAML file: one value replaced, a key dropped or added, or bytes broken."""
    how = draw(st.sampled_from(["value", "value", "value", "drop", "add", "bytes", "truncate", "flip", "alias"]))
    doc = yaml.safe_load(valid_text)
    if how in ("value", "drop", "add", "alias"):
        doc = copy.deepcopy(doc)
        path = draw(st.sampled_from(_paths(doc)))
        if how == "value":
            doc = _set(doc, path, draw(values))
        elif how == "drop" and path:
            parent = doc
            for key in path[:-1]:
                parent = parent[key]
            del parent[path[-1]]
        elif how == "add":
            parent = doc
            for key in path:
                parent = parent[key]
            if isinstance(parent, dict):
                parent[draw(st.text(max_size=8))] = draw(values)
            elif isinstance(parent, list):
                parent.append(draw(values))
        text = yaml.safe_dump(doc, sort_keys=False, allow_unicode=draw(st.booleans()))
        if how == "alias" and path:  # the value at ``path`` becomes a reference to a list of 10^9 leaves
            bomb = (
                "["
                + ", ".join(
                    ["&a [x,x,x,x,x,x,x,x,x,x]"] + [f"&{c} [" + ",".join([f"*{p}"] * 10) + "]" for p, c in zip("abcdefgh", "bcdefghi")]
                )
                + "]"
            )
            text = yaml.safe_dump(_set(doc, path, "BOMB"), sort_keys=False).replace("BOMB", bomb, 1)
        return text.encode()
    raw = valid_text.encode()
    if how == "bytes":
        return draw(st.binary(max_size=3000))
    if how == "truncate":
        return raw[: draw(st.integers(0, len(raw)))]
    data = bytearray(raw)
    for _ in range(draw(st.integers(1, 8))):
        data[draw(st.integers(0, len(data) - 1))] = draw(st.integers(0, 255))
    return bytes(data)


CSV_TOKENS = ["nan", "inf", "-inf", "-1", "1e308", "", "abc", "1.5", "0", " 3", "1e400", "٣", "0x1", "-0"]


@st.composite
def csv_documents(draw, valid_text: str) -> bytes:
    """A hostile variant of a valid CSV file: a field replaced, a row cut, dropped, repeated or swapped, or bytes broken."""
    lines = valid_text.splitlines()
    how = draw(st.sampled_from(["field", "field", "cut", "drop", "repeat", "swap", "header", "bytes", "truncate"]))
    if how == "bytes":
        return draw(st.binary(max_size=3000))
    if how == "truncate":
        raw = valid_text.encode()
        return raw[: draw(st.integers(0, len(raw)))]
    i = draw(st.integers(0, len(lines) - 1))
    fields = lines[i].split(",")
    if how == "field":
        j = draw(st.integers(0, len(fields) - 1))
        fields[j] = draw(
            st.sampled_from(CSV_TOKENS) | st.floats(allow_nan=True, allow_infinity=True).map(repr) | st.integers(-(10**20), 10**20).map(str)
        )
        lines[i] = ",".join(fields)
    elif how == "cut":
        lines[i] = ",".join(fields[: draw(st.integers(0, len(fields)))])
    elif how == "drop":
        del lines[i]
    elif how == "repeat":
        lines.insert(i, lines[i])
    elif how == "swap":
        j = draw(st.integers(0, len(lines) - 1))
        lines[i], lines[j] = lines[j], lines[i]
    elif how == "header":
        lines[0] = ",".join(draw(st.permutations(lines[0].split(","))))
    ending = draw(st.sampled_from(["\n", "\r\n", ""]))
    return (ending or "\n").join(lines).encode() + ending.encode()
