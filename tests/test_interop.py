"""F-ORIGINAL-IDENTITY and F-RESULT-RECORD: interop with the original AssemblyGrid v1 release."""

from __future__ import annotations

import copy
import json

import jsonschema
import pytest

from agspec.interop.original import (
    ExportError,
    instance_definition,
    instance_sha256,
    original_instance_id,
    profile_enforced,
    result_record,
)
from agspec.ir.instance import make_instance
from agspec.resources import schemas_dir
from conftest_ir import bundle

# Digests published in the original's official_realizations.json (one per cell) and, for
# index 1000, reported by the original engine for the final-test instance.
PUBLISHED = [
    ("flow-easy", 0, "ag32-flow-easy-s00", "b87822087ece44957a53d8a1e973373f9083eaa835aeade0b1daae99d482c10d"),
    ("flow-medium", 1, "ag32-flow-medium-s01", "6197c6a7a0200a23c4f1056feda20649eb3e1b1f59fab92790e8af59616600b6"),
    ("flow-hard", 2, "ag32-flow-hard-s02", "72d704eb853f0df50780f1b00402cb2e542d2e69019be1b732a77075737492c8"),
    ("coalition-easy", 3, "ag32-coalition-easy-s03",
     "74e9d96d565aad7a076072a5ccfadd2e34c48ae3d3707b78e306f618fd8fd7d1"),
    ("coalition-medium", 4, "ag32-coalition-medium-s04",
     "35ec91d5b8be51833b4d8af06a7f2f0fd2789a1d863ecd6ae36fa7e723edfa95"),
    ("coalition-hard", 0, "ag32-coalition-hard-s00",
     "52fa73667ae777aa55dd371a9a5b8208d0a8391aad3a38b4dcd9e8938e23df34"),
    ("concurrency-easy", 1, "ag32-concurrency-easy-s01",
     "8f07de529eb34b10e775d9b2d16b3f54561d8e80272675f068e811706af810cf"),
    ("concurrency-medium", 2, "ag32-concurrency-medium-s02",
     "1f036fee60f53706adb4bd61e76f9bb70c02d5491828c49d36ebef6f4413feb3"),
    ("concurrency-hard", 3, "ag32-concurrency-hard-s03",
     "06b0793d66d885660098576175ba32d903dd0993345848856ce04c262eb19f14"),
    ("coalition-medium", 1000, "ag32-coalition-medium-s1000",
     "fb710d89a0fb71a180df099fabde6f07dd41f64cb3055abfdf3e3bb653aace28"),
]

# The published instance_definition of ag32-flow-easy-s00.
FLOW_EASY_S00 = {
    "cooperation": {"commitment_horizon": 1, "formation_timeout": 3, "require_bilateral_handoff": True},
    "demand": {"max_wip": 3, "spawn_interval": 8},
    "evaluation_mode": {"batch_Z": 30, "episode_mode": "horizon", "horizon_T": 400},
    "generation_seed": 10000,
    "information": {"proposal_support_visible": True},
    "material_resources": {"product_mass_max": 2.0, "product_mass_min": 0.5, "reach_extra_prob": 0.3,
                           "resource_capacities": {}, "shelf_cap": 6, "shelf_replenish_interval": 5},
    "process": {"recipe_ids": ["solo_inspection"]},
    "robot_population": {"assignment": "homogeneous", "count": 20, "model_source": "geometry_profile"},
    "schema": "assemblygrid-instance-v1",
    "spatial": {"M": 4, "N": 5, "cooperation_radius": 1, "geometry_profile": "abstract-v1",
                "geometry_variant": None, "reference_reach": 1.5, "reference_time": 1.0,
                "role_target_offset": 0.12, "topology": "moore"},
    "timing": {"deliver_duration": 2, "handoff_duration": 1, "pick_duration": 2},
}


def _inst(cell, index=0):
    return make_instance(*bundle(cell), index=index)


@pytest.mark.parametrize("cell,index,oid,digest", PUBLISHED)
def test_published_digests_are_reproduced(cell, index, oid, digest):
    inst = _inst(cell, index)
    assert original_instance_id(inst) == oid
    assert instance_sha256(instance_definition(inst)) == digest


def test_definition_matches_the_published_one_key_by_key():
    defn = instance_definition(_inst("flow-easy", 0))
    assert defn == FLOW_EASY_S00
    # same JSON text, so float spellings (1.0, 2.0) agree too
    assert json.dumps(defn, sort_keys=True) == json.dumps(FLOW_EASY_S00, sort_keys=True)


def test_definition_ignores_non_identity_settings():
    """Due slack and execution seeds are not part of the original identity (§8.2)."""
    sc, rc, pr = bundle("coalition-easy")
    base = instance_sha256(instance_definition(make_instance(sc, rc, pr, index=0)))
    slack = copy.deepcopy(sc)
    slack["products"]["due_slack"] = 3.0
    assert instance_sha256(instance_definition(make_instance(slack, rc, pr, index=0))) == base
    assert instance_sha256(instance_definition(make_instance(sc, rc, pr, index=0, execution_seed=1))) == base
    wip = copy.deepcopy(sc)
    wip["release"]["wip_cap"] = 5
    assert instance_sha256(instance_definition(make_instance(wip, rc, pr, index=0))) != base


