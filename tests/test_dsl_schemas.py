"""JSON Schemas, JSON IR loading with positions, and name resolution (F-IR, F-DIAGNOSTICS)."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import pytest
from jsonschema import Draft202012Validator

from agspec.ir.instance import make_instance
from agspec.ir.schemas import SCHEMA_IDS, load_schema, validate_schema
from agspec.load import Resolver, check_document, json_positions, load_document, resolve_scenario_name
from agspec.resources import catalogue_dir, schemas_dir
from conftest_ir import official_ir

MINE = ["recipe", "profile", "scenario", "instance", "diagnostics"]


@pytest.mark.parametrize("name", MINE)
def test_schemas_are_valid_draft_2020_12_and_closed(name):
    schema = load_schema(name)
    Draft202012Validator.check_schema(schema)
    assert schema["$schema"] == "https://json-schema.org/draft/2020-12/schema"
    assert schema["$id"] == f"urn:agspec:schema:{name}:1"

    def closed(node):  # every object schema with properties forbids other properties
        if isinstance(node, dict):
            if "properties" in node and node.get("type") == "object":
                assert node.get("additionalProperties") is False, node.get("title", node)
            for value in node.values():
                closed(value)
        elif isinstance(node, list):
            for value in node:
                closed(value)

    closed(schema)


def test_official_ir_and_an_instance_are_schema_valid():
    ir = official_ir()
    for kind in ("recipes", "profiles", "scenarios"):
        for doc in ir[kind].values():
            assert validate_schema(doc) == []
    scen = ir["scenarios"]["geometry-matched-high"]
    inst = make_instance(scen, ir["recipes"], ir["profiles"]["abstract-v1"], index=3)
    assert validate_schema(inst) == []
    inst["profile"]["variants"] = {}
    assert [(i.code, i.pointer) for i in validate_schema(inst)] == [("AG204", "/profile/variants")]


@pytest.mark.parametrize("mutate, expected", [
    (lambda r: r["operations"][0].pop("duration"), [("AG201", "/operations/0")]),
    (lambda r: r["operations"][0].update(duration=2.5), [("AG202", "/operations/0/duration")]),
    (lambda r: r["operations"][0].update(duration=0), [("AG203", "/operations/0/duration")]),
    (lambda r: r["operations"][0].update(arity=[1, 0]), [("AG203", "/operations/0/arity/1")]),
    (lambda r: r["operations"][0].update(durration=2), [("AG204", "/operations/0/durration")]),
    (lambda r: r.update(kind="recipe", ir_version="agspec-ir/2"), [("AG205", "/ir_version")]),
    (lambda r: r.update(kind="cake"), [("AG004", "/kind")]),
])
def test_schema_issue_codes_and_pointers(mutate, expected):
    recipe = copy.deepcopy(official_ir()["recipes"]["pair_assembly"])
    mutate(recipe)
    assert [(i.code, i.pointer) for i in validate_schema(recipe)] == expected


def test_unknown_field_suggests_a_close_name():
    recipe = copy.deepcopy(official_ir()["recipes"]["pair_assembly"])
    recipe["operations"][0]["durration"] = 2
    (issue,) = validate_schema(recipe)
    assert issue.hint == "did you mean `duration`?"


def test_evaluation_mode_fields():
    scen = copy.deepcopy(official_ir()["scenarios"]["flow-easy"])
    scen["evaluation"] = {"mode": "batch", "batch_size": 30, "timeout": 400, "horizon": 400}
    assert [(i.code, i.pointer) for i in validate_schema(scen)] == [("AG204", "/evaluation/horizon")]


def test_schema_ids_cover_every_kind():
    assert set(SCHEMA_IDS) == {"recipe", "profile", "scenario", "instance"}
    assert {p.name for p in schemas_dir().glob("*.schema.json")} >= {f"{k}.schema.json" for k in MINE}


# --------------------------------------------------------------------------- JSON IR files


def test_json_positions():
    text = '{\n  "a": 1,\n  "ops": [\n    {"id": "x", "d": 2},\n    3\n  ]\n}'
    srcmap, dups = json_positions(text)
    assert srcmap["/a"] == (2, 3, 2, 9)
    assert srcmap["/ops"] == (3, 3, 3, 8)
    assert srcmap["/ops/0"] == srcmap["/ops/0/id"] == (4, 6, 4, 15)
    assert srcmap["/ops/0/d"] == (4, 17, 4, 23)
    assert srcmap["/ops/1"] == (5, 5, 5, 6)
    assert dups == []


def test_json_ir_issue_is_located(tmp_path: Path):
    recipe = copy.deepcopy(official_ir()["recipes"]["pair_assembly"])
    recipe["operations"][0]["duration"] = -1
    path = tmp_path / "r.json"
    path.write_text(json.dumps(recipe, indent=2), encoding="utf-8")
    doc = load_document(path)
    (diag,) = check_document(doc)
    line = doc.text.splitlines()[diag.line - 1]
    assert diag.code == "AG350" and line[diag.col - 1:].startswith('"duration": -1')  # F-CODES: the rule's code


@pytest.mark.parametrize("content, code", [
    (b'{"kind": "recipe",}', "AG003"),
    (b'{"kind": NaN}', "AG003"),
    (b"\xff\xfe", "AG007"),
    (b'[1, 2]', "AG004"),
    (b'{"kind": "cake"}', "AG004"),
    (b'{"kind": "recipe", "kind": "recipe"}', "AG206"),
])
def test_bad_json_files(tmp_path: Path, content: bytes, code: str):
    path = tmp_path / "bad.json"
    path.write_bytes(content)
    doc = load_document(path)
    assert doc.diagnostics[0].code == code and doc.diagnostics[0].line is not None


def test_io_errors(tmp_path: Path):
    assert load_document(tmp_path / "missing.ag").diagnostics[0].code == "AG001"
    assert load_document(tmp_path).diagnostics[0].code == "AG002"  # a directory (F-LIMITS)
    (tmp_path / "notes.txt").write_text("hi")
    assert load_document(tmp_path / "notes.txt").diagnostics[0].code == "AG004"


# --------------------------------------------------------------------------- resolver


def test_resolve_official_scenario_name():
    assert resolve_scenario_name("coalition-medium") == catalogue_dir() / "scenarios" / "coalition-medium.ag"
    assert resolve_scenario_name("no-such-scenario") is None


def test_resolver_prefers_use_includes_then_directory_then_catalogue(tmp_path: Path):
    (tmp_path / "lib").mkdir()
    (tmp_path / "recipes").mkdir()
    recipe = "recipe {name} {{ raw A operation a {{ type {type} inputs A -> FINAL team 1 roles w(A) duration 2 }} }}\n"
    (tmp_path / "lib" / "mine.ag").write_text(recipe.format(name="pair_assembly", type="included"))
    (tmp_path / "recipes" / "solo.ag").write_text(recipe.format(name="solo", type="tree"))
    (tmp_path / "recipes" / "pair_assembly.ag").write_text(recipe.format(name="pair_assembly", type="tree"))
    scen = tmp_path / "s.ag"
    scen.write_text('use "lib/mine.ag"\nscenario s { family f level l recipes pair_assembly, solo, standard_abc\n'
                    ' release every 5 wip 4 }\n')
    doc = load_document(scen)
    resolver = Resolver().bind(doc)
    assert resolver.recipe("pair_assembly")["operations"][0]["type"] == "included"  # use wins
    assert resolver.recipe("solo")["operations"][0]["type"] == "tree"  # sibling recipes/ directory
    assert resolver.recipe("standard_abc")["id"] == "standard_abc"  # catalogue
    assert resolver.profile("abstract-v1")["rho_conf"] == 0.25
    assert resolver.recipe("nope") is None
    assert [d.code for d in check_document(doc, Resolver(), semantic=False)] == []


def test_unresolved_use_is_ag005_and_an_unknown_mix_recipe_ag412_at_the_reference(tmp_path: Path):
    scen = tmp_path / "s.ag"
    scen.write_text('use "gone.ag"\nscenario s { family f level l\n  recipes pair_assembly, nope\n'
                    '  release every 5 wip 4 }\n')
    diags = check_document(load_document(scen), Resolver())
    assert [(d.code, d.line, d.col) for d in diags if d.code in ("AG005", "AG412")] == [
        ("AG005", 1, 5), ("AG412", 3, 26)]  # F-CODES; the unknown recipe is reported once
