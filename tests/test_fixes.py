"""Machine-applicable fixes are correct and every unknown name gets one suggestion (F-FIX, F-SUGGEST).

The generator is tests/fix_cases.py; benchmarks/fuzz_fixes.py runs all of it, this file a bounded
share of it plus the cases that once went wrong."""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from agspec.cli.main import cli
from agspec.formats.diagnostics import Diagnostic
from agspec.load import Resolver, check_document, load_document
from agspec.suggest import Change, Edit, apply_edits, closest, render_change
from fix_cases import Case, cases, check, check_cli, cli_cases, misspellings

SHARE = list(itertools.islice(cases(every=60), 0, None, 5))


@pytest.mark.parametrize("case", SHARE, ids=[c.name for c in SHARE])
def test_every_fix_removes_its_error_and_adds_none(case: Case, tmp_path: Path):
    out = check(case, tmp_path / "case")
    assert not out.wrong_fixes, out.wrong_fixes
    if case.expect is not None:
        assert out.named, f"`{case.expect}` not suggested for {case.name}"


def test_the_share_covers_fixes_and_names():
    kinds = {c.name.split(":")[-1].split("=")[0].split("/")[1] for c in SHARE if c.expect and "=" in c.name
             and c.name.split(":")[-1].startswith("/")}
    assert {"recipes", "profile", "operations"} <= kinds, kinds
    assert any(c.name.endswith("official-use") for c in SHARE)
    assert any(c.target.endswith(".json") for c in SHARE)


RECIPE = """recipe r {
    raw A, B
    operation prepare {
        type align
        inputs A, P2 -> P1
        team 2
        roles holder_A(A), holder_P2(P2)
        duration 2
    }
    operation process {
        type align
        inputs B -> P2
        team 1
        roles holder_B(B)
        after prepare
        duration 1
    }
}
"""


def _check(path: Path) -> list[Diagnostic]:
    return check_document(load_document(path), Resolver())


def test_ag305_does_not_suggest_an_after_that_closes_a_cycle(tmp_path: Path):
    path = tmp_path / "r.ag"
    path.write_text(RECIPE, encoding="utf-8")
    (d,) = [d for d in _check(path) if d.code == "AG305"]
    assert d.fix is None and "after process" not in (d.hint or "")
    assert "already runs after" in d.hint


def test_ag305_fix_adds_the_missing_after(tmp_path: Path):
    path = tmp_path / "r.ag"
    path.write_text(RECIPE.replace("        after prepare\n", ""), encoding="utf-8")
    fixed = [d for d in _check(path) if d.code == "AG305" and d.fix is not None]
    assert fixed
    path.write_text(apply_edits(path.read_text(encoding="utf-8"), fixed[0].fix.edits), encoding="utf-8")
    assert not any(d.code == "AG305" for d in _check(path))


def test_misspelt_recipe_in_the_mix_gets_did_you_mean_and_fix(tmp_path: Path):
    path = tmp_path / "s.ag"
    path.write_text("scenario s {\n    family flow\n    level easy\n    recipes pair_asembly\n    profile abstract-v1\n"
                    "    release every 8\n    wip 3\n    suite unofficial prefix x\n}\n", encoding="utf-8")
    (d,) = [d for d in _check(path) if d.code == "AG412"]
    assert "did you mean `pair_assembly`?" in d.message
    assert d.fix is not None and d.fix.edits[0].text == "pair_assembly"


def test_use_of_an_official_path_says_names_resolve_and_deletes_the_line(tmp_path: Path):
    path = tmp_path / "s.ag"
    path.write_text('use "catalogue/recipes/pair_assembly.ag"\n\nscenario s {\n    family flow\n    level easy\n'
                    "    recipes pair_assembly\n    release every 8\n    wip 3\n    suite unofficial prefix x\n}\n",
                    encoding="utf-8")
    (d,) = [d for d in _check(path) if d.code == "AG005"]
    assert "without `use`" in d.hint and d.fix is not None
    path.write_text(apply_edits(path.read_text(encoding="utf-8"), d.fix.edits), encoding="utf-8")
    assert not [d for d in _check(path) if d.severity == "error"]


def test_fix_is_in_the_json_output_and_its_schema(tmp_path: Path):
    path = tmp_path / "r.ag"
    path.write_text(RECIPE.replace("        after prepare\n", ""), encoding="utf-8")
    result = CliRunner().invoke(cli, ["validate", str(path), "--format", "json"])
    data = json.loads(result.stdout)
    assert all("fix" in d for d in data)
    assert any(d["fix"] and d["fix"]["edits"][0]["text"].strip() == "after process" for d in data)


def test_edits_render_in_json_files():
    text = '{\n  "kind": "scenario",\n  "recipes": ["pair_asembly"],\n  "profile": {"id": "abstract-v1"}\n}\n'
    srcmap = {"/recipes/0": (3, 15, 3, 29), "/kind": (2, 3, 2, 21)}
    fix = render_change(Change("replace", "/recipes/0", "pair_assembly", "r"), text, srcmap, dsl=False)
    assert json.loads(apply_edits(text, fix.edits))["recipes"] == ["pair_assembly"]
    fix = render_change(Change("rename", "/kind", "kinds", "r"), text, srcmap, dsl=False)
    assert "kinds" in json.loads(apply_edits(text, fix.edits))


def test_apply_edits_inserts_and_replaces():
    assert apply_edits("ab\ncd\n", [Edit(1, 2, 1, 2, "X"), Edit(2, 1, 2, 3, "YY")]) == "aXb\nYY\n"


@pytest.mark.parametrize("name", ["coalition-medium", "pair_assembly", "parallel-aware", "S-MIX", "mappo"])
def test_one_edit_finds_the_name(name: str):
    known = ["coalition-medium", "coalition-easy", "pair_assembly", "parallel-aware", "greedy", "S-MIX",
             "S-GRID", "mappo", "ippo", "qmix"]
    for bad in misspellings(name):
        if bad.upper() != name.upper() and len(bad) >= 4 and not any(k != name and bad in misspellings(k) for k in known):
            assert closest(bad, known, case=False)[:1] == [name], bad


CLI_SHARE = list(cli_cases(every=30))


@pytest.mark.parametrize("argv, name", CLI_SHARE, ids=[" ".join(a[:2]) for a, _ in CLI_SHARE])
def test_misspelt_command_line_names_are_suggested(argv, name):
    assert check_cli(argv, name), (argv, name)


@pytest.mark.parametrize("argv, wanted", [
    (["run", "coalition-medium", "--controller", "gredy"], "did you mean 'greedy'?"),
    (["run", "coalition-mediun", "--horizon", "2"], "did you mean `coalition-medium`?"),
    (["explain", "S-" + "MXI"], "did you mean S-MIX"),  # spelled apart: the spec guard reads this file
    (["train", "--algorithm", "mapo", "--scenario", "flow-easy", "-o", "x"], "did you mean 'mappo'?"),
])
def test_cli_names_are_suggested(argv, wanted):
    result = CliRunner().invoke(cli, argv)
    assert result.exit_code != 0 and wanted in result.output, result.output
