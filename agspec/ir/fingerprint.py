"""F-FINGERPRINT: content identity of IR documents.

A fingerprint is ``"sha256:" + hex(SHA-256(JCS(defining(ir))))`` where JCS is the RFC 8785
JSON Canonicalization Scheme (library ``rfc8785``) and ``defining(ir)`` is the IR without its
non-defining keys:

* the top-level ``"id"`` and ``"meta"`` (names and provenance do not change the problem),
* the key ``"doc"`` with a string value at any depth (free text; a resource or token that happens
  to be named ``doc`` maps to a number, not a string, and stays defining),
* ``"seeds.execution"`` in instances (the execution stream is inert in v1) and ``"seeds.index"``
  (a label: the same realization made from index k or from its generation seed is one problem).

Because JCS canonicalises numbers, ``1`` and ``1.0`` have the same fingerprint, and key order
and whitespace of the source never matter.
"""

from __future__ import annotations

import hashlib
from typing import Any, Mapping

import rfc8785

FINGERPRINT_PREFIX = "sha256:"

# F-FINGERPRINT: keys that name or describe a document without defining it.
TOP_LEVEL_NON_DEFINING = ("id", "meta")
DOC_KEY = "doc"
NON_DEFINING_SEEDS = ("execution", "index")


class FingerprintError(ValueError):
    """The IR holds a value that has no canonical JSON form (NaN, huge integer, non-string key)."""


def _strip_doc(value: Any) -> Any:
    """Copy ``value`` without any ``"doc"`` key at any depth (tuples become lists)."""
    if isinstance(value, Mapping):
        return {k: _strip_doc(v) for k, v in value.items() if not (k == DOC_KEY and isinstance(v, str))}
    if isinstance(value, (list, tuple)):
        return [_strip_doc(v) for v in value]
    return value


def defining_view(ir: Mapping[str, Any]) -> dict[str, Any]:
    """The part of ``ir`` that its fingerprint covers (F-FINGERPRINT)."""
    if not isinstance(ir, Mapping):
        raise FingerprintError(f"an IR document must be a JSON object, not {type(ir).__name__}")
    view = _strip_doc({k: v for k, v in ir.items() if k not in TOP_LEVEL_NON_DEFINING})
    if view.get("kind") == "instance" and isinstance(view.get("seeds"), dict):
        view["seeds"] = {k: v for k, v in view["seeds"].items() if k not in NON_DEFINING_SEEDS}
    return view


def canonical_bytes(ir: Mapping[str, Any]) -> bytes:
    """RFC 8785 canonical UTF-8 bytes of the defining part of ``ir``."""
    try:
        return rfc8785.dumps(defining_view(ir))
    except rfc8785.CanonicalizationError as exc:  # includes float/integer domain errors
        raise FingerprintError(f"IR cannot be canonicalised (RFC 8785): {exc}") from exc


def fingerprint(ir: Mapping[str, Any]) -> str:
    """``"sha256:<64 hex>"`` of :func:`canonical_bytes` (F-FINGERPRINT)."""
    return FINGERPRINT_PREFIX + hashlib.sha256(canonical_bytes(ir)).hexdigest()
