"""The JSON Schemas of ``schemas/``: one loader, one registry, compiled validators, one wording.

Every schema is addressed by name (``"instance"``, ``"trace"``, ``"protocol/step.reply"``; see
:func:`schema_id`) and compiled once with every ``$ref`` inlined (``_inline``): jsonschema's
reference resolution dominated validation time otherwise.  A violation is worded once
(:func:`issues`, codes AG2xx of F-CODES) for the IR validator, the protocol, traces, reports and
cases alike.
"""

from __future__ import annotations

import copy
import json
import os
from dataclasses import dataclass
from functools import lru_cache
from typing import Any, Iterable, Mapping

from jsonschema import Draft202012Validator, validators
from jsonschema.exceptions import ValidationError, best_match, relevance
from referencing import Registry, Resource

from agspec.formats.diagnostics import Issue
from agspec.formats.pointer import join as json_pointer
from agspec.formats.pointer import parse as parse_pointer
from agspec.formats.values import integer
from agspec.resources import schemas_dir
from agspec.suggest import Change, closest

_RANGE = {"minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum", "minItems", "maxItems", "minLength",
          "maxLength", "minProperties", "maxProperties", "multipleOf"}
_JSON_TYPES = {"integer": "an integer", "number": "a number", "string": "a string", "boolean": "a boolean",
               "object": "an object", "array": "an array", "null": "null"}


@lru_cache(maxsize=1)
def documents() -> dict[str, dict[str, Any]]:
    """Every agspec schema by ``$id``: schemas/*.schema.json and schemas/protocol/*.schema.json."""
    return {doc["$id"]: doc for doc in _files().values() if "$id" in doc}


@lru_cache(maxsize=1)
def _files() -> dict[str, dict[str, Any]]:
    """Every schema by its file name without ``.schema.json`` (``protocol/`` ones prefixed)."""
    out: dict[str, dict[str, Any]] = {}
    root = schemas_dir()
    for path in sorted(root.glob("*.schema.json")) + sorted((root / "protocol").glob("*.schema.json")):
        name = path.name[: -len(".schema.json")]
        out[name if path.parent == root else f"protocol/{name}"] = json.loads(path.read_text(encoding="utf-8"))
    return out


@lru_cache(maxsize=1)
def registry() -> Registry:
    """All agspec schemas, addressable by their ``$id``."""
    return Registry().with_resources((k, Resource.from_contents(v)) for k, v in documents().items())


def schema_id(name: str) -> str:
    """``"trace"`` -> ``urn:agspec:schema:trace:1``; ``"protocol/step.reply"`` -> the protocol schema; a
    schema whose ``$id`` is not agspec's (``original-result-v1``) by its file name."""
    doc = _files().get(name)
    if doc is not None and isinstance(doc.get("$id"), str) and not doc["$id"].startswith("urn:agspec:"):
        return doc["$id"]
    if name.startswith("protocol/"):
        return f"urn:agspec:schema:protocol:{name.split('/', 1)[1]}:1"
    return f"urn:agspec:schema:{name}:1"


def load_schema(name: str) -> dict[str, Any]:
    """A schema document by name, e.g. ``load_schema("recipe")`` or ``load_schema("diagnostics")``."""
    docs = documents()
    sid = schema_id(name)
    if sid not in docs:
        raise KeyError(f"no schema {name!r} ({sid}) under {schemas_dir()}")
    return docs[sid]


def _resolve_fragment(doc: Any, fragment: str) -> Any:
    cur = doc
    for tok in parse_pointer(fragment):
        cur = cur[int(tok)] if isinstance(cur, list) else cur[tok]
    return cur


