"""Shapes: what a reader of a JSON value relies on, checked at simulation speed (F-PROTOCOL-SHAPE, F-VALUES).

A full JSON Schema validation of a step reply takes tens of milliseconds (jsonschema), a hundred
times the simulation step, so ``--validate-protocol`` asks for it explicitly (RES-SHAPE-ALWAYS).  Every reply is still
checked for its **shape**, compiled from the same schema (:func:`compile_shape`, no second schema
written by hand): the JSON types (``type``, and the types of ``const``/``enum`` values), the required
members, the members (``properties``, ``additionalProperties``), the items, the array lengths
(``minItems``, ``maxItems``) and the alternatives the schemas choose by one member's constant
(``if: {properties: {K: {const: V}}}``, ``then``, ``else``).  Patterns, numeric bounds, uniqueness
and closed objects are left to the full validation and to the comparison.  Members the shape does
not describe, and values of any type, are held to the nesting limit
(:data:`~agspec.formats.jsonl.MAX_DEPTH`) instead.

F-VALUES: a number is its value.  Where a shape requires an integer, a number with an integral
value within ±(2^53 − 1) is one (RES-INTEGRAL-NUMBERS): :func:`conform` turns such a float (``6.0``, ``6e0``) into the
integer in place, so every reader after it — comparison, invariants, expectations — sees one value.

:func:`conform` runs a check compiled into closures (no per-node bookkeeping); only a value that
fails it is walked again with its JSON Pointer (to turn integral floats into integers, or to name
the first problem).
"""

from __future__ import annotations

import re
import copy
import os
from dataclasses import dataclass, field
from functools import lru_cache
from itertools import repeat
from typing import Any, Callable

from agspec.formats.jsonl import MAX_DEPTH, depth
from agspec.formats.pointer import join as json_pointer
from agspec.formats.schemas import SELF_CHECK, SchemaDrift, inlined, json_type
from agspec.formats.values import MAX_SAFE_INTEGER, integer

# F-VALUES: the interoperable integer range of I-JSON (RFC 7493 §2.2), exact in binary64

_PY = {"integer": (int,), "number": (int, float), "string": (str,), "boolean": (bool,), "null": (type(None),),
       "array": (list,), "object": (dict,)}
_WORDS = {"integer": "an integer", "number": "a number", "string": "a string", "boolean": "a boolean",
          "null": "null", "array": "an array", "object": "an object"}
_CONTAINERS = frozenset({dict, list})


@dataclass
class Shape:
    """The compiled shape of one schema position.  ``types`` are Python types (None: any value);
    ``key``/``variants``/``default``: the alternative chosen by member ``key``'s value."""

    types: frozenset | None = None
    names: tuple[str, ...] = ()  # the JSON type names, for messages
    required: tuple[str, ...] = ()
    props: dict[str, "Shape"] = field(default_factory=dict)
    extra: "Shape | None" = None
    items: "Shape | None" = None
    min_items: int = 0
    max_items: int | None = None
    key: str | None = None
    variants: dict[tuple[type, Any], "Shape"] = field(default_factory=dict)
    default: "Shape | None" = None
    pattern: str | None = None  # of a string (identifiers the harness parses, R-IDS)
    key_pattern: str | None = None  # of every member name (propertyNames)

    @property
    def leaf(self) -> bool:
        """A scalar position: a type test decides it."""
        return (self.types is not None and not (self.types & _CONTAINERS) and not self.required
                and self.key is None and self.pattern is None)

    @property
    def structured(self) -> bool:
        """Something below this position is described (members, items, alternatives)."""
        return bool(self.props or self.required or self.extra or self.items or self.key or self.min_items
                    or self.max_items is not None or self.pattern or self.key_pattern)


def _types_of(values: list[Any]) -> tuple[frozenset, tuple[str, ...]]:
    names = []
    for v in values:
        name = ("boolean" if isinstance(v, bool) else "integer" if isinstance(v, int) else "number"
                if isinstance(v, float) else "string" if isinstance(v, str) else "null" if v is None
                else "array" if isinstance(v, list) else "object")
        if name not in names:
            names.append(name)
    return frozenset(t for n in names for t in _PY[n]), tuple(names)


