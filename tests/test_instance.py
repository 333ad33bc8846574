"""I-REALIZATION: instances reproduce the original release's evaluated realizations exactly.

Expected values are quoted from a run of the original release (evaluated realization = reset #2
after construction; REFERENCE_NOTES §8.4).
"""

from __future__ import annotations

import copy
import math
import random

import pytest

from agspec.ir.instance import (
    InstanceError,
    critical_path,
    draw_shelf_access,
    make_instance,
    raw_types,
    resolve_profile,
    shelf_layout,
)
from conftest_ir import bundle, official_ir


def _product(inst, pid):
    p = inst["realization"]["products"][pid]
    return p["recipe"], p["source_rows"], p["mass"], p["slack"], p["due_offset"]


def _access(inst):
    return {a["shelf_row"]: a["robot_rows"] for a in inst["realization"]["shelf_access"]}


# (cell, index 1000) -> product id -> (recipe, source_rows, mass, slack, due_time - spawn_time)
ORIGINAL_PRODUCTS = {
    "coalition-medium": {
        0: ("supported_insert", {"A": 4, "B": 3}, 0.7863897569708054, 2.36286647517045, 26),
        1: ("supported_insert", {"A": 2, "B": 3}, 1.670628526268013, 2.285997892815676, 26),
        18: ("supported_insert", {"A": 0, "B": 3}, 0.5886858825676121, 2.3472628103851307, 26),
    },
    "coalition-hard": {
        0: ("standard_abc", {"A": 0, "B": 4, "C": 5}, 1.670628526268013, 2.285997892815676, 28),
        5: ("standard_abc", {"A": 0, "B": 1, "C": 5}, 1.2030604446131177, 2.352459293745576, 29),
    },
    "concurrency-hard": {
        0: ("parallel_branch_light", {"A": 0, "B": 5}, 1.4942997127556743, 2.5932844111124758, 29),
        23: ("parallel_branch_light", {"A": 2, "B": 3}, 0.7196325446158347, 1.7768828368773972, 20),
    },
    "flow-easy": {
        0: ("solo_inspection", {"A": 1}, 0.6979935022748766, 2.306632901309546, 14),
        23: ("solo_inspection", {"A": 2}, 0.5477069718097904, 2.5141934747844052, 16),
    },
    "flow-hard": {
        0: ("flow_serial_5", {"A": 4}, 1.8234134923393701, 2.1947631596842894, 36),
        46: ("flow_serial_5", {"A": 4}, 1.3756810544341258, 2.053150851282196, 33),
    },
}

ORIGINAL_ACCESS = {
    "coalition-medium": {0: [0], 1: [1, 2], 2: [2], 3: [3], 4: [4]},
    "concurrency-hard": {0: [0], 1: [0, 1], 2: [2], 3: [3], 4: [4], 5: [5]},
    "flow-easy": {0: [0], 1: [1, 2], 2: [2], 3: [2, 3]},
    "flow-medium": {0: [0], 1: [0, 1], 2: [1, 2], 3: [3, 4], 4: [3, 4]},
}


@pytest.mark.parametrize("cell", sorted(ORIGINAL_PRODUCTS))
def test_products_match_the_original_bit_for_bit(cell):  # P-RELEASE-DRAWS, P-DUE
    inst = make_instance(*bundle(cell), index=1000)
    for pid, expected in ORIGINAL_PRODUCTS[cell].items():
        got = _product(inst, pid)
        assert got == expected
        assert type(got[2]) is float and type(got[3]) is float


@pytest.mark.parametrize("cell", sorted(ORIGINAL_ACCESS))
def test_shelf_access_matches_the_original(cell):  # S-SHELF-ACCESS (reset #2)
    assert _access(make_instance(*bundle(cell), index=1000)) == ORIGINAL_ACCESS[cell]


def test_evaluated_realization_is_the_second_reset():  # I-CONSTRUCT-THEN-RESET
    """Reset #1 of coalition-medium s1000 has other draws; the instance records reset #2."""
    inst = make_instance(*bundle("coalition-medium"), index=1000)
    rng = random.Random(11000)
    first = {a["shelf_row"]: a["robot_rows"] for a in draw_shelf_access(rng, 5, 0.3, 1.0, 1.5)}
    assert first == {0: [0, 1], 1: [1], 2: [1, 2, 3], 3: [3], 4: [4]}  # original reset #1
    assert _access(inst) != first
    # product 0 of reset #1 in the original: source rows A 2, B 1, mass 1.8075794708094204
    assert inst["realization"]["products"][0]["mass"] != 1.8075794708094204


