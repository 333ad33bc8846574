"""The signatures of the known divergences of the original release (F-CONFORM-KNOWN).

The data is one file, ``conformance/divergences.yaml`` (schema ``schemas/divergences.schema.json``),
one entry per ``DIV-…`` heading of spec/10-divergences.md: its title, its scope (``reply``,
``metrics`` or ``none``) and what a failure must show to be that divergence.  This module only reads
and checks it; :mod:`agspec.conform.known` matches conformance failures against the ``reply``
signatures and :mod:`agspec.trace.verify` footer metrics against the ``metrics`` ones.
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path
from typing import Any, Mapping

from agspec.formats import limits
from agspec.formats.schemas import validate
from agspec.resources import conformance_dir

FILE = "divergences.yaml"


class SignatureError(ValueError):
    """The signature file is unreadable or invalid: a defect of this agspec, never of its user."""


def path() -> Path:
    return conformance_dir() / FILE


@lru_cache(maxsize=1)
def signatures() -> Mapping[str, Mapping[str, Any]]:
    """DIV id -> its signature (read once; validated against its schema)."""
    where = path()
    try:
        data = limits.parse_yaml(limits.read_text(where), str(where))
    except limits.InputError as exc:
        raise SignatureError(str(exc)) from None
    problems = validate("divergences", data)
    if problems:
        p = problems[0]
        raise SignatureError(f"{where}: {p.pointer or '/'}: {p.message} [{p.code}]")
    return {k: dict(v) for k, v in data.items()}


def by_scope(scope: str) -> dict[str, Mapping[str, Any]]:
    """The signatures of one scope, in file order."""
    return {k: v for k, v in signatures().items() if v["scope"] == scope}


def expect_entry(item_id: str, ident: str) -> str:
    """The expected-failures line (F-EXPECT, YAML) that accepts ``item_id`` failing as ``ident``."""
    title = signatures()[ident]["title"].replace('"', "'")
    return f'{item_id}: {{outcome: fail, reason: "{ident}: {title} (spec/10-divergences.md)"}}'


__all__ = ["signatures", "by_scope", "expect_entry", "path", "SignatureError", "FILE"]
