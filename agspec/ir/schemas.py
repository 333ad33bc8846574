"""JSON Schema validation of IR documents (spec F-IR, F-DIAGNOSTICS; Draft 2020-12).

The schemas live in ``schemas/*.schema.json`` and are loaded and compiled by
:mod:`agspec.formats.schemas`; they have ``$id`` ``urn:agspec:schema:<kind>:1``.  :func:`validate_schema` picks the schema by
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

from typing import Any

from agspec.formats import shape
from agspec.formats.diagnostics import Issue
from agspec.formats.schemas import iter_issues, json_type, load_schema, show_value, validator

KINDS = ("recipe", "profile", "scenario", "instance")
SCHEMA_IDS = {kind: f"urn:agspec:schema:{kind}:1" for kind in KINDS}

def validate_schema(ir: Any) -> list[Issue]:
    """Validate an IR document against the schema of its ``kind`` (F-IR); best match first."""
    if not isinstance(ir, dict):
        return [Issue("AG004", f"an IR document must be a JSON object, found {json_type(ir)}", "")]
    kind = ir.get("kind")
    if kind not in SCHEMA_IDS:
        hint = "`kind` must be one of " + ", ".join(KINDS)
        shown = f"`{kind}`" if isinstance(kind, str) else ("missing" if kind is None else show_value(kind))
        return [Issue("AG004", f"unknown document kind {shown}", "/kind" if "kind" in ir else "", hint=hint)]
    return list(iter_issues(kind, ir))


def ir_integers(ir: Any) -> Any:
    """F-VALUES, RES-INTEGRAL-NUMBERS: ``ir`` with every integral number at a position its kind's schema
    types integer made the integer (``1.0`` is the radius 1), in place — what a reader does after
    :func:`validate_schema`, so that the interpreter sees one value whatever the writer's JSON
    library wrote.  Anything else stays for the validation to judge."""
    if isinstance(ir, dict) and ir.get("kind") in SCHEMA_IDS:
        shape.conform(ir, ir["kind"])
    return ir


__all__ = ["KINDS", "SCHEMA_IDS", "ir_integers", "validate_schema", "load_schema", "validator"]
