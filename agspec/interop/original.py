"""Interop with the original AssemblyGrid v1 release (v1.0.0).

* :func:`instance_definition` builds the original's ``assemblygrid-instance-v1`` content
  identity of an instance (spec F-ORIGINAL-IDENTITY; REFERENCE_NOTES §8.2), and
  :func:`instance_sha256` its digest: SHA-256 of the UTF-8 JSON with sorted keys, separators
  ``(",", ":")`` and ``ensure_ascii=False``. For every official realization this reproduces the
  published catalogue digest.
* :func:`original_instance_id` maps an agspec instance to the original's instance id
  (``ag32-{family}-{level}-sNN``).
* :func:`result_record` writes an ``assemblygrid-result-v1`` record (schema
  ``schemas/original-result-v1.schema.json``, ``$id`` ``urn:assemblygrid:schema:result:v1``).

The original's identity names recipes and the geometry profile by id, so only instances whose
recipes are the original's registry recipes can be exported; anything else raises
:class:`ExportError` rather than producing a digest that would claim a different problem.
"""

from __future__ import annotations

import hashlib
import json
import math
from typing import Any, Mapping

from agspec.ir import variants

INSTANCE_SCHEMA = "assemblygrid-instance-v1"
RESULT_SCHEMA = "assemblygrid-result-v1"
BENCHMARK = "AssemblyGrid"
ORIGINAL_VERSION = "v1.0.0"
DEFAULT_BATCH_Z = 30  # the original EnvConfig default; part of its identity even in horizon mode


class ExportError(ValueError):
    """The instance (or result) cannot be expressed in the original release's formats."""


# --------------------------------------------------------------------------- original registry
# The original's canonical geometry profile `abstract-v1` (public profiles.py values) and its
# declared variants. Profile-owned numbers are represented in the original identity only by
# profile + variant name when the profile is enforced, i.e. when these values hold exactly.
ABSTRACT_V1 = {
    "spacing": 1.0, "reach": 1.5, "reference_reach": 1.5, "reference_time": 1.0, "rho_conf": 0.25,
    "clearance": 0.1, "role_target_offset": 0.12, "retreat_fraction": 0.25, "speed": 1.0,
    "joint_speed": 1.0, "payload": 10.0, "robot_model": "generic_ur", "tools": ["gripper"],
    "motion_planning": True, "trajectory_conflicts": True,
}
ABSTRACT_V1_VARIANTS = {
    None: {},
    "conflict-low": {"rho_conf": 0.12}, "conflict-medium": {"rho_conf": 0.25},
    "conflict-high": {"rho_conf": 0.4}, "spacing-0.75": {"spacing": 0.75},
    "spacing-1.00": {"spacing": 1.0}, "spacing-1.25": {"spacing": 1.25},
}