def _inline(node: Any, base: str, docs: Mapping[str, Any], stack: tuple[str, ...] = ()) -> Any:
    """Replace every ``$ref`` by the schema it names (``$ref`` with siblings becomes ``allOf``)."""
    if isinstance(node, list):
        return [_inline(x, base, docs, stack) for x in node]
    if not isinstance(node, dict):
        return node
    if "$ref" in node and isinstance(node["$ref"], str):
        ref = node["$ref"]
        uri, _, fragment = ref.partition("#")
        target_base = uri or base
        key = f"{target_base}#{fragment}"
        if key in stack or target_base not in docs:  # recursive or unknown: keep the reference
            return {k: _inline(v, base, docs, stack) if k != "$ref" else v for k, v in node.items()}
        target = _inline(_resolve_fragment(docs[target_base], fragment), target_base, docs, stack + (key,))
        siblings = {k: _inline(v, base, docs, stack) for k, v in node.items() if k != "$ref"}
        if not siblings:
            return target
        return {"allOf": [target], **siblings}
    out = {}
    for k, v in node.items():
        if k in ("$defs", "definitions"):
            continue  # inlined where used
        if k in ("properties", "patternProperties", "dependentSchemas"):
            out[k] = {name: _inline(sub, base, docs, stack) for name, sub in v.items()}
        elif k in ("enum", "const", "required", "examples", "default"):
            out[k] = copy.deepcopy(v)
        else:
            out[k] = _inline(v, base, docs, stack)
    return out


def inlined(name: str) -> dict[str, Any]:
    """Schema ``name`` with every ``$ref`` replaced by the schema it names (what validators and
    :mod:`agspec.formats.shape` compile)."""
    docs = documents()
    sid = schema_id(name)
    if sid not in docs:
        raise KeyError(f"no schema {name!r} ({sid}) under {schemas_dir()}")
    return _inline(docs[sid], sid, docs)


@lru_cache(maxsize=None)
def validator(name: str) -> Draft202012Validator:
    """The compiled validator of schema ``name`` (see :func:`schema_id`), references inlined."""
    return Draft202012Validator(inlined(name), registry=registry())


@lru_cache(maxsize=None)
def _integers_only(name: str) -> Draft202012Validator:
    """Schema ``name`` with `integer` meaning an int: its type errors are the integral floats to read."""
    strict = Draft202012Validator.TYPE_CHECKER.redefine(
        "integer", lambda _checker, v: isinstance(v, int) and not isinstance(v, bool))
    return validators.extend(Draft202012Validator, type_checker=strict)(inlined(name), registry=registry())


def integers_of(name: str, doc: Any) -> Any:
    """F-VALUES, RES-INTEGRAL-NUMBERS: ``doc`` with every integral float at a position schema ``name``
    types integer made the integer (:func:`agspec.formats.values.integer`), in place — for documents
    whose schema has unions (a results bundle, a training record); a shaped schema's readers use
    :func:`agspec.formats.shape.conform`, the same rule in one walk.  Anything else stays for the
    validation to judge."""
    for _ in range(4):  # a member under a union the first pass could not see past
        spots = []
        stack = list(_integers_only(name).iter_errors(doc))
        while stack:
            error = stack.pop()
            stack.extend(error.context or ())
            wanted = error.validator_value if isinstance(error.validator_value, list) else [error.validator_value]
            if error.validator == "type" and "integer" in wanted and type(error.instance) is float \
                    and integer(error.instance) is not None and error.absolute_path:
                spots.append(tuple(error.absolute_path))
        if not spots:
            break
        for path in spots:
            node = doc
            for key in path[:-1]:
                node = node[key]
            node[path[-1]] = integer(node[path[-1]])
    return doc


_TYPE_WORDS = ((bool, "a boolean"), (int, "an integer"), (float, "a number"), (str, "a string"), (list, "an array"),
               (dict, "an object"))  # bool before int: a boolean is not a number in JSON


def json_type(value: Any) -> str:
    if value is None:
        return "null"
    return next((word for kind, word in _TYPE_WORDS if isinstance(value, kind)), type(value).__name__)


def show_value(value: Any) -> str:
    text = json.dumps(value, ensure_ascii=False) if not isinstance(value, (dict, list)) else json_type(value)
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


