"""The official AssemblyGrid v1 catalogue as IR dicts (contract shapes), for tests.

Written by hand from the paper's recipe table and REFERENCE_NOTES §3.1/§8.1 so that tests of
fingerprints, realizations and interop do not depend on the DSL parser. The lead checks that the
parsed catalogue (catalogue/*.ag) produces exactly these dicts.
"""

from __future__ import annotations

import copy
from typing import Any

IR = "agspec-ir/1"


def _op(op_id, typ, inputs, output, after, arity, roles, duration, weight) -> dict[str, Any]:
    return {
        "id": op_id,
        "type": typ,
        "inputs": sorted(inputs),
        "outputs": [output],
        "after": sorted(after),
        "arity": list(arity),
        "roles": [{"name": n, "binds": b} if b else {"name": n} for n, b in roles],
        "resources": [],
        "duration": duration,
        "weight": weight,
    }


def _recipe(rid: str, raw: list[str], ops: list[dict[str, Any]]) -> dict[str, Any]:
    return {
        "ir_version": IR,
        "kind": "recipe",
        "id": rid,
        "value": 1.0,
        "raw": raw,
        "resources": {},
        "operations": sorted(ops, key=lambda o: o["id"]),
        "xor": [],
    }


def official_recipes() -> dict[str, dict[str, Any]]:
    recipes = [
        _recipe("solo_inspection", ["A"], [
            _op("inspect", "inspect", ["A"], "FINAL", [], (1, 1), [("inspector", "A")], 2, 1.0),
        ]),
        _recipe("flow_serial_3", ["A"], [
            _op("prepare", "prepare", ["A"], "P1", [], (1, 1), [("operator", None)], 2, 1.0),
            _op("process", "process", ["P1"], "P2", ["prepare"], (1, 1), [("operator", None)], 3, 1.0),
            _op("inspect", "inspect", ["P2"], "FINAL", ["process"], (1, 1), [("inspector", None)], 2, 1.0),
        ]),
        _recipe("flow_serial_5", ["A"], [
            _op("prepare", "prepare", ["A"], "P1", [], (1, 1), [("operator", None)], 2, 1.0),
            _op("process_1", "process", ["P1"], "P2", ["prepare"], (1, 1), [("operator", None)], 3, 1.0),
            _op("process_2", "process", ["P2"], "P3", ["process_1"], (1, 1), [("operator", None)], 3, 1.0),
            _op("finish", "finish", ["P3"], "P4", ["process_2"], (1, 1), [("operator", None)], 2, 1.0),
            _op("inspect", "inspect", ["P4"], "FINAL", ["finish"], (1, 1), [("inspector", None)], 2, 1.0),
        ]),
        _recipe("pair_assembly", ["A", "B"], [
            _op("pair_join", "assemble", ["A", "B"], "FINAL", [], (2, 2),
                [("holder_A", "A"), ("holder_B", "B")], 4, 1.2),
        ]),
        _recipe("supported_insert", ["A", "B"], [
            _op("align_ab", "align", ["A", "B"], "AB", [], (2, 2),
                [("holder_A", "A"), ("holder_B", "B")], 3, 1.0),
            _op("supported_insert", "assemble", ["AB"], "FINAL", ["align_ab"], (2, 4),
                [("holder", "AB"), ("inserter", None), ("stabilizer", None), ("inspector", None)], 4, 1.3),
        ]),
        _recipe("standard_abc", ["A", "B", "C"], [
            _op("align_ab", "align", ["A", "B"], "AB", [], (2, 2),
                [("holder_A", "A"), ("holder_B", "B")], 3, 1.0),
            _op("stabilize_insert", "assemble", ["AB", "C"], "FINAL", ["align_ab"], (4, 4),
                [("holder_AB", "AB"), ("holder_C", "C"), ("operator", None), ("stabilizer", None)], 5, 1.5),
        ]),
        _recipe("parallel_branch_light", ["A", "B"], [
            _op("prepare_a", "prepare", ["A"], "PA", [], (1, 1), [("operator_a", None)], 3, 1.0),
            _op("prepare_b", "prepare", ["B"], "PB", [], (1, 1), [("operator_b", None)], 3, 1.0),
            _op("join_branches", "assemble", ["PA", "PB"], "FINAL", ["prepare_a", "prepare_b"], (2, 2),
                [("holder_PA", "PA"), ("holder_PB", "PB")], 4, 1.5),
        ]),
    ]
    return {r["id"]: r for r in recipes}