def _merge(a: Shape, b: Shape) -> Shape:
    """``allOf``: both shapes hold."""
    if b.types is not None:
        a.types = b.types if a.types is None else a.types & b.types
        a.names = tuple(n for n in (a.names or b.names) if set(_PY[n]) <= a.types) or b.names
    a.required = tuple(dict.fromkeys(a.required + b.required))
    for k, s in b.props.items():
        a.props[k] = _merge(a.props[k], s) if k in a.props else s
    a.extra = a.extra or b.extra
    a.items = a.items or b.items
    a.pattern = a.pattern or b.pattern
    a.key_pattern = a.key_pattern or b.key_pattern
    a.min_items = max(a.min_items, b.min_items)
    if b.max_items is not None:
        a.max_items = b.max_items if a.max_items is None else min(a.max_items, b.max_items)
    if b.key is not None:
        if a.key not in (None, b.key):  # alternatives on two members: keep the first (shape is a subset)
            return a
        a.key = b.key
        a.variants.update(b.variants)
        a.default = a.default or b.default
    return a


class ShapeError(ValueError):
    """A schema a shape is compiled from uses a combinator a shape cannot describe (a bug in ``schemas/``)."""


_VALUE_WORDS = frozenset({"type", "properties", "additionalProperties", "items", "const", "enum", "$ref"})


def _describes_values(branches: Any) -> bool:
    """Whether a combinator's branches say what values are (types, members, items), not only which
    members are required: only then would a shape lose something by not descending into them."""
    if isinstance(branches, dict):
        branches = [branches]
    return isinstance(branches, list) and any(
        isinstance(b, dict) and (_VALUE_WORDS & b.keys() or any(_describes_values(b.get(w)) for w in
                                                                   ("anyOf", "oneOf", "not", "allOf")))
        for b in branches)


def _compile(node: Any) -> Shape:
    s = Shape()
    if not isinstance(node, dict):
        return s
    # anyOf / oneOf / not would make the position opaque: F-VALUES (integral numbers made integers)
    # would silently stop below it, so a shaped schema writes unions as type lists instead
    # (``"type": ["array", "null"]``) and alternatives as if/then on one member's constant
    for word in ("anyOf", "oneOf", "not"):
        if _describes_values(node.get(word)):
            raise ShapeError(f"`{word}` in a schema compiled to a shape (F-PROTOCOL-SHAPE): write a type list "
                             f"or an if/then on one member's constant instead: {str(node)[:160]}")
    if "type" in node:
        names = node["type"] if isinstance(node["type"], list) else [node["type"]]
        s.types, s.names = frozenset(t for n in names for t in _PY[n]), tuple(names)
    if "const" in node:
        s.types, s.names = _types_of([node["const"]])
    elif isinstance(node.get("enum"), list):
        s.types, s.names = _types_of(node["enum"])
    s.required = tuple(node.get("required", ()))
    s.props = {k: _compile(v) for k, v in (node.get("properties") or {}).items()}
    if isinstance(node.get("additionalProperties"), dict):
        s.extra = _compile(node["additionalProperties"])
    if isinstance(node.get("items"), dict):
        s.items = _compile(node["items"])
    if isinstance(node.get("pattern"), str):
        s.pattern = node["pattern"]
    member_names = node.get("propertyNames")
    if isinstance(member_names, dict) and isinstance(member_names.get("pattern"), str):
        s.key_pattern = member_names["pattern"]
    s.min_items = int(node.get("minItems", 0))
    s.max_items = node.get("maxItems")
    for part in node.get("allOf", ()):
        _merge(s, _compile(part))
    cond = node.get("if")
    members = cond.get("properties") if isinstance(cond, dict) else None
    if isinstance(members, dict) and len(members) == 1:
        (key, test), = members.items()
        if isinstance(test, dict) and "const" in test and not isinstance(test["const"], (dict, list)):
            alt = Shape(key=key, variants={(type(test["const"]), test["const"]): _compile(node.get("then", {}))},
                        default=_compile(node["else"]) if "else" in node else None)
            _merge(s, alt)
    return s


@lru_cache(maxsize=None)
def compile_shape(name: str) -> Shape:
    """The shape of schema ``name`` (``"protocol/step.reply"``, ``"trace"``; see formats.schemas)."""
    return _compile(inlined(name))


# --------------------------------------------------------------------------- the fast check


class _Absent:
    """The type of a member that is not there (every optional member's type set holds it)."""


_ABSENT = _Absent()
_contains = frozenset.__contains__


def _opaque(level: int) -> Callable[[Any], bool]:
    budget = MAX_DEPTH - level
    return lambda v: depth(v, budget) <= budget


def _matcher(pattern: str | None) -> Callable[[str], bool] | None:
    return _matches(pattern) if pattern is not None else None


@lru_cache(maxsize=None)
def _matches(pattern: str) -> Callable[[str], bool]:
    """Whether a string matches ``pattern`` (unanchored, as JSON Schema says); memoised, because the
    same identifiers (robot, item, candidate ids) recur in every reply."""
    search = re.compile(pattern).search

    @lru_cache(maxsize=4096)
    def matches(text: str) -> bool:
        return search(text) is not None

    return matches


