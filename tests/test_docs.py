"""Generated parts of the README match what generates them."""

from __future__ import annotations

import runpy
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_the_readme_layout_block_is_the_generated_one():
    layout = runpy.run_path(str(ROOT / "docs" / "layout.py"))["layout"]()
    readme = (ROOT / "README.md").read_text()
    block = readme.split("<!-- section: layout -->\n```\n")[1].split("\n```\n<!-- /section: layout -->")[0]
    assert block == layout, "regenerate it: .venv/bin/python docs/layout.py, pasted between the README's layout markers"


def test_every_module_the_readme_names_exists():
    import re

    readme = (ROOT / "README.md").read_text()
    named = set(re.findall(r"`((?:stereotrack/)?[a-z_]+(?:/[a-z_]+)*\.py)`", readme))
    files = [p.relative_to(ROOT).as_posix() for d in ("stereotrack", "docs", "benchmarks", "tests") for p in (ROOT / d).rglob("*.py")] + [
        "dev.py"
    ]
    missing = [n for n in sorted(named) if not any(f == n or f.endswith("/" + n) for f in files)]
    assert not missing, f"the README names modules that do not exist: {missing}"
