"""Shared helpers of the semantic checks: pointers, issue constructors, tolerant type tests."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any, Iterable, Protocol, Sequence

from agspec.formats.diagnostics import Issue, json_pointer
from agspec.suggest import Change, closest, did_you_mean

Json = Any
MAX_ROUTES = 1024  # AG390: XOR routes analysed per recipe
MAX_CYCLES = 16  # AG303: precedence cycles reported per recipe
REACH_TOLERANCE = 1e-9  # G-REACH


class Resolver(Protocol):
    """Names -> IR documents (``agspec.load.Resolver`` implements it)."""

    def get(self, kind: str, name: str) -> Json | None: ...


# =============================================================================================
# Small helpers
# =============================================================================================


def _ptr(*parts: object) -> str:
    return json_pointer(*parts)


def _err(code: str, message: str, pointer: str, hint: str | None = None) -> Issue:
    return Issue(code=code, message=message, pointer=pointer, hint=hint)


def _warn(code: str, message: str, pointer: str, hint: str | None = None) -> Issue:
    return Issue(code=code, message=message, pointer=pointer, hint=hint, severity="warning")


def _is_num(x: object) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def _is_int(x: object) -> bool:
    """Integers, including integral floats (JSON Schema's "integer" accepts 3.0)."""
    return _is_num(x) and float(x) == int(x)


def _list(x: object) -> list:
    return x if isinstance(x, list) else []


def _dict(x: object) -> dict:
    return x if isinstance(x, dict) else {}


def _str(x: object) -> str | None:
    return x if isinstance(x, str) else None


def _q(names: Iterable[object]) -> str:
    return ", ".join(f"`{n}`" for n in names)


def _did_you_mean(name: object, known: Iterable[str]) -> str:
    return did_you_mean(name, known)


def _fixable(issue: Issue, name: object, known: Iterable[str]) -> Issue:
    """``issue`` about the unknown name at its pointer, with the fix that writes the closest known name
    (F-SUGGEST, F-FIX) when there is one."""
    match = closest(name, known)
    if not match:
        return issue
    return replace(issue, change=Change("replace", issue.pointer, match[0], f"replace `{name}` by `{match[0]}`"))


def _prefixed(prefix: str, issues: Iterable[Issue]) -> list[Issue]:
    return [replace(i, pointer=prefix + i.pointer) for i in issues]


def errors(issues: Sequence[Issue]) -> list[Issue]:
    """The issues of severity ``error``."""
    return [i for i in issues if i.severity == "error"]