def _strings_match(match: Callable[[str], bool], values: Any) -> bool:
    return all(map(match, [x for x in values if type(x) is str]))


def _build(s: Shape, level: int, memo: dict) -> Callable[[Any], bool]:
    """``s`` as a predicate for a value ``level`` containers deep (True: it has the shape and needs
    no F-VALUES rewriting)."""
    key_ = (id(s), level)
    if key_ in memo:
        return memo[key_]
    types = s.types
    if not s.structured:
        if types is None or types & _CONTAINERS:  # any value, or a container nothing below is described of
            opaque = _opaque(level)
            f = opaque if types is None else (lambda v: type(v) in types and opaque(v))
        else:
            f = lambda v: type(v) in types  # noqa: E731
        memo[key_] = f
        return f
    match = _matcher(s.pattern)
    if match is not None and not (types or frozenset()) & _CONTAINERS:  # a string with a pattern (or null)
        def string(v: Any) -> bool:
            return (types is None or type(v) in types) and (type(v) is not str or match(v))
        memo[key_] = string
        return string
    required = frozenset(s.required)
    plain = [(k, sub) for k, sub in s.props.items() if sub.leaf]
    plain_keys = tuple(k for k, _ in plain)
    plain_types = tuple(sub.types | {_Absent} for _, sub in plain)
    # (member, the types that need no closer look, the member's check)
    deep = tuple((k, (sub.types - _CONTAINERS - ({str} if sub.pattern else set())) | {_Absent}
                  if sub.types is not None else frozenset({_Absent}), _build(sub, level + 1, memo))
                 for k, sub in s.props.items() if not sub.leaf)
    known = frozenset(s.props)
    key_match = _matcher(s.key_pattern)
    extra = _build(s.extra, level + 1, memo) if s.extra is not None else None
    extra_types = s.extra.types if s.extra is not None and s.extra.leaf else None
    unknown = _opaque(level + 1)
    items = _build(s.items, level + 1, memo) if s.items is not None else unknown
    items_types, items_match = None, None
    if s.items is not None and (s.items.leaf or (s.items.pattern is not None and not s.items.props)):
        items_types, items_match = s.items.types, _matcher(s.items.pattern)
    low, high = s.min_items, s.max_items
    key, variants = s.key, {k: _build(v, level, memo) for k, v in s.variants.items()}
    default = _build(s.default, level, memo) if s.default is not None else None

    def check(v: Any) -> bool:
        tv = type(v)
        if types is not None and tv not in types:
            return False
        if tv is dict:
            if required and not required <= v.keys():
                return False
            if plain_keys and not all(map(_contains, plain_types, map(type, map(v.get, plain_keys,
                                                                                repeat(_ABSENT))))):
                return False
            for k, leaves, sub in deep:
                x = v.get(k, _ABSENT)
                if type(x) not in leaves and not sub(x):
                    return False
            if key_match is not None and not all(map(key_match, v)):
                return False
            alt = None
            if key is not None:
                d = v.get(key)
                alt = variants.get((type(d), d), default) if type(d) in (str, bool, int) else default
                if alt is not None and not alt(v):
                    return False
            if extra is not None:
                rest = v.values() if not known else [x for k, x in v.items() if k not in known]
                if extra_types is not None:
                    if not set(map(type, rest)) <= extra_types:
                        return False
                elif not all(map(extra, rest)):
                    return False
            elif alt is None and not v.keys() <= known and not all(map(unknown, [x for k, x in v.items()
                                                                                 if k not in known])):
                return False  # members no shape describes: held to the nesting limit (the alternative's own)
        elif tv is list:
            if len(v) < low or (high is not None and len(v) > high):
                return False
            if items_types is not None:
                return set(map(type, v)) <= items_types and (items_match is None or _strings_match(items_match, v))
            return all(map(items, v))
        elif match is not None and tv is str:
            return match(v)
        return True

    memo[key_] = check
    return check


@lru_cache(maxsize=None)
def checker(name: str) -> Callable[[Any], bool]:
    """The compiled fast check of schema ``name``'s shape."""
    return _build(compile_shape(name), 0, {})


# --------------------------------------------------------------------------- the located walk


@dataclass(frozen=True)
class Problem:
    """Why a value does not have its shape: ``code`` (``missing_field``, ``bad_field`` or ``too_deep``,
    F-PROTOCOL-ERRORS), the JSON Pointer of the value, and a message."""

    code: str
    pointer: str
    message: str

    def __str__(self) -> str:
        return f"{self.pointer or '/'}: {self.message}"