def test_int_spelled_floats_still_match():
    """A catalogue that spells 1.0 as 1 must not change the original digest."""
    sc, rc, pr = bundle("flow-easy")
    pr = dict(pr, reference_time=1, reference_reach=1.5)
    sc = copy.deepcopy(sc)
    sc["products"]["mass"] = [0.5, 2]
    inst = make_instance(sc, rc, pr, index=0)
    assert instance_sha256(instance_definition(inst)) == PUBLISHED[0][3]


def test_matched_variant_ids_and_variant_identity():
    inst = _inst("geometry-matched-low", 0)
    assert original_instance_id(inst) == "ag32-geometry-matched-low-s00"
    defn = instance_definition(inst)
    assert defn["spatial"]["geometry_variant"] == "conflict-low"
    assert profile_enforced(inst["profile"]) and "geometry_overrides" not in defn
    high = instance_definition(_inst("geometry-matched-high", 0))
    assert instance_sha256(high) != instance_sha256(defn)


def test_non_canonical_profile_is_explicit():
    sc, rc, pr = bundle("coalition-medium")
    custom = dict(pr, rho_conf=0.3)
    inst = make_instance(sc, rc, custom, index=0)
    assert not profile_enforced(inst["profile"])
    defn = instance_definition(inst)
    assert defn["geometry_overrides"]["workspace_conflict_radius"] == 0.3
    assert defn["robot_population"]["robot_models"][0]["reach_radius"] == 1.5
    assert "model_source" not in defn["robot_population"]


def test_non_registry_recipes_cannot_be_exported():
    sc, rc, pr = bundle("coalition-medium")
    changed = copy.deepcopy(rc)
    changed["supported_insert"]["operations"][1]["duration"] = 5
    with pytest.raises(ExportError, match="duration"):
        instance_definition(make_instance(sc, changed, pr, index=0))
    renamed = {"my_insert": dict(copy.deepcopy(rc["supported_insert"]), id="my_insert")}
    sc2 = dict(sc, recipes=["my_insert"])
    with pytest.raises(ExportError, match="not in the original release's recipe registry"):
        instance_definition(make_instance(sc2, renamed, pr, index=0))


def test_seed_only_instances_keep_their_id():
    inst = make_instance(*bundle("flow-easy"), generation_seed=42)
    assert original_instance_id(inst) == "flow-easy-g42"
    assert instance_definition(inst)["generation_seed"] == 42


# --------------------------------------------------------------------------- results

METRICS = {
    "delivered": 16, "completion_rate": 0.8, "unfinished_count": 4.0, "throughput": 0.04,
    "makespan": 391.0, "restricted_mean_flow_time": 72.5, "coalition_success_rate": 0.9,
    "coalition_formation_latency": 1.25, "geometry_rejection_count": 0, "geometry_conflict_count": 12.0,
    "geometry_delay_ticks": 880.0, "blocked_activity_count": 12, "geometry_block_count": 10,
    "resource_block_count": 2, "robot_block_count": 0,
}


def _schema():
    return json.loads((schemas_dir() / "original-result-v1.schema.json").read_text(encoding="utf-8"))


def test_result_schema_is_the_original_public_schema():
    schema = _schema()
    assert schema["$id"] == "urn:assemblygrid:schema:result:v1"
    jsonschema.Draft202012Validator.check_schema(schema)


def test_result_record_validates_and_uses_true_integers():
    inst = _inst("coalition-medium", 1000)
    rec = result_record(inst, "greedy", METRICS)
    jsonschema.Draft202012Validator(_schema()).validate(rec)
    assert rec["instance"] == {"id": "ag32-coalition-medium-s1000", "sha256": PUBLISHED[-1][3],
                               "family": "coalition", "difficulty": "medium", "episode_mode": "horizon"}
    assert rec["seeds"] == {"generation": 11000, "execution": 21000, "algorithm": None}
    assert rec["method"] == {"name": "greedy", "execution_information": "local",
                             "training_information": "not_applicable"}
    assert rec["fidelity"] == "abstract-v1" and rec["status"] == "complete"
    for key in ("unfinished_count", "geometry_conflict_count", "delivered", "robot_block_count"):
        assert type(rec["metrics"][key]) is int
    assert rec["metrics"]["unfinished_count"] == 4


def test_result_record_statuses_and_nulls():
    inst = _inst("flow-easy", 0)
    metrics = dict(METRICS, delivered=0, throughput=None, coalition_success_rate=None,
                   coalition_formation_latency=None)
    rec = result_record(inst, "centralized", metrics)
    jsonschema.Draft202012Validator(_schema()).validate(rec)
    assert rec["status"] == "zero_delivery"
    assert rec["method"]["execution_information"] == "global"


def test_result_record_rejects_bad_metrics():
    inst = _inst("flow-easy", 0)
    missing = {k: v for k, v in METRICS.items() if k != "makespan"}
    with pytest.raises(ExportError, match="makespan"):
        result_record(inst, "greedy", missing)
    with pytest.raises(ExportError, match="whole count"):
        result_record(inst, "greedy", dict(METRICS, unfinished_count=2.5))
    with pytest.raises(ExportError, match="must not be null"):
        result_record(inst, "greedy", dict(METRICS, delivered=None))


def test_result_record_for_matched_levels_needs_a_difficulty():
    inst = _inst("geometry-matched-low", 3)
    with pytest.raises(ExportError, match="difficulty `low`"):
        result_record(inst, "greedy", METRICS)
    rec = result_record(inst, "greedy", METRICS, difficulty="easy")
    jsonschema.Draft202012Validator(_schema()).validate(rec)
    assert rec["instance"]["id"] == "ag32-geometry-matched-low-s03"
