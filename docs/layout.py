"""Print the package's layout for the README: every folder in the order data flows, each module with its docstring's first line.

.venv/bin/python docs/layout.py        # paste between the README's layout markers (tests/test_docs.py checks them)
"""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "stereotrack"
# (folder or top-level module, one-line role) in the order of the data flow, core types first
ORDER = [
    ("core", "core types every layer uses"),
    ("capture", "sources: live cameras, recordings replayed"),
    ("evidence", "per frame, camera and target: what the image says"),
    ("particles", "the particle population of each target"),
    ("objects", "particles -> ball candidates in 3D"),
    ("tracks", "identities over time"),
    ("sinks", "where results go"),
    ("pipeline", "the stages wired into a tracker, run from a source into sinks"),
    ("calibration", "the rig from board views"),
    ("simulation", "synthetic scenes with exact ground truth"),
    ("commands", "one module per `stereotrack` command"),
]
CORE = [
    "errors.py",
    "console.py",
    "files.py",
    "camera.py",
    "config.py",
    "frames.py",
    "results.py",
    "recording.py",
    "evaluate.py",
    "kernels.py",
]


def first_line(path: Path) -> str:
    doc = ast.get_docstring(ast.parse(path.read_text())) or ""
    return doc.strip().splitlines()[0].rstrip(".") if doc.strip() else ""


def entries(folder: Path, indent: str) -> list[str]:
    out = []
    for path in sorted(folder.iterdir()):
        if path.name.startswith("__") or path.name.startswith("."):
            continue
        if path.is_dir() and (path / "__init__.py").exists():
            out.append(f"{indent}{path.name + '/':<22}{first_line(path / '__init__.py')}")
            out += entries(path, indent + "  ")
        elif path.suffix == ".py" and not path.name.startswith("_"):
            out.append(f"{indent}{path.name:<22}{first_line(path)}")
    return out


def layout() -> str:
    lines = []
    for name, role in ORDER:
        if name == "core":
            lines.append(f"stereotrack/            {role}")
            lines += [f"  {m:<22}{first_line(PACKAGE / m)}" for m in CORE]
        else:
            lines.append(f"  {name + '/':<22}{role}")
            lines += entries(PACKAGE / name, "    ")
    return "\n".join(lines)


if __name__ == "__main__":
    print(layout())
