"""Suggestions and machine-applicable fixes of diagnostics (spec F-DIAGNOSTICS, F-FIX, F-SUGGEST).

* :func:`closest` is the one "did you mean" of agspec (F-SUGGEST): every unknown name — a DSL
  keyword, a field, a recipe, profile, variant, resource, operation, scenario, controller,
  algorithm or spec ID — is matched against the names it could have been with it, so that the
  same misspelling gets the same answer wherever it is typed.
* :class:`Change` is a fix stated on the IR (replace the value at a pointer, append to a list);
  :func:`render_change` turns it into :class:`Edit`\\ s of the document's text, ``.ag`` or
  ``.json``, and returns None where it cannot place them exactly — then the hint stays prose
  (F-FIX).  :func:`apply_edits` applies edits to a text, which is what a tool (or a test) does
  with the ``fix`` of a diagnostic.
"""

from __future__ import annotations

import difflib
import json
import re
from dataclasses import dataclass
from typing import Any, Iterable, Mapping, Sequence

Span = tuple[int, int, int, int]  # (line, col, end_line, end_col), 1-based, end_col exclusive

# difflib's ratio threshold: one edit of a name of four or more characters stays above it (F-SUGGEST)
CUTOFF = 0.6


# --------------------------------------------------------------------------- names (F-SUGGEST)


def closest(name: object, known: Iterable[str], n: int = 1, *, case: bool = True) -> list[str]:
    """The known names closest to ``name``, best first (at most ``n``; none when nothing is close).

    ``case=False`` compares case-insensitively (spec IDs are typed in either case) and returns the
    known spelling.  A name that is itself known is not suggested."""
    names = sorted({k for k in known if isinstance(k, str)})
    wanted = str(name)
    fold = (lambda x: x) if case else str.upper
    spelled = {fold(k): k for k in names}
    # all candidates above the cutoff, then best first: difflib's ratio, ties broken by the ratio of
    # the sorted letters (a transposition, `process1_`, is closer to `process_1` than to `process_2`)
    found = difflib.get_close_matches(fold(wanted), sorted(spelled), n=len(spelled) or 1, cutoff=CUTOFF)
    found = [m for m in found if m != fold(wanted)]
    found.sort(key=lambda m: (-_ratio(fold(wanted), m), -_ratio(sorted(fold(wanted)), sorted(m)), m))
    return [spelled[m] for m in found[:n]]


def _ratio(a: Sequence[str], b: Sequence[str]) -> float:
    return difflib.SequenceMatcher(None, a, b).ratio()


def did_you_mean(name: object, known: Iterable[str]) -> str:
    """``; did you mean `x`?`` for the closest known name, or ``""`` (appended to a message)."""
    match = closest(name, known)
    return f"; did you mean `{match[0]}`?" if match else ""


def choice_message(what: str, name: object, known: Sequence[str]) -> str:
    """The message for a value outside a fixed set of names (CLI options, controllers, algorithms)."""
    match = closest(name, known)
    tail = f"; did you mean `{match[0]}`?" if match else ""
    return f"unknown {what} `{name}`{tail} (one of {', '.join(known)})"


# --------------------------------------------------------------------------- edits (F-FIX)


@dataclass(frozen=True)
class Edit:
    """Replace the text of a span by ``text``; an insertion has an empty span (end = start)."""

    line: int
    col: int
    end_line: int
    end_col: int
    text: str

    def to_json(self) -> dict[str, Any]:
        return {"line": self.line, "col": self.col, "end_line": self.end_line, "end_col": self.end_col,
                "text": self.text}


@dataclass(frozen=True)
class Fix:
    """A machine-applicable edit of the diagnostic's file, with a one-line description."""

    description: str
    edits: tuple[Edit, ...]

    def to_json(self) -> dict[str, Any]:
        return {"description": self.description, "edits": [e.to_json() for e in self.edits]}


@dataclass(frozen=True)
class Change:
    """A fix stated on the IR: ``replace`` the string at ``pointer`` by ``value``, ``rename`` the
    member at ``pointer`` to ``value``, or ``append`` ``value`` to the list at ``pointer`` (created
    when absent)."""

    op: str
    pointer: str
    value: str
    description: str


def _offsets(text: str) -> list[int]:
    starts = [0]
    for m in re.finditer("\n", text):
        starts.append(m.end())
    return starts


def _offset(starts: Sequence[int], line: int, col: int) -> int:
    return starts[line - 1] + col - 1


def _position(starts: Sequence[int], offset: int) -> tuple[int, int]:
    lo, hi = 0, len(starts) - 1
    while lo < hi:
        mid = (lo + hi + 1) // 2
        if starts[mid] <= offset:
            lo = mid
        else:
            hi = mid - 1
    return lo + 1, offset - starts[lo] + 1