def _expected(s: Shape) -> str:
    return " or ".join(_WORDS.get(n, n) for n in s.names) or "another type"


def _integral(v: Any) -> bool:
    """F-VALUES: a float that is an integer (RES-INTEGRAL-NUMBERS, :func:`agspec.formats.values.integer`)."""
    return type(v) is float and integer(v) is not None


def _locate(value: Any, shape: Shape) -> Problem | None:
    """The check of :func:`_build`, walked with JSON Pointers: integral floats where an integer is
    required become integers in place; the first other problem is returned."""
    # (value, shape, container holding it, its key there, its path, containers above it)
    stack: list[tuple[Any, Shape, Any, Any, tuple, int]] = [(value, shape, None, None, (), 0)]
    while stack:
        v, s, parent, at, path, level = stack.pop()
        tv = type(v)
        if s.types is not None and tv not in s.types:
            if int in s.types and _integral(v) and parent is not None:
                parent[at] = int(v)
                continue
            found = json_type(v) if tv in _CONTAINERS else f"{json_type(v)} {_short(v)}"
            return Problem("bad_field", json_pointer(*path), f"must be {_expected(s)}, found {found}")
        if tv is str and s.pattern is not None and re.search(s.pattern, v) is None:
            return Problem("bad_field", json_pointer(*path), f"must match {s.pattern}, found {_short(v)}")
        if tv not in _CONTAINERS:
            continue
        if not s.structured:
            if depth(v, MAX_DEPTH - level) > MAX_DEPTH - level:
                return Problem("too_deep", json_pointer(*path), f"nests deeper than {MAX_DEPTH} levels")
            continue
        below: list[tuple[Any, Shape | None, Any]] = []  # (key, shape or None for undescribed, value)
        if tv is dict:
            missing = [k for k in s.required if k not in v]
            if missing:
                return Problem("missing_field", json_pointer(*path, missing[0]), f"lacks `{missing[0]}`")
            wrong = [k for k in v if s.key_pattern is not None and re.search(s.key_pattern, k) is None]
            if wrong:
                return Problem("bad_field", json_pointer(*path, wrong[0]),
                               f"is not a member name this object may have (must match {s.key_pattern})")
            alt = None
            if s.key is not None:
                d = v.get(s.key)
                alt = s.variants.get((type(d), d), s.default) if type(d) in (str, bool, int) else s.default
                if alt is not None:
                    stack.append((v, alt, parent, at, path, level))
            # members no shape describes are held to the nesting limit, by the alternative when there is one
            below = [(k, s.props.get(k, s.extra), x) for k, x in v.items()
                     if alt is None or k in s.props or s.extra is not None]
        else:
            if len(v) < s.min_items or (s.max_items is not None and len(v) > s.max_items):
                bound = (f"exactly {s.min_items}" if s.min_items == s.max_items else
                         f"at least {s.min_items}" if len(v) < s.min_items else f"at most {s.max_items}")
                return Problem("bad_field", json_pointer(*path), f"must have {bound} items, found {len(v)}")
            below = [(i, s.items, x) for i, x in enumerate(v)]
        for k, sub, x in reversed(below):  # document order
            stack.append((x, sub if sub is not None else Shape(), v, k, path + (k,), level + 1))
    return None


def _short(v: Any) -> str:
    text = repr(v) if not isinstance(v, str) else '"' + v[:30] + ('..."' if len(v) > 30 else '"')
    return text if len(text) <= 40 else text[:37] + "..."


def conform(value: Any, name: str) -> Problem | None:
    """Check ``value`` against the shape of schema ``name``: None when it has it (after F-VALUES
    turned integral floats into integers where integers are required, in place), else the first
    :class:`Problem`."""
    if checker(name)(value):
        return None
    return _locate(value, compile_shape(name))


def self_check_shape(name: str, doc: Any) -> None:
    """F-SCHEMAS-SELF for the many records of a stream (a trace's tick records): in self-check mode,
    :class:`~agspec.formats.schemas.SchemaDrift` when ``doc`` lacks the shape of schema ``name`` — the
    schema's types, members, lengths and identifiers, at a thousandth of a full validation's cost."""
    if os.environ.get(SELF_CHECK) and not checker(name)(doc):
        problem = _locate(copy.deepcopy(doc), compile_shape(name))
        raise SchemaDrift(f"a document agspec wrote lacks the shape of schemas/{name}.schema.json: "
                          f"{problem or 'an integral float where an integer is required'}")


__all__ = ["MAX_SAFE_INTEGER", "Shape", "ShapeError", "Problem", "compile_shape", "checker", "conform", "self_check_shape"]
