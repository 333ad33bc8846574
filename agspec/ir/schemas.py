"""JSON Schema validation of IR documents (spec F-IR, F-DIAGNOSTICS; Draft 2020-12).

The schemas live in ``schemas/*.schema.json`` (found with
:func:`agspec.resources.schemas_dir`), have ``$id`` ``urn:agspec:schema:<kind>:1`` and refer to
each other through a ``referencing`` registry.  :func:`validate_schema` picks the schema by
the document's ``kind`` and turns each jsonschema error into an :class:`Issue` with the JSON
Pointer of the offending node, most relevant first (``jsonschema.exceptions.relevance``,
descending into ``anyOf``/``oneOf`` with ``best_match``).

Codes: AG200 other schema violation, AG201 missing required field, AG202 wrong type,
AG203 value out of range (minimum, maximum, lengths, item counts), AG204 unknown field,
AG205 value not allowed (enum, const), AG206 duplicate (items that must be unique; also
duplicate fields/keys found while building or reading JSON), AG207 malformed text (pattern,
format).  A document that is not an object or has an unknown ``kind`` gives AG004.
"""

from __future__ import annotations

import difflib
import json
from functools import lru_cache
from typing import Any, Iterable, Mapping

from jsonschema import Draft202012Validator
from jsonschema.exceptions import ValidationError, best_match, relevance
from referencing import Registry, Resource

from agspec.diagnostics import Issue, json_pointer
from agspec.resources import schemas_dir

KINDS = ("recipe", "profile", "scenario", "instance")
SCHEMA_IDS = {kind: f"urn:agspec:schema:{kind}:1" for kind in KINDS}

_RANGE = {"minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum", "minItems", "maxItems", "minLength",
          "maxLength", "minProperties", "maxProperties", "multipleOf"}
_JSON_TYPES = {"integer": "an integer", "number": "a number", "string": "a string", "boolean": "a boolean",
               "object": "an object", "array": "an array", "null": "null"}


@lru_cache(maxsize=None)
def load_schema(name: str) -> dict[str, Any]:
    """A schema by file stem, e.g. ``load_schema("recipe")`` or ``load_schema("diagnostics")``."""
    path = schemas_dir() / f"{name}.schema.json"
    return json.loads(path.read_text(encoding="utf-8"))


@lru_cache(maxsize=1)
def registry() -> Registry:
    """All agspec schemas, addressable by their ``$id``."""
    resources = []
    for path in sorted(schemas_dir().glob("*.schema.json")):
        schema = json.loads(path.read_text(encoding="utf-8"))
        if "$id" in schema:
            resources.append((schema["$id"], Resource.from_contents(schema)))
    return Registry().with_resources(resources)


@lru_cache(maxsize=None)
def validator_for(name: str) -> Draft202012Validator:
    return Draft202012Validator(load_schema(name), registry=registry())


def _json_type(value: Any) -> str:
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, int):
        return "an integer"
    if isinstance(value, float):
        return "a number"
    if isinstance(value, str):
        return "a string"
    if isinstance(value, list):
        return "an array"
    if isinstance(value, dict):
        return "an object"
    return type(value).__name__