def abstract_v1() -> dict[str, Any]:
    return {
        "ir_version": IR, "kind": "profile", "id": "abstract-v1",
        "spacing": 1.0, "reach": 1.5, "reference_reach": 1.5, "reference_time": 1.0,
        "rho_conf": 0.25, "clearance": 0.1, "role_target_offset": 0.12, "retreat_fraction": 0.25,
        "speed": 1.0, "joint_speed": 1.0, "payload": 10.0, "robot_model": "generic_ur", "tools": ["gripper"],
        "durations": {"pick": 2, "handoff": 1, "deliver": 2},
        "motion_planning": True, "trajectory_conflicts": True,
        "variants": {
            "conflict-low": {"rho_conf": 0.12}, "conflict-medium": {"rho_conf": 0.25},
            "conflict-high": {"rho_conf": 0.4}, "spacing-0.75": {"spacing": 0.75},
            "spacing-1.00": {"spacing": 1.0}, "spacing-1.25": {"spacing": 1.25},
        },
    }


# family, level, rows, cols, recipe, wip_cap, interval (REFERENCE_NOTES §8.1, paper table)
OFFICIAL_TABLE = [
    ("flow", "easy", 4, 5, "solo_inspection", 3, 8),
    ("flow", "medium", 5, 6, "flow_serial_3", 5, 5),
    ("flow", "hard", 6, 8, "flow_serial_5", 10, 2),
    ("coalition", "easy", 5, 6, "pair_assembly", 4, 7),
    ("coalition", "medium", 5, 6, "supported_insert", 4, 5),
    ("coalition", "hard", 6, 8, "standard_abc", 1, 8),
    ("concurrency", "easy", 5, 6, "parallel_branch_light", 2, 10),
    ("concurrency", "medium", 5, 6, "parallel_branch_light", 5, 5),
    ("concurrency", "hard", 6, 8, "parallel_branch_light", 10, 2),
]


def _scenario(sid, family, level, rows, cols, recipe, wip, interval, *, variant=None, official=True):
    return {
        "ir_version": IR, "kind": "scenario", "id": sid,
        "family": family, "level": level,
        "grid": {"rows": rows, "cols": cols, "topology": "moore", "radius": 1},
        "recipes": [recipe],
        "profile": {"id": "abstract-v1", "variant": variant},
        "release": {"interval": interval, "wip_cap": wip},
        "evaluation": {"mode": "continuing", "horizon": 400},
        "shelves": {"capacity": 6, "replenish_interval": 5, "extra_access_probability": 0.3},
        "coordination": {"support_timeout": 3, "switch_lock": 1, "support_visible": True,
                         "bilateral_handoff": True},
        "products": {"mass": [0.5, 2.0], "due_slack": 2.2, "due_slack_jitter": 0.5},
        "resources": {},
        "suite": {"official": official, "prefix": "ag32", "generation_seed_base": 10000,
                  "execution_seed_base": 20000},
    }


def official_scenarios() -> dict[str, dict[str, Any]]:
    out = {}
    for family, level, rows, cols, recipe, wip, interval in OFFICIAL_TABLE:
        sid = f"{family}-{level}"
        out[sid] = _scenario(sid, family, level, rows, cols, recipe, wip, interval)
    for level in ("low", "medium", "high"):
        sid = f"geometry-matched-{level}"
        out[sid] = _scenario(sid, "geometry", level, 5, 6, "supported_insert", 4, 5,
                             variant=f"conflict-{level}", official=False)
    return out


def official_ir() -> dict[str, dict[str, dict[str, Any]]]:
    """{"recipes": {id: IR}, "profiles": {id: IR}, "scenarios": {id: IR}} — fresh copies."""
    return copy.deepcopy({
        "recipes": official_recipes(),
        "profiles": {"abstract-v1": abstract_v1()},
        "scenarios": official_scenarios(),
    })


def bundle(name: str) -> tuple[dict[str, Any], dict[str, dict[str, Any]], dict[str, Any]]:
    """(scenario_ir, recipes, profile_ir) for a scenario name — the `load_fn` shape."""
    ir = official_ir()
    scenario = ir["scenarios"][name]
    recipes = {rid: ir["recipes"][rid] for rid in scenario["recipes"]}
    return scenario, recipes, ir["profiles"][scenario["profile"]["id"]]
