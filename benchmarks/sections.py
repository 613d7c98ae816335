"""Generated sections of a markdown file: ``<!-- section: NAME -->`` ... ``<!-- /section: NAME -->``.

Several scripts write parts of one document (docs/evaluation.md): each
replaces its own section and keeps the others.
"""

from __future__ import annotations

import re

from stereotrack.files import replace_section  # noqa: F401  (one writer of sections: atomic, text outside kept byte for byte)


def _pattern(name: str) -> re.Pattern:
    return re.compile(rf"<!-- section: {re.escape(name)} -->\n.*?<!-- /section: {re.escape(name)} -->\n?", re.S)


def sections(text: str) -> dict[str, str]:
    """Every section of ``text``, by name, markers included."""
    names = re.findall(r"<!-- section: ([\w-]+) -->", text)
    return {n: m.group(0) for n in names if (m := _pattern(n).search(text))}


def keep_sections(old: str, new: str) -> str:
    """``new`` with the sections of ``old`` that ``new`` lacks appended (a script rewriting a whole file keeps the others' parts)."""
    mine = sections(new)
    kept = [block for name, block in sections(old).items() if name not in mine]
    if not kept:
        return new
    return new.rstrip("\n") + "\n\n" + "\n".join(b.rstrip("\n") + "\n" for b in kept)