# The original's registry recipes (paper recipe table; REFERENCE_NOTES §3.1):
# recipe -> (raw, {op: (inputs, output, after, (kmin, kmax), role names, duration, weight)})
ORIGINAL_RECIPES: dict[str, tuple[list[str], dict[str, tuple]]] = {
    "solo_inspection": (["A"], {
        "inspect": (["A"], "FINAL", [], (1, 1), ["inspector"], 2, 1.0)}),
    "flow_serial_3": (["A"], {
        "prepare": (["A"], "P1", [], (1, 1), ["operator"], 2, 1.0),
        "process": (["P1"], "P2", ["prepare"], (1, 1), ["operator"], 3, 1.0),
        "inspect": (["P2"], "FINAL", ["process"], (1, 1), ["inspector"], 2, 1.0)}),
    "flow_serial_5": (["A"], {
        "prepare": (["A"], "P1", [], (1, 1), ["operator"], 2, 1.0),
        "process_1": (["P1"], "P2", ["prepare"], (1, 1), ["operator"], 3, 1.0),
        "process_2": (["P2"], "P3", ["process_1"], (1, 1), ["operator"], 3, 1.0),
        "finish": (["P3"], "P4", ["process_2"], (1, 1), ["operator"], 2, 1.0),
        "inspect": (["P4"], "FINAL", ["finish"], (1, 1), ["inspector"], 2, 1.0)}),
    "pair_assembly": (["A", "B"], {
        "pair_join": (["A", "B"], "FINAL", [], (2, 2), ["holder_A", "holder_B"], 4, 1.2)}),
    "supported_insert": (["A", "B"], {
        "align_ab": (["A", "B"], "AB", [], (2, 2), ["holder_A", "holder_B"], 3, 1.0),
        "supported_insert": (["AB"], "FINAL", ["align_ab"], (2, 4),
                             ["holder", "inserter", "stabilizer", "inspector"], 4, 1.3)}),
    "standard_abc": (["A", "B", "C"], {
        "align_ab": (["A", "B"], "AB", [], (2, 2), ["holder_A", "holder_B"], 3, 1.0),
        "stabilize_insert": (["AB", "C"], "FINAL", ["align_ab"], (4, 4),
                             ["holder_AB", "holder_C", "operator", "stabilizer"], 5, 1.5)}),
    "parallel_branch_light": (["A", "B"], {
        "prepare_a": (["A"], "PA", [], (1, 1), ["operator_a"], 3, 1.0),
        "prepare_b": (["B"], "PB", [], (1, 1), ["operator_b"], 3, 1.0),
        "join_branches": (["PA", "PB"], "FINAL", ["prepare_a", "prepare_b"], (2, 2),
                          ["holder_PA", "holder_PB"], 4, 1.5)}),
}


def _recipe_signature(recipe: Mapping[str, Any]) -> tuple[list[str], dict[str, tuple]]:
    ops = {}
    for op in recipe.get("operations", []):
        ops[op["id"]] = (
            sorted(op.get("inputs", [])),
            op["outputs"][0] if len(op.get("outputs", [])) == 1 else list(op.get("outputs", [])),
            sorted(op.get("after", [])),
            tuple(op.get("arity", [])),
            [role["name"] for role in op.get("roles", [])],
            op.get("duration"),
            op.get("weight", 1.0),
        )
    return list(recipe.get("raw", [])), ops


def _plain(value: Any) -> Any:
    return list(value) if isinstance(value, (list, tuple)) else value


def registry_mismatch(recipe: Mapping[str, Any]) -> str | None:
    """Why ``recipe`` is not the original's registry recipe of the same id (None if it is)."""
    rid = recipe.get("id")
    if rid not in ORIGINAL_RECIPES:
        return f"recipe `{rid}` is not in the original release's recipe registry"
    raw, ops = ORIGINAL_RECIPES[rid]
    got_raw, got_ops = _recipe_signature(recipe)
    if got_raw != raw:
        return f"recipe `{rid}`: raw materials {got_raw} differ from the original's {raw}"
    if sorted(got_ops) != sorted(ops):
        return f"recipe `{rid}`: operations {sorted(got_ops)} differ from the original's {sorted(ops)}"
    names = ("inputs", "output", "after", "arity", "roles", "duration", "weight")
    for op_id, expected in ops.items():
        for name, want, got in zip(names, expected, got_ops[op_id]):
            if _plain(want) != _plain(got):
                return f"recipe `{rid}`, operation `{op_id}`: {name} {got!r} differs from the original's {want!r}"
    if recipe.get("xor") or recipe.get("resources") or any(op.get("resources") for op in recipe.get("operations", [])):
        return f"recipe `{rid}` declares XOR groups or resources the original registry recipe does not"
    if float(recipe.get("value", 1.0)) != 1.0:
        return f"recipe `{rid}`: product value {recipe.get('value')} differs from the original's 1.0"
    return None


def profile_enforced(profile: Mapping[str, Any]) -> bool:
    """True iff the resolved profile is exactly the original's abstract-v1 (with a declared variant)."""
    variant = profile.get("variant")
    if profile.get("id") != "abstract-v1" or variant not in ABSTRACT_V1_VARIANTS:
        return False
    expected = {**ABSTRACT_V1, **ABSTRACT_V1_VARIANTS[variant]}
    return all(profile.get(k) == v for k, v in expected.items())


