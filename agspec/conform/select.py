"""``-k EXPR``: selecting cases and episodes by id, title, tag, rule or invariant.

The expression combines terms with ``and``, ``or``, ``not`` and parentheses (as pytest's ``-k``);
a bare list of terms separated by commas means ``or``.  A term matches an item when it

* is a substring (case-insensitive) of its id, title or source location, or
* equals (case-insensitive) one of its tags, rule IDs, invariant IDs or its kind, or
* contains ``*``, ``?`` or ``[`` and glob-matches (fnmatch) any of those.

Examples: ``-k R-HANDOFF``, ``-k "flow-easy or coalition"``, ``-k "c-3f2a*"``,
``-k "episode and not random"``.
"""

from __future__ import annotations

import fnmatch
import re
from typing import Any, Callable, Iterable

_TOKEN = re.compile(r"\s*(\(|\)|[^\s()]+)")


class SelectError(ValueError):
    """A malformed -k expression (usage error, exit 2)."""


def _fields(item: Any) -> tuple[list[str], list[str]]:
    """(substring fields, exact fields) of an item, lower-cased."""
    loose = [str(getattr(item, "id", "")), str(getattr(item, "title", "")), str(getattr(item, "location", "") or "")]
    exact = [str(getattr(item, "kind", ""))]
    for attr in ("tags", "rules", "invariants"):
        exact += [str(x) for x in (getattr(item, attr, ()) or ())]
    return [s.lower() for s in loose], [s.lower() for s in exact]


def term_matches(term: str, item: Any) -> bool:
    loose, exact = _fields(item)
    t = term.lower()
    if any(ch in t for ch in "*?["):
        return any(fnmatch.fnmatchcase(s, t) for s in loose + exact)
    return any(t in s for s in loose) or t in exact


def compile_filter(expr: str | None) -> Callable[[Any], bool]:
    """A predicate for ``-k EXPR`` (None or blank: everything)."""
    if expr is None or not expr.strip():
        return lambda item: True
    text = expr.replace(",", " or ")
    tokens = _TOKEN.findall(text)
    pos = 0

    def peek() -> str | None:
        return tokens[pos] if pos < len(tokens) else None

    def take() -> str:
        nonlocal pos
        if pos >= len(tokens):
            raise SelectError(f"-k {expr!r}: unexpected end of expression")
        tok = tokens[pos]
        pos += 1
        return tok

    def parse_or() -> Callable[[Any], bool]:
        parts = [parse_and()]
        while peek() == "or":
            take()
            parts.append(parse_and())
        return parts[0] if len(parts) == 1 else (lambda item, ps=tuple(parts): any(p(item) for p in ps))

    def parse_and() -> Callable[[Any], bool]:
        parts = [parse_not()]
        while peek() == "and":
            take()
            parts.append(parse_not())
        return parts[0] if len(parts) == 1 else (lambda item, ps=tuple(parts): all(p(item) for p in ps))

    def parse_not() -> Callable[[Any], bool]:
        if peek() == "not":
            take()
            inner = parse_not()
            return lambda item: not inner(item)
        return parse_atom()

    def parse_atom() -> Callable[[Any], bool]:
        tok = take()
        if tok == "(":
            inner = parse_or()
            if take() != ")":
                raise SelectError(f"-k {expr!r}: missing `)`")
            return inner
        if tok in (")", "and", "or"):
            raise SelectError(f"-k {expr!r}: unexpected `{tok}`")
        return lambda item, term=tok: term_matches(term, item)

    pred = parse_or()
    if pos != len(tokens):
        raise SelectError(f"-k {expr!r}: unexpected `{tokens[pos]}`")
    return pred


def select(items: Iterable[Any], expr: str | None) -> list[Any]:
    pred = compile_filter(expr)
    return [item for item in items if pred(item)]


__all__ = ["compile_filter", "select", "term_matches", "SelectError"]
