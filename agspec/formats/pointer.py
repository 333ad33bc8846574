"""RFC 6901 JSON Pointers and the one comparison of two JSON values.

``first_difference`` walks two JSON values in canonical order (object keys sorted, arrays by index)
and returns the first pointer where they differ.  Numbers compare as JSON numbers (``1`` equals
``1.0``; a boolean is not a number), exactly unless an absolute ``tolerance`` is given.  Every
comparison in agspec — lockstep replies (F-CONFORM), case expectations, event patterns, the viewer's
state differences — goes through it.
"""

from __future__ import annotations

import json
import math
from typing import Any, Iterator, Mapping


class _Missing:
    """A value absent on one side (rendered ``<absent>``, serialised as null + an ``*_absent`` flag)."""

    def __repr__(self) -> str:
        return "<absent>"


MISSING = _Missing()


class PointerError(ValueError):
    pass


def escape(token: str) -> str:
    """RFC 6901 escaping of one reference token."""
    return token.replace("~", "~0").replace("/", "~1")


def join(*tokens: Any) -> str:
    """The pointer of a path of keys and indices: ``join("robots", "0,1")`` -> ``/robots/0,1``."""
    return "".join("/" + escape(str(t)) for t in tokens)


def parse(pointer: str) -> list[str]:
    """RFC 6901 tokens of ``pointer``; ``""`` is the whole document."""
    if pointer == "":
        return []
    if not pointer.startswith("/"):
        raise PointerError(f"JSON Pointer {pointer!r} must be empty or start with '/'")
    tokens = pointer[1:].split("/")
    for tok in tokens:
        if "~" in tok.replace("~0", "").replace("~1", ""):
            raise PointerError(f"JSON Pointer {pointer!r} has a bad escape (only ~0 and ~1)")
    return [t.replace("~1", "/").replace("~0", "~") for t in tokens]


def resolve(doc: Any, pointer: str) -> Any:
    """The value at ``pointer`` in ``doc``, or :data:`MISSING`."""
    cur = doc
    for tok in parse(pointer):
        if isinstance(cur, Mapping):
            if tok not in cur:
                return MISSING
            cur = cur[tok]
        elif isinstance(cur, (list, tuple)):
            if not tok.isdigit() or (len(tok) > 1 and tok[0] == "0") or int(tok) >= len(cur):
                return MISSING
            cur = cur[int(tok)]
        else:
            return MISSING
    return cur


def _same_scalar(a: Any, b: Any, tolerance: float | None) -> bool:
    if isinstance(a, bool) or isinstance(b, bool):
        return isinstance(a, bool) and isinstance(b, bool) and a == b
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        if a == b:
            return True
        if tolerance is None or math.isnan(a) or math.isnan(b):
            return False
        return abs(a - b) <= tolerance  # absolute tolerance (--float-tolerance)
    return type(a) is type(b) and a == b


def iter_differences(expected: Any, actual: Any, pointer: str = "", tolerance: float | None = None
                     ) -> Iterator[tuple[str, Any, Any]]:
    """Every differing leaf (pointer, expected, actual), depth first in canonical order."""
    if isinstance(expected, Mapping) and isinstance(actual, Mapping):
        for key in sorted(set(expected) | set(actual), key=str):
            sub = f"{pointer}/{escape(str(key))}"
            if key not in actual:
                yield (sub, expected[key], MISSING)
            elif key not in expected:
                yield (sub, MISSING, actual[key])
            else:
                yield from iter_differences(expected[key], actual[key], sub, tolerance)
        return
    if isinstance(expected, (list, tuple)) and isinstance(actual, (list, tuple)):
        for i, (e, a) in enumerate(zip(expected, actual)):
            yield from iter_differences(e, a, f"{pointer}/{i}", tolerance)
        for i in range(min(len(expected), len(actual)), max(len(expected), len(actual))):
            yield (f"{pointer}/{i}", expected[i] if i < len(expected) else MISSING,
                   actual[i] if i < len(actual) else MISSING)
        return
    if isinstance(expected, (Mapping, list, tuple)) or isinstance(actual, (Mapping, list, tuple)):
        yield (pointer, expected, actual)
        return
    if not _same_scalar(expected, actual, tolerance):
        yield (pointer, expected, actual)


def first_difference(expected: Any, actual: Any, tolerance: float | None = None, pointer: str = ""
                     ) -> tuple[str, Any, Any] | None:
    """The first (pointer, expected, actual) where ``actual`` differs from ``expected``, or None."""
    return next(iter_differences(expected, actual, pointer, tolerance), None)


def show(value: Any, limit: int = 160) -> str:
    """A value for a message: compact JSON, cut at ``limit`` characters; :data:`MISSING` is ``<absent>``."""
    if value is MISSING:
        return "<absent>"
    text = json.dumps(value, sort_keys=True, ensure_ascii=False)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def to_json(value: Any) -> Any:
    return None if value is MISSING else value


__all__ = ["MISSING", "PointerError", "escape", "join", "parse", "resolve", "iter_differences", "first_difference",
           "show", "to_json"]