def _robot_model(profile: Mapping[str, Any]) -> dict[str, Any]:
    return {
        "clearance": float(profile["clearance"]), "joint_speed": float(profile["joint_speed"]),
        "name": profile["robot_model"], "payload": float(profile["payload"]),
        "reach_radius": float(profile["reach"]), "speed": float(profile["speed"]),
        "tools": list(profile.get("tools", [])),
    }


# --------------------------------------------------------------------------- identity


def instance_definition(instance_ir: Mapping[str, Any]) -> dict[str, Any]:
    """The original's ``instance_definition(cfg)`` for this instance (F-ORIGINAL-IDENTITY)."""
    scenario, profile = instance_ir["scenario"], instance_ir["profile"]
    for rid in dict.fromkeys(scenario["recipes"]):
        problem = registry_mismatch(instance_ir["recipes"][rid])
        if problem:
            raise ExportError(problem + "; the assemblygrid-instance-v1 identity names recipes only by id")
    grid, release, shelves = scenario["grid"], scenario["release"], scenario["shelves"]
    coordination, products, evaluation = scenario["coordination"], scenario["products"], scenario["evaluation"]
    durations = profile["durations"]
    rows, cols = int(grid["rows"]), int(grid["cols"])
    enforced = profile_enforced(profile)

    if evaluation["mode"] == "batch":
        mode = {"episode_mode": "batch", "horizon_T": int(evaluation["timeout"]),
                "batch_Z": int(evaluation["batch_size"])}
    else:
        mode = {"episode_mode": "horizon", "horizon_T": int(evaluation["horizon"]), "batch_Z": DEFAULT_BATCH_Z}
    population: dict[str, Any] = {"count": rows * cols, "assignment": "homogeneous"}
    if enforced:
        population["model_source"] = "geometry_profile"
    else:
        population["robot_models"] = [_robot_model(profile)]

    defn: dict[str, Any] = {
        "schema": INSTANCE_SCHEMA,
        "spatial": {
            "M": rows, "N": cols, "topology": grid["topology"], "cooperation_radius": int(grid.get("radius", 1)),
            "geometry_profile": profile["id"], "geometry_variant": profile.get("variant"),
            "reference_reach": float(profile["reference_reach"]),
            "reference_time": float(profile["reference_time"]),
            "role_target_offset": float(profile["role_target_offset"]),
        },
        "robot_population": population,
        "process": {"recipe_ids": list(scenario["recipes"])},
        "material_resources": {
            "shelf_cap": int(shelves["capacity"]),
            "shelf_replenish_interval": int(shelves["replenish_interval"]),
            "reach_extra_prob": float(shelves["extra_access_probability"]),
            "product_mass_min": float(products["mass"][0]),
            "product_mass_max": float(products["mass"][1]),
            "resource_capacities": {k: int(v) for k, v in sorted((scenario.get("resources") or {}).items())},
        },
        "demand": {"spawn_interval": int(release["interval"]), "max_wip": int(release["wip_cap"])},
        "timing": {"pick_duration": int(durations["pick"]), "deliver_duration": int(durations["deliver"]),
                   "handoff_duration": int(durations["handoff"])},
        "cooperation": {"formation_timeout": int(coordination["support_timeout"]),
                        "commitment_horizon": int(coordination["switch_lock"]),
                        "require_bilateral_handoff": bool(coordination["bilateral_handoff"])},
        "information": {"proposal_support_visible": bool(coordination["support_visible"])},
        "evaluation_mode": mode,
        "generation_seed": int(instance_ir["seeds"]["generation"]),
    }
    if not enforced:
        # Non-canonical profile: the profile-owned numbers become explicit (original: geometry_overrides).
        defn["geometry_overrides"] = {
            "cell_spacing": float(profile["spacing"]),
            "workspace_conflict_radius": float(profile["rho_conf"]),
            "retreat_fraction": float(profile["retreat_fraction"]),
            "motion_planning": bool(profile["motion_planning"]),
            "trajectory_conflicts": bool(profile["trajectory_conflicts"]),
        }
    return defn


def canonical_json(defn: Mapping[str, Any]) -> bytes:
    return json.dumps(defn, sort_keys=True, separators=(",", ":"), ensure_ascii=False).encode("utf-8")


