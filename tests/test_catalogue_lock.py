"""F-LOCK: catalogue constants, index lists, and lock drift detection."""

from __future__ import annotations

import copy
import json

import jsonschema
import pytest

from agspec.catalogue import (
    GEOMETRY_MATCHED,
    OFFICIAL_SCENARIOS,
    SPLITS,
    CatalogueError,
    lock_entries,
    lock_text,
    parse_indices,
    read_lock,
    verify_lock,
    write_lock,
)
from agspec.resources import schemas_dir
from conftest_ir import bundle


@pytest.fixture(scope="module")
def locked():
    return lock_entries(bundle)


def _load_with(edit):
    """A load_fn whose bundles pass through ``edit(name, scenario, recipes, profile)``."""
    def load(name):
        scenario, recipes, profile = copy.deepcopy(bundle(name))
        edit(name, scenario, recipes, profile)
        return scenario, recipes, profile
    return load


def test_constants():
    assert OFFICIAL_SCENARIOS == (
        "flow-easy", "flow-medium", "flow-hard", "coalition-easy", "coalition-medium", "coalition-hard",
        "concurrency-easy", "concurrency-medium", "concurrency-hard")
    assert GEOMETRY_MATCHED == ("geometry-matched-low", "geometry-matched-medium", "geometry-matched-high")
    assert SPLITS["catalogue"] == range(0, 5) and SPLITS["training"] == range(0, 5)
    assert SPLITS["validation"] == range(200, 205)
    assert SPLITS["final-test"] == range(1000, 1050)
    assert SPLITS["geometry-matched"] == range(0, 50)


def test_parse_indices():
    got = parse_indices("1000-1049,3")
    assert got[:2] == [1000, 1001] and got[-2:] == [1049, 3] and len(got) == 51
    assert parse_indices("4, 2,4,0-1") == [4, 2, 0, 1]
    assert parse_indices("validation") == [200, 201, 202, 203, 204]
    for bad in ("", "a", "5-3", "1,,2", "-1", "1-x"):
        with pytest.raises(CatalogueError):
            parse_indices(bad)


def test_lock_shape_and_schema(locked):
    schema = json.loads((schemas_dir() / "lock.schema.json").read_text(encoding="utf-8"))
    jsonschema.Draft202012Validator.check_schema(schema)
    jsonschema.Draft202012Validator(schema).validate(locked)
    assert list(locked["scenarios"]) == list(OFFICIAL_SCENARIOS)
    assert locked["indices"] == [0, 1, 2, 3, 4]
    flow_easy = locked["scenarios"]["flow-easy"]["instances"]
    assert [e["id"] for e in flow_easy] == [f"ag32-flow-easy-s0{i}" for i in range(5)]
    # the original's published digests are part of the lock
    assert flow_easy[0]["instance_sha256"] == "b87822087ece44957a53d8a1e973373f9083eaa835aeade0b1daae99d482c10d"
    assert locked["scenarios"]["coalition-hard"]["instances"][0]["instance_sha256"] == (
        "52fa73667ae777aa55dd371a9a5b8208d0a8391aad3a38b4dcd9e8938e23df34")


def test_no_drift_against_itself(locked):
    assert verify_lock(lock_entries(bundle), locked) == []


def test_scenario_value_change_is_drift(locked):
    def edit(name, scenario, recipes, profile):
        if name == "coalition-medium":
            scenario["release"]["wip_cap"] = 5

    drift = verify_lock(lock_entries(_load_with(edit)), locked)
    assert any(m.startswith("scenario `coalition-medium` changed: fingerprint") for m in drift)
    assert any("ag32-coalition-medium-s03" in m and "original instance_sha256 changed" in m for m in drift)
    assert all("coalition-medium" in m for m in drift)


def test_non_identity_change_is_still_drift(locked):
    """Due slack is outside the original identity but changes the realization (due offsets)."""
    def edit(name, scenario, recipes, profile):
        if name == "flow-easy":
            scenario["products"]["due_slack"] = 2.5

    drift = verify_lock(lock_entries(_load_with(edit)), locked)
    assert any("ag32-flow-easy-s00" in m and "realization changed" in m for m in drift)
    assert not any("instance_sha256" in m for m in drift)


def test_recipe_and_profile_changes_are_drift(locked):
    def edit(name, scenario, recipes, profile):
        if "pair_assembly" in recipes:
            recipes["pair_assembly"]["operations"][0]["weight"] = 2.0
        profile["variants"]["conflict-high"]["rho_conf"] = 0.5

    drift = verify_lock(lock_entries(_load_with(edit)), locked)
    assert any("recipe `pair_assembly` changed" in m for m in drift)
    assert sum("profile changed" in m for m in drift) == len(OFFICIAL_SCENARIOS)


def test_doc_only_change_is_not_drift(locked):
    def edit(name, scenario, recipes, profile):
        scenario["doc"] = "edited prose"
        for recipe in recipes.values():
            recipe["doc"] = "more prose"

    assert verify_lock(lock_entries(_load_with(edit)), locked) == []


def test_missing_and_extra_scenarios(locked):
    partial = lock_entries(bundle, names=OFFICIAL_SCENARIOS[:8])
    drift = verify_lock(partial, locked)
    assert drift == ["scenario `concurrency-hard` is locked but no longer in the catalogue"]
    assert verify_lock(locked, partial) == ["scenario `concurrency-hard` is not in the lock"]


def test_lock_file_round_trip(tmp_path, locked):
    path = write_lock(locked, tmp_path / "lock.json")
    assert path.read_text(encoding="utf-8") == lock_text(locked)
    assert lock_text(locked).endswith("}\n")
    assert read_lock(path) == locked
    with pytest.raises(CatalogueError, match="no lock file"):
        read_lock(tmp_path / "absent.json")
    (tmp_path / "other.json").write_text('{"schema": "something-else"}', encoding="utf-8")
    with pytest.raises(CatalogueError, match="not an agspec catalogue lock"):
        read_lock(tmp_path / "other.json")


def test_shipped_lock_agrees_with_the_test_catalogue(locked):
    """catalogue/lock.json (written from the DSL catalogue) pins the same content as conftest_ir."""
    from agspec.catalogue import lock_path

    if not lock_path().is_file():
        pytest.skip("catalogue/lock.json not written yet (`agspec catalogue verify --update`)")
    assert verify_lock(locked, read_lock()) == []


# --------------------------------------------------------------------------- loader adapter
# These use the DSL loader (agspec.load) and the shipped catalogue; skipped if it is absent.


@pytest.mark.parametrize("name", ["coalition-medium", "flow-hard", "geometry-matched-high"])
def test_load_scenario_bundle_agrees_with_the_test_catalogue(name):
    pytest.importorskip("agspec.load")
    from agspec.catalogue import load_scenario_bundle

    assert load_scenario_bundle(name) == bundle(name)


def test_load_scenario_bundle_errors(tmp_path):
    pytest.importorskip("agspec.load")
    from agspec.catalogue import InvalidDocumentError, load_scenario_bundle

    with pytest.raises(CatalogueError, match="unknown scenario `nope`"):
        load_scenario_bundle("nope")
    with pytest.raises(CatalogueError, match=r"error\[AG001\]: file not found"):
        load_scenario_bundle(str(tmp_path / "missing.ag"))
    broken = tmp_path / "broken.ag"
    broken.write_text("scenario broken {\n    family flow\n", encoding="utf-8")
    with pytest.raises(InvalidDocumentError, match="broken.ag"):
        load_scenario_bundle(str(broken))
