"""Index of the normative IDs declared in the spec (`### ID — title` headings of spec/*.md).

The conformance suite's coverage is measured against this index: every rule (`R-…`) and
invariant (`INV-…`) heading must be exercised by at least one case.
"""

from __future__ import annotations

import re
from functools import lru_cache
from pathlib import Path
from typing import Iterable

from agspec.resources import spec_dir

# `### R-PICK — picks`: level-3 heading, an upper-case ID, then an em dash (or hyphen) and the title.
_HEADING = re.compile(r"^###\s+([A-Z][A-Z0-9]*(?:-[A-Z0-9]+)+)\s+(?:—|-{1,2})\s+(.*?)\s*$")


@lru_cache(maxsize=8)
def _index(root: str) -> tuple[tuple[str, str, str, int], ...]:
    out = []
    for path in sorted(Path(root).glob("*.md")):
        for lineno, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
            m = _HEADING.match(line)
            if m:
                out.append((m.group(1), m.group(2), path.name, lineno))
    return tuple(out)


def spec_headings(root: Path | None = None) -> list[tuple[str, str, str, int]]:
    """Every `### ID — title` heading: (id, title, file name, line), in file then line order."""
    return list(_index(str(root or spec_dir())))


def spec_ids(prefixes: Iterable[str] = ("R-", "INV-"), root: Path | None = None) -> list[str]:
    """The declared IDs starting with one of ``prefixes``, in spec order, without duplicates."""
    prefixes = tuple(prefixes)
    seen: dict[str, None] = {}
    for ident, _title, _file, _line in spec_headings(root):
        if ident.startswith(prefixes):
            seen.setdefault(ident, None)
    return list(seen)


def spec_titles(root: Path | None = None) -> dict[str, str]:
    """ID -> heading title (first declaration wins)."""
    out: dict[str, str] = {}
    for ident, title, _file, _line in spec_headings(root):
        out.setdefault(ident, title)
    return out