def apply_edits(text: str, edits: Iterable[Edit]) -> str:
    """``text`` with ``edits`` applied (they must not overlap); positions are those of ``text``."""
    starts = _offsets(text)
    spans = sorted(((_offset(starts, e.line, e.col), _offset(starts, e.end_line, e.end_col), e.text) for e in edits),
                   reverse=True)
    for start, end, new in spans:
        text = text[:start] + new + text[end:]
    return text


def line_removal(text: str, line: int) -> Edit:
    """The edit that deletes line ``line`` with its line break."""
    starts = _offsets(text)
    if line < len(starts):
        return Edit(line, 1, line + 1, 1, "")
    end = len(text) - starts[line - 1] + 1
    return Edit(line, 1, line, end, "")


_JSON_KEY = re.compile(r'"(?:[^"\\]|\\.)*"\s*:\s*')


def render_change(change: Change, text: str | None, srcmap: Mapping[str, Span], dsl: bool) -> Fix | None:
    """The text edits of ``change`` in a document's text, or None when they cannot be placed exactly."""
    if text is None:
        return None
    starts = _offsets(text)
    if change.op == "replace":
        span = srcmap.get(change.pointer)
        if span is None:
            return None
        start, end = _offset(starts, span[0], span[1]), _offset(starts, span[2], span[3])
        if dsl:
            new = change.value
        else:  # a JSON member maps to `"key": value`: the value follows the key and the colon
            m = _JSON_KEY.match(text, start)
            if m and not change.pointer.rsplit("/", 1)[-1].isdigit():
                start = m.end()
            new = json.dumps(change.value)
        return Fix(change.description, (Edit(*_position(starts, start), *_position(starts, end), new),))
    if change.op == "rename":  # a JSON member's key (the DSL reports unknown fields while parsing, AG104)
        span = srcmap.get(change.pointer)
        m = _JSON_KEY.match(text, _offset(starts, span[0], span[1])) if span is not None and not dsl else None
        if m is None:
            return None
        key_end = m.start() + len(json.dumps(json.loads(text[m.start():m.end()].rstrip().rstrip(":").rstrip())))
        if text[m.start():key_end] != json.dumps(change.pointer.rsplit("/", 1)[-1]):
            return None  # the key is written with escapes: not placed exactly
        return Fix(change.description, (Edit(*_position(starts, m.start()), *_position(starts, key_end),
                                             json.dumps(change.value)),))
    if change.op == "append":
        return _append_dsl(change, text, starts, srcmap) if dsl else _append_json(change, text, starts, srcmap)
    return None


def _append_dsl(change: Change, text: str, starts: list[int], srcmap: Mapping[str, Span]) -> Fix | None:
    span = srcmap.get(change.pointer)
    if span is not None:  # `after a, b`: the list ends where the field's span ends
        return Fix(change.description, (Edit(span[2], span[3], span[2], span[3], f", {change.value}"),))
    parent = srcmap.get(change.pointer.rsplit("/", 1)[0])
    if parent is None:
        return None
    field = change.pointer.rsplit("/", 1)[-1]
    line = text[starts[parent[0] - 1]:].split("\n", 1)[0]
    brace = line.find("{", parent[3] - 1)
    if brace < 0:
        return None
    rest = line[brace + 1:]
    if rest.strip():  # a one-line block: the field goes right after the brace
        return Fix(change.description, (Edit(parent[0], brace + 2, parent[0], brace + 2,
                                              f" {field} {change.value}"),))
    indent = len(line) - len(line.lstrip()) + 2
    end = len(line.rstrip("\r")) + 1
    return Fix(change.description, (Edit(parent[0], end, parent[0], end,
                                          "\n" + " " * indent + f"{field} {change.value}"),))


def _append_json(change: Change, text: str, starts: list[int], srcmap: Mapping[str, Span]) -> Fix | None:
    decoder = json.JSONDecoder()
    value = json.dumps(change.value)
    span = srcmap.get(change.pointer)
    if span is not None:  # `"after": [...]`: insert before the closing bracket
        m = _JSON_KEY.match(text, _offset(starts, span[0], span[1]))
        if not m or text[m.end():m.end() + 1] != "[":
            return None
        current, end = decoder.raw_decode(text, m.end())
        insert = f", {value}" if current else value
        return Fix(change.description, (Edit(*_position(starts, end - 1), *_position(starts, end - 1), insert),))
    parent = srcmap.get(change.pointer.rsplit("/", 1)[0] + "/id")
    if parent is None:
        return None
    field = json.dumps(change.pointer.rsplit("/", 1)[-1])
    return Fix(change.description, (Edit(parent[0], parent[1], parent[0], parent[1], f"{field}: [{value}], "),))