def instance_sha256(defn: Mapping[str, Any]) -> str:
    """The original's content digest: SHA-256 hex of sorted-key compact JSON (UTF-8)."""
    return hashlib.sha256(canonical_json(defn)).hexdigest()


def original_instance_id(instance_ir: Mapping[str, Any]) -> str:
    """The original's instance id: `ag32-{family}-{level}-s{index:02d}` for official suite indices.

    Non-official suites with a prefix (the geometry-matched control) map to
    `{prefix}-{scenario}-s{index:02d}` (e.g. `ag32-geometry-matched-low-s00`); instances made
    from an explicit seed keep their agspec id.
    """
    scenario, seeds = instance_ir["scenario"], instance_ir["seeds"]
    suite = scenario.get("suite") or {}
    index = seeds.get("index")
    base = suite.get("generation_seed_base")
    if index is None or base is None or int(base) + int(index) != seeds["generation"]:
        return instance_ir.get("id") or f"{scenario['id']}-g{seeds['generation']}"
    if suite.get("official"):
        return f"{suite['prefix']}-{scenario['family']}-{scenario['level']}-s{index:02d}"
    if suite.get("prefix"):
        return f"{suite['prefix']}-{scenario['id']}-s{index:02d}"
    return f"{scenario['id']}-s{index:02d}"


# --------------------------------------------------------------------------- results

MANDATORY_METRICS = (
    "delivered", "completion_rate", "unfinished_count", "throughput", "makespan",
    "restricted_mean_flow_time", "coalition_success_rate", "coalition_formation_latency",
    "geometry_rejection_count", "geometry_conflict_count", "geometry_delay_ticks",
)
OPTIONAL_METRICS = ("blocked_activity_count", "geometry_block_count", "resource_block_count", "robot_block_count")
INTEGER_METRICS = frozenset({
    "delivered", "unfinished_count", "geometry_rejection_count", "geometry_conflict_count",
    "blocked_activity_count", "geometry_block_count", "resource_block_count", "robot_block_count",
})
NULLABLE_METRICS = frozenset({
    "throughput", "makespan", "restricted_mean_flow_time", "coalition_success_rate", "coalition_formation_latency",
})
# agspec metric name -> original result metric name (identical in v1, but aliases are accepted)
METRIC_ALIASES = {"trajectory_conflicts": "geometry_conflict_count"}

# controller -> (execution_information, training_information) of the reference methods
CONTROLLER_INFORMATION = {
    "random": ("local", "not_applicable"),
    "random_feasible": ("local", "not_applicable"),
    "greedy": ("local", "not_applicable"),
    "parallel_aware": ("local", "not_applicable"),
    "centralized": ("global", "not_applicable"),
}
FAMILIES = ("flow", "coalition", "concurrency", "geometry")
DIFFICULTIES = ("easy", "medium", "hard")
FIDELITIES = ("abstract-v1", "geometry-off-control", "ur10-case-v1", "ur10-kinematic-validation-v1")
STATUSES = ("complete", "zero_delivery", "timeout", "failed", "unavailable")


def _metric_value(name: str, value: Any) -> Any:
    if value is None:
        if name in NULLABLE_METRICS:
            return None
        raise ExportError(f"metric `{name}` must not be null")
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ExportError(f"metric `{name}` must be a number, got {value!r}")
    if not math.isfinite(value):
        raise ExportError(f"metric `{name}` must be finite, got {value!r}")
    if name in INTEGER_METRICS:
        if float(value) != int(value):
            raise ExportError(f"metric `{name}` must be a whole count, got {value!r}")
        return int(value)  # a true integer (the original emits e.g. 3.0 for unfinished_count)
    return value


def _fidelity(profile: Mapping[str, Any]) -> str:
    if profile.get("id") == "abstract-v1":
        if not variants.enabled("motion_planning", profile) or not variants.enabled("trajectory_conflicts", profile):
            return "geometry-off-control"
        return "abstract-v1"
    if profile.get("id") in FIDELITIES:
        return profile["id"]
    raise ExportError(f"profile `{profile.get('id')}` has no fidelity label in the original result schema")


