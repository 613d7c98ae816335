#!/usr/bin/env python3
"""Set up a virtual environment in .venv (first run, or when pyproject.toml changed), then run.

    python3 dev.py demo [ARGS]   # track the bundled demo recording
    python3 dev.py test [ARGS]   # the whole test suite (ARGS go to pytest)
    python3 dev.py bench [ARGS]  # the benchmark (--docs BENCHMARKS.md writes its table there)

Needs only Python >= 3.11 with pip and venv; everything else is installed into .venv.
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
import venv
from pathlib import Path

ROOT = Path(__file__).resolve().parent
VENV = ROOT / ".venv"
BIN = VENV / ("Scripts" if os.name == "nt" else "bin")
PY = BIN / ("python.exe" if os.name == "nt" else "python")
STAMP = VENV / ".stereotrack-installed"


def ensure_env() -> None:
    if sys.version_info < (3, 11):  # noqa: UP036 (dev.py may be started by an older Python: say so)
        sys.exit(f"stereotrack needs Python 3.11 or newer; this is {sys.version.split()[0]}")
    wanted = hashlib.sha256((ROOT / "pyproject.toml").read_bytes()).hexdigest()
    if STAMP.is_file() and STAMP.read_text().strip() == wanted and PY.exists():
        return
    if not PY.exists():
        print("creating virtual environment in .venv ...", flush=True)
        venv.EnvBuilder(with_pip=True).create(VENV)
    print("installing stereotrack and its dependencies into .venv (first run takes a minute or two) ...", flush=True)
    subprocess.check_call([str(PY), "-m", "pip", "install", "--quiet", "--upgrade", "pip"])
    subprocess.check_call([str(PY), "-m", "pip", "install", "--quiet", "-e", f"{ROOT}[test,eval]"])
    print("compiling the tracker's kernels (once per install, about a minute) ...", flush=True)
    subprocess.check_call([str(PY), "-c", "from stereotrack.pipeline.tracker import warm_up; warm_up()"])
    STAMP.write_text(wanted)


def main() -> int:
    if len(sys.argv) < 2 or sys.argv[1] not in {"demo", "test", "bench"}:
        print(__doc__)
        return 2
    what, rest = sys.argv[1], sys.argv[2:]
    ensure_env()
    os.chdir(ROOT)
    if what == "demo":
        cmd = [str(PY), "-m", "stereotrack", "demo", *rest]
    elif what == "test":
        cmd = [str(PY), "-m", "pytest", *rest]
    else:
        cmd = [str(PY), "-m", "stereotrack", "bench", *rest]
    return subprocess.call(cmd)


if __name__ == "__main__":
    sys.exit(main())