def _show(value: Any) -> str:
    text = json.dumps(value, ensure_ascii=False) if not isinstance(value, (dict, list)) else _json_type(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _field(path: Iterable[Any]) -> str:
    parts = list(path)
    if not parts:
        return "the document"
    last = parts[-1]
    if isinstance(last, int) and len(parts) > 1:
        return f"`{parts[-2]}[{last}]`"
    return f"`{last}`"


def _required_in(schema: Any) -> list[str]:
    """Field names a `required`/`anyOf` combination mentions (for `not` errors)."""
    if not isinstance(schema, Mapping):
        return []
    out = list(schema.get("required", []))
    for sub in schema.get("anyOf", []) + schema.get("oneOf", []):
        out += _required_in(sub)
    return out


def _issues(error: ValidationError) -> list[Issue]:
    """One jsonschema error -> Issues (several for several unknown keys)."""
    path = list(error.absolute_path)
    ptr = json_pointer(*path) if path else ""
    where = _field(path)
    kw = error.validator
    instance = error.instance
    if kw == "required":
        missing = [p for p in error.validator_value if isinstance(instance, dict) and p not in instance]
        return [Issue("AG201", f"missing required field `{p}`" + (f" in {where}" if path else ""), ptr)
                for p in missing]
    if kw in ("additionalProperties", "unevaluatedProperties"):
        known = sorted((error.schema.get("properties") or {}).keys())
        issues = []
        extras = [k for k in instance if k not in known] if isinstance(instance, dict) else []
        for key in extras:
            close = difflib.get_close_matches(key, known, n=1)
            hint = f"did you mean `{close[0]}`?" if close else (
                "allowed fields: " + ", ".join(known) if known else None)
            issues.append(Issue("AG204", f"unknown field `{key}`", json_pointer(*path, key), hint=hint))
        return issues or [Issue("AG204", error.message, ptr)]
    if kw == "not" and isinstance(instance, dict):
        # `not: {anyOf: [{required: [a]}, ...]}` forbids fields a, ... in this context
        forbidden = _required_in(error.validator_value)
        present = [f for f in forbidden if f in instance]
        if present:
            return [Issue("AG204", f"field `{f}` is not allowed here" + (f" in {where}" if path else ""),
                          json_pointer(*path, f)) for f in present]
    if kw is None or error.schema is False:
        return [Issue("AG204", f"{where} is not allowed here", ptr)]
    if kw == "type":
        want = error.validator_value
        wants = [want] if isinstance(want, str) else list(want)
        words = " or ".join(_JSON_TYPES.get(w, w) for w in wants)
        found = _json_type(instance) if isinstance(instance, (dict, list)) else f"{_json_type(instance)} {_show(instance)}"
        return [Issue("AG202", f"{where} must be {words}, found {found}", ptr)]
    if kw in _RANGE:
        bound = error.validator_value
        text = {
            "minimum": f"must be >= {bound}",
            "maximum": f"must be <= {bound}",
            "exclusiveMinimum": f"must be > {bound}",
            "exclusiveMaximum": f"must be < {bound}",
            "minItems": f"must have at least {bound} item(s)",
            "maxItems": f"must have at most {bound} item(s)",
            "minLength": "must not be empty" if bound == 1 else f"must have at least {bound} characters",
            "maxLength": f"must have at most {bound} characters",
            "minProperties": f"must have at least {bound} entr{'y' if bound == 1 else 'ies'}",
            "maxProperties": f"must have at most {bound} entries",
            "multipleOf": f"must be a multiple of {bound}",
        }[kw]
        return [Issue("AG203", f"{where} {text}, found {_show(instance)}", ptr)]
    if kw == "enum":
        allowed = ", ".join(f"`{v}`" for v in error.validator_value)
        return [Issue("AG205", f"{where} must be one of {allowed}, found {_show(instance)}", ptr)]
    if kw == "const":
        return [Issue("AG205", f"{where} must be {_show(error.validator_value)}, found {_show(instance)}", ptr)]
    if kw == "uniqueItems":
        return [Issue("AG206", f"{where} has duplicate items", ptr)]
    if kw in ("pattern", "format"):
        return [Issue("AG207", f"{where} is malformed: {error.message}", ptr)]
    if kw == "dependentRequired":
        return [Issue("AG201", f"{where}: {error.message}", ptr)]
    return [Issue("AG200", f"{where}: {error.message}", ptr)]


def _sort_key(error: ValidationError) -> Any:
    """Most relevant first, as ``best_match`` ranks (``relevance``: shallow errors, strong
    keywords); siblings in document order.  Paths are compared as strings (mixed types)."""
    key = relevance(error)
    return (-key[0], [-k for k in key[2:]], [str(p) for p in key[1]])


def validate_schema(ir: Any) -> list[Issue]:
    """Validate an IR document against the schema of its ``kind`` (F-IR); best match first."""
    if not isinstance(ir, dict):
        return [Issue("AG004", f"an IR document must be a JSON object, found {_json_type(ir)}", "")]
    kind = ir.get("kind")
    if kind not in SCHEMA_IDS:
        hint = "`kind` must be one of " + ", ".join(KINDS)
        shown = f"`{kind}`" if isinstance(kind, str) else ("missing" if kind is None else _show(kind))
        return [Issue("AG004", f"unknown document kind {shown}", "/kind" if "kind" in ir else "", hint=hint)]
    errors = list(validator_for(kind).iter_errors(ir))
    errors.sort(key=_sort_key)
    out: list[Issue] = []
    seen: set[tuple[str, str, str]] = set()
    for error in errors:
        if error.context:
            error = best_match([error]) or error
        for issue in _issues(error):
            key = (issue.code, issue.pointer, issue.message)
            if key not in seen:
                seen.add(key)
                out.append(issue)
    return out