def test_identity_and_seeds():  # I-ID, I-SEEDS
    sc, rc, pr = bundle("coalition-medium")
    inst = make_instance(sc, rc, pr, index=1000)
    assert inst["id"] == "ag32-coalition-medium-s1000"
    assert inst["seeds"] == {"index": 1000, "generation": 11000, "execution": 21000}
    assert make_instance(sc, rc, pr, index=3)["id"] == "ag32-coalition-medium-s03"
    assert make_instance(sc, rc, pr, index=0)["seeds"] == {"index": 0, "generation": 10000, "execution": 20000}
    by_seed = make_instance(sc, rc, pr, generation_seed=777)
    assert by_seed["id"] == "coalition-medium-g777"
    assert by_seed["seeds"] == {"index": None, "generation": 777, "execution": 777}
    assert make_instance(sc, rc, pr, generation_seed=777, execution_seed=5)["seeds"]["execution"] == 5
    # an explicit seed equal to the derived one keeps the suite identity
    assert make_instance(sc, rc, pr, index=2, generation_seed=10002)["id"] == "ag32-coalition-medium-s02"
    assert make_instance(sc, rc, pr, index=2, generation_seed=5)["id"] == "coalition-medium-g5"
    # the realization depends on the generation seed only
    a, b = make_instance(sc, rc, pr, index=4), make_instance(sc, rc, pr, generation_seed=10004, execution_seed=1)
    assert a["realization"] == b["realization"]


def test_non_official_ids():
    sc, rc, pr = bundle("geometry-matched-high")
    inst = make_instance(sc, rc, pr, index=7)
    assert inst["id"] == "geometry-matched-high-s07"
    assert inst["profile"]["rho_conf"] == 0.4 and inst["profile"]["variant"] == "conflict-high"


def test_matched_variants_share_the_base_realization():  # the matched geometry control
    real = [make_instance(*bundle(f"geometry-matched-{lvl}"), index=9)["realization"]
            for lvl in ("low", "medium", "high")]
    assert real[0] == real[1] == real[2]
    assert real[1] == make_instance(*bundle("coalition-medium"), index=9)["realization"]


def test_instance_shape():
    sc, rc, pr = bundle("coalition-hard")
    inst = make_instance(sc, rc, pr, index=0)
    assert inst["ir_version"] == "agspec-ir/1" and inst["kind"] == "instance"
    assert inst["scenario"] == sc and list(inst["recipes"]) == ["standard_abc"]
    assert "variants" not in inst["profile"] and inst["profile"]["variant"] is None
    real = inst["realization"]
    assert real["method"] == "python-mt19937/construct-then-reset"
    assert real["raw_types"] == ["A", "B", "C"]
    assert [s["stock"] for s in real["shelves"]] == [{"A": 6}, {"B": 6}, {"C": 6}] * 2
    assert [p["id"] for p in real["products"]] == list(range(51))  # 1 + 400 // 8


def test_product_counts():
    sc, rc, pr = bundle("flow-hard")
    assert len(make_instance(sc, rc, pr, index=0)["realization"]["products"]) == 201  # 1 + 400 // 2
    batch = copy.deepcopy(sc)
    batch["evaluation"] = {"mode": "batch", "batch_size": 30, "timeout": 400}
    inst = make_instance(batch, rc, pr, index=0)
    assert len(inst["realization"]["products"]) == 30
    # the first products are the same draws as in continuing mode
    assert inst["realization"]["products"] == make_instance(sc, rc, pr, index=0)["realization"]["products"][:30]


def test_inputs_are_not_mutated_and_output_is_deterministic():
    sc, rc, pr = bundle("concurrency-medium")
    before = copy.deepcopy((sc, rc, pr))
    a = make_instance(sc, rc, pr, index=201)
    assert (sc, rc, pr) == before
    assert a == make_instance(sc, rc, pr, index=201)


@pytest.mark.parametrize("recipe,cp", [
    ("solo_inspection", 2), ("flow_serial_3", 7), ("flow_serial_5", 12), ("pair_assembly", 4),
    ("supported_insert", 7), ("standard_abc", 8), ("parallel_branch_light", 7),
])
def test_nominal_critical_paths(recipe, cp):
    assert critical_path(official_ir()["recipes"][recipe]) == cp


