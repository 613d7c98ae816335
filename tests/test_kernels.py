"""How kernels are compiled and cached: every stage's kernels are registered, and a change to any kernel file
renews every kernel file's stamp, so numba recompiles callers whose callee changed (numba issue 1833)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import stereotrack
from stereotrack.kernels import KERNELS, kernel_files

PACKAGE = Path(stereotrack.__file__).resolve().parent


def test_every_stage_has_its_kernels_beside_it_and_registered():
    assert {f.parent.name for f in kernel_files()} == {"stereotrack", "evidence", "particles", "objects", "tracks"}
    import stereotrack.evidence.blob_kernels
    import stereotrack.evidence.kernels
    import stereotrack.objects.kernels
    import stereotrack.particles.kernels
    import stereotrack.tracks.kernels  # noqa: F401

    homes = {k.py_func.__module__ for k in KERNELS}
    assert homes >= {
        "stereotrack.kernels",
        "stereotrack.evidence.kernels",
        "stereotrack.evidence.blob_kernels",
        "stereotrack.objects.kernels",
        "stereotrack.tracks.kernels",
    }


def _import_kernels(copy: Path) -> None:
    subprocess.run(
        [sys.executable, "-c", "import stereotrack.kernels"], cwd=copy, env=dict(os.environ, PYTHONPATH=str(copy)), check=True, timeout=120
    )


def test_a_changed_kernel_file_renews_every_kernel_files_stamp(tmp_path):
    copy = tmp_path / "pkg"
    shutil.copytree(PACKAGE, copy / "stereotrack", ignore=shutil.ignore_patterns("__pycache__", "data"))
    files = [copy / "stereotrack" / "kernels.py", *sorted((copy / "stereotrack").glob("*/*kernels.py"))]
    assert copy / "stereotrack" / "evidence" / "blob_kernels.py" in files
    _import_kernels(copy)  # first import: records the sources' digest
    past = 1_000_000_000.0
    for f in files:
        os.utime(f, (past, past))
    _import_kernels(copy)  # nothing changed: stamps stay
    assert all(f.stat().st_mtime == past for f in files)
    tracks = copy / "stereotrack" / "tracks" / "kernels.py"
    tracks.write_text(tracks.read_text() + "\n# a changed callee\n")
    os.utime(tracks, (past, past))
    _import_kernels(copy)  # one file changed: every kernel file gets a new stamp (numba's cache key)
    assert all(f.stat().st_mtime > past for f in files)