def _status(instance_ir: Mapping[str, Any], delivered: int) -> str:
    evaluation = instance_ir["scenario"]["evaluation"]
    if delivered == 0:
        return "zero_delivery"
    if evaluation["mode"] == "batch" and delivered < int(evaluation["batch_size"]):
        return "timeout"
    return "complete"


def result_record(
    instance_ir: Mapping[str, Any],
    controller: str,
    metrics: Mapping[str, Any],
    *,
    benchmark_version: str = ORIGINAL_VERSION,
    execution_information: str | None = None,
    training_information: str | None = None,
    algorithm_seed: int | None = None,
    environment_steps: int = 0,
    evaluation_episodes: int = 1,
    status: str | None = None,
    fidelity: str | None = None,
    family: str | None = None,
    difficulty: str | None = None,
    reward: Mapping[str, Any] | None = None,
    extra_metrics: bool = True,
) -> dict[str, Any]:
    """An ``assemblygrid-result-v1`` record for one evaluated instance (F-RESULT-RECORD).

    ``metrics`` uses agspec metric names (identical to the original's in v1). Counts are emitted
    as true integers. Other numeric metrics are passed through when ``extra_metrics`` is true
    (the schema's metrics object is open).
    """
    scenario = instance_ir["scenario"]
    named = {METRIC_ALIASES.get(k, k): v for k, v in metrics.items()}
    if "geometry_conflict_count" not in named and "blocked_activity_count" in named:
        named["geometry_conflict_count"] = named["blocked_activity_count"]  # legacy alias (§6)
    missing = [m for m in MANDATORY_METRICS if m not in named]
    if missing:
        raise ExportError(f"missing mandatory metric(s): {', '.join(missing)}")
    out_metrics = {m: _metric_value(m, named[m]) for m in MANDATORY_METRICS}
    for m in OPTIONAL_METRICS:
        if named.get(m) is not None:
            out_metrics[m] = _metric_value(m, named[m])
    if extra_metrics:
        for k, v in named.items():
            if k not in out_metrics and (v is None or isinstance(v, (int, float, str, bool))):
                out_metrics[k] = v

    family = family or scenario.get("family")
    difficulty = difficulty or scenario.get("level")
    if family not in FAMILIES:
        raise ExportError(f"family `{family}` is not one of the original's {', '.join(FAMILIES)}")
    if difficulty not in DIFFICULTIES:
        raise ExportError(f"difficulty `{difficulty}` is not one of the original's {', '.join(DIFFICULTIES)}")
    info = CONTROLLER_INFORMATION.get(controller, ("local", "not_applicable"))
    status = status or _status(instance_ir, out_metrics["delivered"])
    if status not in STATUSES:
        raise ExportError(f"status `{status}` is not one of {', '.join(STATUSES)}")
    fidelity = fidelity or _fidelity(instance_ir["profile"])
    if fidelity not in FIDELITIES:
        raise ExportError(f"fidelity `{fidelity}` is not one of {', '.join(FIDELITIES)}")
    seeds = instance_ir["seeds"]
    record: dict[str, Any] = {
        "schema": RESULT_SCHEMA,
        "benchmark": BENCHMARK,
        "benchmark_version": benchmark_version,
        "instance": {
            "id": original_instance_id(instance_ir),
            "sha256": instance_sha256(instance_definition(instance_ir)),
            "family": family,
            "difficulty": difficulty,
            "episode_mode": "batch" if scenario["evaluation"]["mode"] == "batch" else "horizon",
        },
        "seeds": {"generation": int(seeds["generation"]), "execution": int(seeds["execution"]),
                  "algorithm": algorithm_seed},
        "method": {"name": controller,
                   "execution_information": execution_information or info[0],
                   "training_information": training_information or info[1]},
        "budget": {"environment_steps": int(environment_steps), "evaluation_episodes": int(evaluation_episodes)},
        "fidelity": fidelity,
        "status": status,
        "metrics": out_metrics,
    }
    if reward is not None:
        record["reward"] = dict(reward)
    return record