def issues(error: ValidationError) -> list[Issue]:
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
            close = closest(key, known)  # F-SUGGEST
            hint = f"did you mean `{close[0]}`?" if close else (
                "allowed fields: " + ", ".join(known) if known else None)
            ptr = json_pointer(*path, key)
            # F-FIX: the rename is an edit only when it does not duplicate a field already set
            change = Change("rename", ptr, close[0], f"rename `{key}` to `{close[0]}`") \
                if close and close[0] not in instance else None
            issues.append(Issue("AG204", f"unknown field `{key}`", ptr, hint=hint, change=change))
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
        found = json_type(instance) if isinstance(instance, (dict, list)) else f"{json_type(instance)} {show_value(instance)}"
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
        return [Issue("AG203", f"{where} {text}, found {show_value(instance)}", ptr)]
    if kw == "enum":
        allowed = ", ".join(f"`{v}`" for v in error.validator_value)
        return [Issue("AG205", f"{where} must be one of {allowed}, found {show_value(instance)}", ptr)]
    if kw == "const":
        return [Issue("AG205", f"{where} must be {show_value(error.validator_value)}, found {show_value(instance)}", ptr)]
    if kw == "uniqueItems":
        return [Issue("AG206", f"{where} has duplicate items", ptr)]
    if kw in ("pattern", "format"):
        return [Issue("AG207", f"{where} is malformed: {error.message}", ptr)]
    if kw == "dependentRequired":
        return [Issue("AG201", f"{where}: {error.message}", ptr)]
    return [Issue("AG200", f"{where}: {error.message}", ptr)]


def sort_key(error: ValidationError) -> Any:
    """Most relevant first, as ``best_match`` ranks (``relevance``: shallow errors, strong
    keywords); siblings in document order.  Paths are compared as strings (mixed types)."""
    key = relevance(error)
    return (-key[0], [-k for k in key[2:]], [str(p) for p in key[1]])


def iter_issues(name: str, doc: Any) -> Iterable[Issue]:
    """The violations of ``doc`` against schema ``name`` as Issues, most relevant first, without repeats."""
    errors = sorted(validator(name).iter_errors(doc), key=sort_key)
    seen: set[tuple[str, str, str]] = set()
    for error in errors:
        if error.context:
            error = best_match([error]) or error
        for issue in issues(error):
            key = (issue.code, issue.pointer, issue.message)
            if key not in seen:
                seen.add(key)
                yield issue


@dataclass(frozen=True)
class SchemaProblem:
    """One schema violation: JSON Pointer into the message, stable code (AG2xx), message."""

    pointer: str
    code: str
    message: str

    def __str__(self) -> str:
        return f"{self.pointer or '/'}: {self.message} [{self.code}]"


def validate(name: str, doc: Any, limit: int = 5) -> list[SchemaProblem]:
    """Schema problems of ``doc`` against schema ``name``, most relevant first, at most ``limit``."""
    out: list[SchemaProblem] = []
    for issue in iter_issues(name, doc):
        out.append(SchemaProblem(issue.pointer, issue.code, issue.message))
        if len(out) >= limit:
            break
    return out


# F-SCHEMAS-SELF: with this variable set (the test suite sets it), every document agspec writes is
# validated against its schema as it is written, and a violation is raised (SchemaDrift)
SELF_CHECK = "AGSPEC_SELF_CHECK"


class SchemaDrift(AssertionError):
    """A document agspec wrote violates its own schema: a bug of agspec (F-SCHEMAS-SELF)."""


def self_check(name: str, doc: Any) -> None:
    """F-SCHEMAS-SELF: in self-check mode (``$AGSPEC_SELF_CHECK`` set), raise :class:`SchemaDrift` when
    ``doc`` — a document agspec is writing — violates schema ``name``; otherwise do nothing."""
    if not os.environ.get(SELF_CHECK):
        return
    problems = validate(name, doc, limit=3)
    if problems:
        raise SchemaDrift(f"a document agspec wrote violates schemas/{name}.schema.json: "
                          + "; ".join(str(p) for p in problems))


__all__ = ["integers_of", "SELF_CHECK", "SchemaDrift", "self_check", "documents", "registry", "schema_id", "load_schema", "inlined", "validator", "issues", "sort_key", "iter_issues",
           "SchemaProblem", "validate", "json_type", "show_value"]
