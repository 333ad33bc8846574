"""IR builders for the semantic-check tests (validate, realizability, topology).

The official documents come from ``conftest_ir`` (shared with the instance tests); this module adds
a configurable scenario builder, a resolved profile, and an in-memory resolver.  Every call returns
a fresh copy that a test may mutate.
"""

from __future__ import annotations

import copy
from typing import Any

from agspec.formats.diagnostics import Issue
from conftest_ir import OFFICIAL_TABLE, abstract_v1, official_recipes, official_scenarios

IR = "agspec-ir/1"
__all__ = ["OFFICIAL_TABLE", "abstract_v1", "official_recipes", "official_scenarios"]

OFFICIAL_RECIPE_IDS = tuple(official_recipes())


def official_recipe(rid: str) -> dict[str, Any]:
    return official_recipes()[rid]


def resolved_profile(variant: str | None = None) -> dict[str, Any]:
    """The profile with ``variant`` applied (PR-VARIANT), as embedded in instances."""
    prof = abstract_v1()
    overrides = prof.pop("variants").get(variant, {}) if variant else {}
    prof.update(copy.deepcopy(overrides))
    prof["variant"] = variant
    return prof


def scenario(
    recipes=("supported_insert",),
    rows: int = 5,
    cols: int = 6,
    topology: str = "moore",
    wip_cap: int = 4,
    interval: int = 5,
    variant: str | None = None,
    sid: str = "test-scenario",
) -> dict[str, Any]:
    return {
        "ir_version": IR,
        "kind": "scenario",
        "id": sid,
        "family": "coalition",
        "level": "medium",
        "grid": {"rows": rows, "cols": cols, "topology": topology, "radius": 1},
        "recipes": list(recipes),
        "profile": {"id": "abstract-v1", "variant": variant},
        "release": {"interval": interval, "wip_cap": wip_cap},
        "evaluation": {"mode": "continuing", "horizon": 400},
        "shelves": {"capacity": 6, "replenish_interval": 5, "extra_access_probability": 0.3},
        "coordination": {"support_timeout": 3, "switch_lock": 1, "support_visible": True, "bilateral_handoff": True},
        "products": {"mass": [0.5, 2.0], "due_slack": 2.2, "due_slack_jitter": 0.5},
        "resources": {},
    }


class DictResolver:
    """Resolver protocol over in-memory documents: get(kind, name) -> ir | None."""

    def __init__(self, *docs: dict[str, Any]) -> None:
        self.docs = {(d["kind"], d["id"]): d for d in docs}

    def get(self, kind: str, name: str):
        return self.docs.get((kind, name))


def official_resolver(*extra: dict[str, Any]) -> DictResolver:
    return DictResolver(*official_recipes().values(), abstract_v1(), *extra)


def found(issues: list[Issue]) -> set[tuple[str, str, str]]:
    return {(i.code, i.pointer, i.severity) for i in issues}


def xor_recipe() -> dict:
    """A valid recipe with an XOR group: align, then glue OR weld, then inspect after the group."""
    def op(oid, inputs, output, after, kind="assemble"):
        n = len(inputs)
        return {"id": oid, "type": kind, "inputs": inputs, "outputs": [output], "after": after,
                "arity": [n, n], "roles": [{"name": f"holder_{t}", "binds": t} for t in inputs],
                "resources": [], "duration": 2, "weight": 1.0}
    return {
        "ir_version": "agspec-ir/1", "kind": "recipe", "id": "glue_or_weld", "value": 1.0,
        "raw": ["A", "B"], "resources": {},
        "operations": [
            op("align", ["A", "B"], "AB", []),  # 0
            op("glue", ["AB"], "G", ["align"]),  # 1
            op("inspect", ["G"], "FINAL", ["route"], "inspect"),  # 2
            op("weld", ["AB"], "G", ["align"]),  # 3
        ],
        "xor": [{"id": "route", "alternatives": ["glue", "weld"]}],
    }
