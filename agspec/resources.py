"""Locate the data shipped with agspec (schemas, catalogue, spec, conformance suite).

An installed wheel carries them under ``agspec/_data``; an editable install or a source
checkout finds them at the repository top level.
"""

from __future__ import annotations

from pathlib import Path

_PKG = Path(__file__).resolve().parent


def _find(name: str) -> Path:
    packaged = _PKG / "_data" / name
    if packaged.is_dir():
        return packaged
    return _PKG.parent / name


def schemas_dir() -> Path:
    return _find("schemas")


def catalogue_dir() -> Path:
    return _find("catalogue")


def spec_dir() -> Path:
    return _find("spec")


def conformance_dir() -> Path:
    """The conformance suite (cases, instances, traces), spec chapter 09."""
    return _find("conformance")
