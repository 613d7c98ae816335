"""Generated sections of a markdown file: ``<!-- section: NAME -->`` ... ``<!-- /section: NAME -->``.

Several scripts write parts of one document (docs/evaluation.md): each
replaces its own section and keeps the others.
"""

from __future__ import annotations

import re
from pathlib import Path


def _pattern(name: str) -> re.Pattern:
    return re.compile(rf"<!-- section: {re.escape(name)} -->\n.*?<!-- /section: {re.escape(name)} -->\n?", re.S)


def sections(text: str) -> dict[str, str]:
    """Every section of ``text``, by name, markers included."""
    names = re.findall(r"<!-- section: ([\w-]+) -->", text)
    return {n: m.group(0) for n in names if (m := _pattern(n).search(text))}


def replace_section(path: str | Path, name: str, body: str) -> None:
    """Put ``body`` into section ``name`` of the file (appended at the end when the file has no such section)."""
    path = Path(path)
    text = path.read_text() if path.is_file() else ""
    block = f"<!-- section: {name} -->\n{body.rstrip()}\n<!-- /section: {name} -->\n"
    if _pattern(name).search(text):
        text = _pattern(name).sub(lambda _: block, text, count=1)
    else:
        text = text.rstrip("\n") + ("\n\n" if text else "") + block
    path.write_text(text)


def keep_sections(old: str, new: str) -> str:
    """``new`` with the sections of ``old`` that ``new`` lacks appended (a script rewriting a whole file keeps the others' parts)."""
    mine = sections(new)
    kept = [block for name, block in sections(old).items() if name not in mine]
    if not kept:
        return new
    return new.rstrip("\n") + "\n\n" + "\n".join(b.rstrip("\n") + "\n" for b in kept)
