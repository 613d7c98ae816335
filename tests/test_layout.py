"""The package's shape: imports point one way (core types <- stages <- pipeline <- commands), no cycles, small modules,
and the tree formatted and linted as pyproject.toml says."""

from __future__ import annotations

import ast
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

# Each entry is a layer; a module may import from its own layer or the ones above it in this list, never below.
# Inside a layer, imports may go either way but must not form a cycle.
LAYERS = [
    {"errors", "console", "files", "kernels", "argtypes"},  # helpers every module may use
    {"camera", "config", "frames", "results", "recording", "evaluate"},  # core types
    {"evidence"},  # tracker stages, in data-flow order
    {"particles"},
    {"objects"},
    {"tracks"},
    {"calibration"},  # the rig from board views
    {"simulation"},  # synthetic scenes (renders boards, so it may use calibration's board model)
    {"capture"},  # sources: devices (simulated cameras render scenes), pairing, replay
    {"sinks"},  # tracks CSV, recorder, viewer
    {"pipeline"},  # stages wired into trackers, run from a source into sinks
    {"commands"},
    {"cli", "__main__"},
]
EXEMPT = {"stereotrack", "stereotrack._compat"}  # the package root and the old-path aliases (imports by name, at run time)
MAX_LINES = 600


def module_name(path: Path, root: Path = ROOT) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def modules(root: Path = ROOT) -> dict[str, Path]:
    return {module_name(p, root): p for p in sorted((root / "stereotrack").rglob("*.py"))}


def imports_of(path: Path, known: set[str], root: Path = ROOT) -> set[str]:
    """Every stereotrack module a file imports, at the top or inside a function."""
    me = module_name(path, root)
    package = me if path.name == "__init__.py" else me.rpartition(".")[0]
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target.split(".")[0] != "stereotrack":
                continue
            for alias in node.names:
                sub = f"{target}.{alias.name}"
                out.add(sub if sub in known else target)
        elif isinstance(node, ast.Import):
            out |= {a.name for a in node.names if a.name.split(".")[0] == "stereotrack"}
    out.discard(me)
    return out


def graph(root: Path = ROOT) -> dict[str, set[str]]:
    mods = modules(root)
    return {name: imports_of(path, set(mods), root) for name, path in mods.items()}


def layer(module: str) -> int:
    unit = module.split(".")[1]
    for rank, units in enumerate(LAYERS):
        if unit in units:
            return rank
    raise AssertionError(f"{module}: its folder or file is in no layer of tests/test_layout.py; add it where it belongs")


def upward_imports(g: dict[str, set[str]]) -> list[str]:
    return [
        f"{a} imports {b}"
        for a, targets in g.items()
        if a not in EXEMPT
        for b in sorted(targets)
        if b not in EXEMPT and layer(b) > layer(a)
    ]


def cycles(g: dict[str, set[str]]) -> list[list[str]]:
    # A package's __init__ re-exporting its own modules is how a package shows its contents, not a cycle.
    edges = {a: {b for b in targets if b in g and not b.startswith(a + ".") and b not in EXEMPT} for a, targets in g.items()}
    state: dict[str, int] = {}
    found: list[list[str]] = []

    def visit(node: str, path: list[str]) -> None:
        state[node] = 1
        for nxt in sorted(edges[node]):
            if state.get(nxt) == 1:
                found.append(path[path.index(nxt) :] + [nxt])
            elif nxt not in state:
                visit(nxt, path + [nxt])
        state[node] = 2

    for node in sorted(edges):
        if node not in state:
            visit(node, [node])
    return found


def test_every_import_points_to_the_same_or_a_lower_layer():
    wrong = upward_imports(graph())
    assert not wrong, "imports against the data flow:\n" + "\n".join(wrong)


def test_no_import_cycle():
    found = cycles(graph())
    assert not found, "import cycles:\n" + "\n".join(" -> ".join(c) for c in found)


def test_the_checks_see_an_upward_import_and_a_cycle(tmp_path):
    """The checks above would pass on a graph they cannot read: show them a tree with both faults."""
    files = {
        "stereotrack/__init__.py": "",
        "stereotrack/evidence/__init__.py": "",
        "stereotrack/evidence/blobs.py": "def f():\n    from ..pipeline.tracker import Tracker  # upward, even inside a function\n",
        "stereotrack/pipeline/__init__.py": "from .tracker import Tracker\n",
        "stereotrack/pipeline/tracker.py": "from ..evidence.blobs import f\nfrom .run import go\nclass Tracker: ...\n",
        "stereotrack/pipeline/run.py": "from . import tracker\ndef go(): ...\n",
    }
    for name, text in files.items():
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text(text)
    g = graph(tmp_path)
    assert upward_imports(g) == ["stereotrack.evidence.blobs imports stereotrack.pipeline.tracker"]
    assert {tuple(c) for c in cycles(g)} >= {
        ("stereotrack.pipeline.run", "stereotrack.pipeline.tracker", "stereotrack.pipeline.run")
    } or any(set(c) == {"stereotrack.pipeline.run", "stereotrack.pipeline.tracker"} for c in cycles(g))


def test_no_source_module_is_over_600_lines():
    long = {name: n for name, path in modules().items() if (n := len(path.read_text().splitlines())) > MAX_LINES}
    assert not long, f"split these by concern: {long}"


def test_every_module_is_in_a_layer():
    for name in modules():
        if name not in EXEMPT:
            layer(name)


def _ruff() -> str:
    exe = Path(sys.executable).parent / "ruff"
    found = str(exe) if exe.exists() else shutil.which("ruff")
    if not found:
        pytest.skip("ruff is not installed (it comes with the 'test' extra: pip install -e '.[test]')")
    return found


def test_the_tree_is_formatted_and_linted():
    ruff = _ruff()
    fmt = subprocess.run([ruff, "format", "--check", "."], cwd=ROOT, capture_output=True, text=True)
    lint = subprocess.run([ruff, "check", "--output-format", "concise", "."], cwd=ROOT, capture_output=True, text=True)
    assert fmt.returncode == 0, f"run `{ruff} format .`:\n{fmt.stdout[-2000:]}"
    assert lint.returncode == 0, f"run `{ruff} check --fix .` and mend the rest:\n{lint.stdout[-2000:]}"
