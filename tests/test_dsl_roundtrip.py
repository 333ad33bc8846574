"""DSL -> IR -> DSL -> IR is a fixpoint (F-DSL), on the catalogue and on generated IR."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from agspec.dsl.build import compile_text
from agspec.dsl.fmt import format_ir, format_source, header_of, number
from agspec.ir.schemas import validate_schema
from agspec.resources import catalogue_dir
from conftest_ir import official_ir
from strategies import profiles, recipes, scenarios

CATALOGUE = sorted(catalogue_dir().glob("*/*.ag"))
FAST = settings(max_examples=150, deadline=None, suppress_health_check=list(HealthCheck))


def _ir(text: str) -> dict:
    _source, built = compile_text(text)
    assert built.diagnostics == (), [d.render(text) for d in built.diagnostics]
    return built.ir


def _assert_fixpoint(ir: dict) -> None:
    text = format_ir(ir)
    again = _ir(text)
    assert again == ir
    assert format_ir(again) == text


def test_catalogue_is_complete():
    names = {p.relative_to(catalogue_dir()).as_posix() for p in CATALOGUE}
    recipes_ = {"solo_inspection", "flow_serial_3", "flow_serial_5", "pair_assembly", "supported_insert",
                "standard_abc", "parallel_branch_light"}
    scenarios_ = {f"{f}-{lvl}" for f in ("flow", "coalition", "concurrency") for lvl in ("easy", "medium", "hard")}
    scenarios_ |= {f"geometry-matched-{lvl}" for lvl in ("low", "medium", "high")}
    assert names == ({f"recipes/{r}.ag" for r in recipes_} | {"profiles/abstract-v1.ag"}
                     | {f"scenarios/{s}.ag" for s in scenarios_})


@pytest.mark.parametrize("path", CATALOGUE, ids=lambda p: p.stem)
def test_catalogue_file_round_trips(path: Path):  # F-DSL fixpoint
    text = path.read_text(encoding="utf-8")
    ir = _ir(text)
    assert validate_schema(ir) == []
    _assert_fixpoint(ir)


@pytest.mark.parametrize("path", CATALOGUE, ids=lambda p: p.stem)
def test_catalogue_file_is_canonical(path: Path):  # `agspec fmt --check` passes on the catalogue
    text = path.read_text(encoding="utf-8")
    result = format_source(text, str(path))
    assert result.text == text
    assert result.dropped_comments == 0
    assert header_of(text).startswith("# ")  # each file cites its paper table


@pytest.mark.parametrize("path", CATALOGUE, ids=lambda p: p.stem)
def test_catalogue_matches_reference_ir(path: Path):  # paper tables, REFERENCE_NOTES 3.1 / 8.1
    ir = _ir(path.read_text(encoding="utf-8"))
    assert ir == official_ir()[ir["kind"] + "s"][ir["id"]]


def test_supported_insert_roles_and_weights():  # paper "Official recipe parameters" + weights
    ir = _ir((catalogue_dir() / "recipes" / "supported_insert.ag").read_text(encoding="utf-8"))
    align, insert = ir["operations"]
    assert align["roles"] == [{"name": "holder_A", "binds": "A"}, {"name": "holder_B", "binds": "B"}]
    assert insert["arity"] == [2, 4] and insert["duration"] == 4 and insert["weight"] == 1.3
    assert [r["name"] for r in insert["roles"]] == ["holder", "inserter", "stabilizer", "inspector"]
    assert insert["roles"][0]["binds"] == "AB" and "binds" not in insert["roles"][1]


def test_canonical_order_and_defaults():  # F-IR canonical order; F-DSL-DEFAULTS
    ir = _ir("""
        recipe r {
            raw B, A
            operation z { type t  inputs B, A -> Z  team 2  roles p(B), q(A)  duration 1 }
            operation a { type t  after z  inputs Z -> FINAL  team 1  duration 2  uses m, k }
            resource m capacity 2
            resource k
            xor g = z | a
        }""")
    assert [op["id"] for op in ir["operations"]] == ["a", "z"]
    assert ir["raw"] == ["B", "A"]  # order kept: it is meaningful
    assert ir["operations"][1]["inputs"] == ["A", "B"]
    assert ir["operations"][1]["roles"] == [{"name": "p", "binds": "B"}, {"name": "q", "binds": "A"}]
    assert ir["operations"][0]["resources"] == ["k", "m"]
    assert ir["resources"] == {"k": 1, "m": 2}
    assert ir["xor"] == [{"id": "g", "alternatives": ["a", "z"]}]
    assert ir["value"] == 1.0 and ir["operations"][0]["weight"] == 1.0 and ir["operations"][1]["after"] == []
    assert ir["operations"][0]["roles"] == []


def test_profile_and_scenario_defaults_are_the_v1_constants():  # paper "Constants shared ..."
    profile = _ir("profile p { rho_conf 0.4  durations pick 3 }")
    assert profile["rho_conf"] == 0.4 and profile["spacing"] == 1.0 and profile["payload"] == 10.0
    assert profile["durations"] == {"pick": 3, "handoff": 1, "deliver": 2} and profile["variants"] == {}
    scenario = _ir("scenario s { family f level l recipes r release every 5 wip 4 evaluation batch 30 }")
    assert scenario["grid"] == {"rows": 5, "cols": 6, "topology": "moore", "radius": 1}
    assert scenario["evaluation"] == {"mode": "batch", "batch_size": 30, "timeout": 400}
    assert scenario["shelves"] == {"capacity": 6, "replenish_interval": 5, "extra_access_probability": 0.3}
    assert scenario["profile"] == {"id": "abstract-v1", "variant": None}
    assert "suite" not in scenario and validate_schema(scenario) == []


def test_exact_decimals_and_integral_decimals():
    ir = _ir("profile p { rho_conf 0.30  spacing 1  durations pick 2.0 }")
    assert ir["rho_conf"] == 0.3 and isinstance(ir["spacing"], float)
    assert ir["durations"]["pick"] == 2 and isinstance(ir["durations"]["pick"], int)


@pytest.mark.parametrize("value, text", [(0.3, "0.3"), (1.0, "1.0"), (10.0, "10.0"), (1e-07, "0.0000001"),
                                         (1e20, "100000000000000000000.0"), (3, "3"), (-2.5, "-2.5")])
def test_number_format_reads_back(value, text):
    assert number(value) == text
    assert float(text) == value


@FAST
@given(recipes())
def test_generated_recipes_round_trip(ir):  # F-DSL on random valid recipes
    assert validate_schema(ir) == []
    _assert_fixpoint(ir)


@FAST
@given(st.one_of(profiles(), scenarios()))
def test_generated_profiles_and_scenarios_round_trip(ir):
    assert validate_schema(ir) == []
    _assert_fixpoint(ir)


@FAST
@given(recipes())
def test_generated_recipes_are_semantically_valid(ir):  # the strategy's promise to other tests
    validate = pytest.importorskip("agspec.ir.validate").validate_document
    assert [i for i in validate(ir, None) if i.severity == "error"] == []


def test_fmt_keeps_header_and_uses_and_counts_lost_comments():
    text = '# header\n# two\n\nuse "a.ag"\nrecipe r { raw A  # inline\n operation a { type t inputs A -> FINAL team 1 duration 1 } }\n'
    result = format_source(text)
    assert result.text.startswith('# header\n# two\n\nuse "a.ag"\n\nrecipe r {\n')
    assert result.dropped_comments == 1
    assert format_source(result.text).text == result.text
