"""Semantic checks on IR documents, one module per spec chapter: ``recipe`` (02, RC-*; with the
per-route ``material`` checks and the recipe ``view``), ``profile`` (03, PR-*), ``scenario`` and
``realization`` (04, S-*), helpers in ``common``; this module dispatches.

Every check returns :class:`~agspec.formats.diagnostics.Issue` values located by a JSON Pointer into the
IR, so that the CLI can place them in the ``.ag`` source through the source map.  All problems of a
document are reported in one run; no check raises on malformed input (schema problems are the
schema's to report, AG2xx — the checks here skip values of the wrong type instead of crashing).

Codes (documented with an example each in spec/09-formats.md):
  AG30x names, precedence and material   AG32x XOR groups   AG33x arity   AG34x roles
  AG35x durations, weights, value         AG36x resources    AG39x limits of the analysis
  AG40x profile   AG41x/AG42x scenario   AG5xx instance realization
Realizability of a scenario under its geometry profile (AG45x) needs the geometry model and
lives in :mod:`agspec.interp.realizability` (ir/ never imports interp/).

Public API::

    validate_recipe(ir, k_topo=None) -> list[Issue]
    validate_profile(ir) -> list[Issue]
    validate_scenario(ir, resolver) -> list[Issue]
    validate_instance(ir) -> list[Issue]
    validate_document(ir, resolver) -> list[Issue]

``resolver`` is anything with ``get(kind, name) -> ir | None`` (:class:`Resolver`).
"""

from __future__ import annotations

from typing import Sequence

from agspec.formats.diagnostics import Issue
from agspec.ir.validate.common import Json, Resolver, _dict, errors
from agspec.ir.validate.profile import _check_profile_values, validate_profile
from agspec.ir.validate.realization import validate_instance
from agspec.ir.validate.recipe import _check_numbers, _check_resources, arity_of, recipe_view, route_graph, route_ops
from agspec.ir.validate.recipe import routes, terminal_token, validate_recipe
from agspec.ir.validate.scenario import _check_grid, _check_scenario_numbers, _check_scenario_resources
from agspec.ir.validate.scenario import validate_scenario

__all__ = ["Resolver", "arity_of", "errors", "recipe_view", "route_graph", "route_ops", "routes", "rule_codes",
           "terminal_token", "validate_document", "validate_instance", "validate_profile", "validate_recipe",
           "validate_scenario", "value_issues"]


def value_issues(ir: Json) -> list[Issue]:
    """The rules about single values (RC-DURATION, RC-WEIGHT, RC-VALUE, RC-RESOURCES, PR-RANGES,
    S-GRID, S-RELEASE ... S-RESOURCES) on any IR, schema-valid or not: their checks tolerate wrong types."""
    doc = _dict(ir)
    kind = doc.get("kind")
    if kind == "recipe":
        view = recipe_view(doc)
        return _check_numbers(doc, view) + [i for i in _check_resources(doc, view) if i.code == "AG361"]
    if kind == "profile":
        return _check_profile_values(doc, doc, "")
    if kind == "scenario":
        return _check_grid(doc) + _check_scenario_numbers(doc) + _check_scenario_resources(doc)
    return []


# schema codes that a rule's own code replaces at the same pointer: wrong type, out of range, not allowed
_SCHEMA_VALUE_CODES = frozenset({"AG202", "AG203", "AG205"})


def rule_codes(ir: Json, schema_issues: Sequence[Issue]) -> list[Issue]:
    """Schema issues with the code and message of the spec rule a bad value breaks (F-CODES: a duration
    of 2.5 is AG350, not the generic AG202), where a rule covers that value."""
    if not any(i.code in _SCHEMA_VALUE_CODES for i in schema_issues):
        return list(schema_issues)
    by_pointer: dict[str, Issue] = {}
    for issue in value_issues(ir):
        by_pointer.setdefault(issue.pointer, issue)
    return [by_pointer.get(i.pointer, i) if i.code in _SCHEMA_VALUE_CODES else i for i in schema_issues]


def validate_document(ir: Json, resolver: Resolver | None = None) -> list[Issue]:
    """Validate any IR document by its ``kind``.

    Recipes are checked against the default topology (D-KTOPO: 4); scenarios resolve their
    references through ``resolver``.  An unknown kind is a usage error the loader reports (AG0xx)
    before validation, so it raises ``ValueError`` here.
    """
    kind = _dict(ir).get("kind")
    if kind == "recipe":
        return validate_recipe(ir)
    if kind == "profile":
        return validate_profile(ir)
    if kind == "scenario":
        return validate_scenario(ir, resolver if resolver is not None else _NoResolver())
    if kind == "instance":
        return validate_instance(ir)
    raise ValueError(f"cannot validate a document of kind {kind!r}")


class _NoResolver:
    def get(self, kind: str, name: str) -> Json | None:
        return None