def test_critical_path_takes_the_longest_xor_route():
    recipe = {
        "id": "routes", "raw": ["A"],
        "operations": [
            {"id": "prep", "after": [], "duration": 2},
            {"id": "glue", "after": ["prep"], "duration": 3},
            {"id": "weld", "after": ["prep"], "duration": 7},
            {"id": "check", "after": ["route"], "duration": 1},
        ],
        "xor": [{"id": "route", "alternatives": ["glue", "weld"]}],
    }
    assert critical_path(recipe) == 2 + 7 + 1
    cyclic = {"id": "loop", "operations": [{"id": "a", "after": ["b"], "duration": 1},
                                           {"id": "b", "after": ["a"], "duration": 1}]}
    with pytest.raises(InstanceError, match="cycle"):
        critical_path(cyclic)


def test_shelf_layout_rule():  # S-SHELF-LAYOUT
    assert raw_types(["supported_insert", "standard_abc"], official_ir()["recipes"]) == ["A", "B", "C"]
    assert [s["stock"] for s in shelf_layout(5, ["A", "B"], 6)] == [{"A": 6}, {"B": 6}, {"A": 6}, {"B": 6}, {"A": 6}]
    # fewer rows than raw types: raw type k is also stocked on row k mod M
    assert [s["stock"] for s in shelf_layout(2, ["A", "B", "C"], 4)] == [{"A": 4, "C": 4}, {"B": 4}]


def test_shelf_access_draws_only_for_reaching_rows():  # S-SHELF-ACCESS
    class Counting(random.Random):
        calls = 0

        def random(self):
            Counting.calls += 1
            return super().random()

    draw_shelf_access(Counting(1), 6, 0.3, 1.0, 1.5)
    assert Counting.calls == 2 * (6 - 1)
    Counting.calls = 0
    access = draw_shelf_access(Counting(1), 6, 1.0, 1.0, 2.2)  # longer reach: |i - r| = 2 also reaches
    assert Counting.calls == 2 * 5 + 2 * 4
    assert access[0]["robot_rows"] == [0, 1, 2]


def test_due_offset_uses_the_flow_time_lower_bound():  # P-DUE
    inst = make_instance(*bundle("flow-medium"), index=0)
    lb = max(2 + 7 + 2, 6 - 1)
    for p in inst["realization"]["products"]:
        assert p["due_offset"] == math.ceil(p["slack"] * lb)
        assert 1.7 <= p["slack"] <= 2.7 and 0.5 <= p["mass"] <= 2.0


def test_resolve_profile():  # PR-VARIANT
    profile = official_ir()["profiles"]["abstract-v1"]
    high = resolve_profile(profile, "conflict-high")
    assert high["rho_conf"] == 0.4 and high["variant"] == "conflict-high" and "variants" not in high
    assert resolve_profile(profile, None)["rho_conf"] == 0.25
    assert resolve_profile(profile, "spacing-0.75")["spacing"] == 0.75
    assert "variants" in profile  # input untouched
    with pytest.raises(InstanceError, match="no variant `nope`"):
        resolve_profile(profile, "nope")


def test_user_errors():
    sc, rc, pr = bundle("coalition-easy")
    with pytest.raises(InstanceError, match="index must be >= 0"):
        make_instance(sc, rc, pr, index=-1)
    with pytest.raises(InstanceError, match="integer"):
        make_instance(sc, rc, pr, index=True)
    with pytest.raises(InstanceError, match="unknown recipe"):
        make_instance(sc, {}, pr, index=0)
    with pytest.raises(InstanceError, match="index or a generation seed"):
        make_instance(sc, rc, pr)
    bare = {k: v for k, v in sc.items() if k != "suite"}
    # RES-SEED-BASES-DEFAULT: without a suite the official seed bases apply
    plain = make_instance(bare, rc, pr, index=2)
    assert plain["id"] == "coalition-easy-s02" and (plain["seeds"]["generation"], plain["seeds"]["execution"]) == (
        10002, 20002)
    assert make_instance(bare, rc, pr, generation_seed=3)["id"] == "coalition-easy-g3"
    other = dict(pr, id="ur10-case-v1")
    with pytest.raises(InstanceError, match="profile"):
        make_instance(sc, rc, other, index=0)
