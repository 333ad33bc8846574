"""Index of the normative IDs declared in the spec (`### ID — title` headings of spec/*.md).

The conformance suite's coverage is measured against this index: every rule (`R-…`) and
invariant (`INV-…`) heading must be exercised by at least one case.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Iterable

from agspec.resources import spec_dir
from agspec.suggest import closest

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


# --- entries: the text of one ID, for `agspec explain` ------------------------------------------------

# A declaring heading of any level 2-4 (`## F-CODES — …` as well as `### R-PICK — …`).
_ANY_HEADING = re.compile(r"^(#{2,4})\s+([A-Z][A-Z0-9]*(?:-[A-Z0-9]+)+)\s+(?:—|-{1,2})\s+(.*?)\s*$")
# An inline resolution: `*Resolution RES-… — title [tag].*` opens a paragraph (spec/README.md "Resolutions").
_RESOLUTION = re.compile(r"^\*Resolution\s+(RES-[A-Z0-9-]+)\s+(?:—|-{1,2})\s+")
# its title: up to the source tag `[…]` or the closing `.*`, which may sit on a following line
_RESOLUTION_TITLE = re.compile(r"^(.*?)\s*(?:\[[^\]]*\]\s*)?\.?\*", re.S)
# A table row naming a diagnostic code in its first cell: `| AG305 | E | meaning | … |` (F-CODES lists each
# code in two tables: meaning and example message, then snippet, pointer, hint and rule).
_CODE_ROW = re.compile(r"^\|\s*(AG\d{3})\s*\|")


def _cells(line: str) -> list[str]:
    return [c.strip() for c in line.strip().strip("|").split("|")]


@dataclass(frozen=True)
class Entry:
    """One spec entry: its ID, kind (heading, resolution or code), title, where it is and its Markdown."""

    id: str
    kind: str
    title: str
    file: str
    line: int
    text: str


@lru_cache(maxsize=8)
def _entries(root: str) -> tuple[Entry, ...]:
    out: list[Entry] = []
    codes: dict[str, list] = {}  # code -> [file, line of its first row, rows as {column: cell}]
    for path in sorted(Path(root).glob("*.md")):
        if path.name == "README.md":
            continue  # the index restates summaries; the chapters declare
        lines = path.read_text(encoding="utf-8").splitlines()
        header: list[str] = []
        for i, line in enumerate(lines):
            if m := _ANY_HEADING.match(line):
                level = len(m.group(1))
                end = next((k for k in range(i + 1, len(lines))
                            if re.match(rf"^#{{1,{level}}}\s", lines[k])), len(lines))
                out.append(Entry(m.group(2), "heading", m.group(3), path.name, i + 1,
                                 "\n".join(lines[i + 1:end]).strip()))
            elif m := _RESOLUTION.match(line):
                end = next((k for k in range(i + 1, len(lines)) if not lines[k].strip()), len(lines))
                text = "\n".join(lines[i:end]).strip()
                title = _RESOLUTION_TITLE.match(" ".join(text[m.end():].split()))
                out.append(Entry(m.group(1), "resolution", title.group(1) if title else "", path.name, i + 1, text))
            elif (m := _CODE_ROW.match(line)) and header:
                codes.setdefault(m.group(1), [path.name, i + 1, []])[2].append(dict(zip(header, _cells(line))))
            if line.startswith("|") and i + 1 < len(lines) and re.match(r"^\|[\s:|-]+\|\s*$", lines[i + 1]):
                header = [c.lower() for c in _cells(line)]
            elif not line.startswith("|"):
                header = []
    for code, (name, lineno, rows) in codes.items():
        fields: dict[str, str] = {}
        for row in rows:
            for key, value in row.items():
                fields.setdefault({"sev": "severity"}.get(key, key), value)
        severity = {"E": "error", "W": "warning"}.get(fields.pop("severity", ""), "")
        meaning = fields.pop("meaning", "")
        fields.pop("code", None)
        body = [f"{severity}: {meaning}" if severity else meaning, ""]
        body += [f"* {key}: {value}" for key, value in fields.items() if value and value != "—"]
        out.append(Entry(code, "code", meaning, name, lineno, "\n".join(body).strip()))
    return tuple(out)


def spec_entries(root: Path | None = None) -> list[Entry]:
    """Every declared entry of spec/ (headings, inline resolutions, diagnostic codes), in file order."""
    return list(_entries(str(root or spec_dir())))


def spec_entry(ident: str, root: Path | None = None) -> Entry | None:
    """The first declaration of ``ident`` (case-insensitive), or None."""
    wanted = ident.strip().upper()
    return next((e for e in _entries(str(root or spec_dir())) if e.id == wanted), None)


def similar_ids(ident: str, root: Path | None = None, n: int = 5) -> list[str]:
    """Declared IDs close to ``ident`` (for "did you mean"), best first."""
    ids = list(dict.fromkeys(e.id for e in _entries(str(root or spec_dir()))))
    wanted = ident.strip().upper()
    prefixed = [i for i in ids if wanted and (i.startswith(wanted) or wanted in i)]
    return list(dict.fromkeys(prefixed[:n] + closest(wanted, ids, n=n, case=False)))[:n]  # F-SUGGEST
