"""F-CODES guard: the spec's code table (spec/09-formats.md) and the codes agspec can emit are the
same set, in both directions; a planted drift is caught. Plus the codes the table assigns to bad
values and names, as `agspec validate` reports them (AG350, AG361, AG412, AG414), and messages that
say what was expected once ("found an array", not "found an array an array")."""

from __future__ import annotations

import re
from pathlib import Path

from click.testing import CliRunner

from agspec.cli.main import cli

ROOT = Path(__file__).resolve().parent.parent
CODE = re.compile(r"""["'](AG[0-5][0-9]{2})["']""")
ROW = re.compile(r"^\| (AG[0-9]{3}) \|", re.M)


def table_codes(spec_text: str) -> set[str]:
    start, end = spec_text.index("<!-- CODES-TABLE-START -->"), spec_text.index("<!-- CODES-TABLE-END -->")
    return set(ROW.findall(spec_text[start:end]))


def source_codes(texts) -> set[str]:
    return {code for text in texts for code in CODE.findall(text)}


def drift(spec_text: str, texts) -> tuple[set[str], set[str]]:
    """(codes emitted but not in the table, codes in the table that nothing emits)."""
    table, emitted = table_codes(spec_text), source_codes(texts)
    return emitted - table, table - emitted


def _sources() -> list[str]:
    return [p.read_text(encoding="utf-8") for p in sorted((ROOT / "agspec").rglob("*.py"))]


def test_the_code_table_equals_the_codes_agspec_emits():
    spec = (ROOT / "spec" / "09-formats.md").read_text(encoding="utf-8")
    undocumented, unused = drift(spec, _sources())
    assert not undocumented, f"codes emitted but missing from F-CODES: {sorted(undocumented)}"
    assert not unused, f"codes in F-CODES that nothing emits: {sorted(unused)}"


def test_a_planted_drift_is_caught_in_both_directions():
    spec = (ROOT / "spec" / "09-formats.md").read_text(encoding="utf-8")
    planted = spec.replace("| AG361 |", "| AG369 |")  # the table renames a code the validator emits
    undocumented, unused = drift(planted, _sources())
    assert undocumented == {"AG361"} and unused == {"AG369"}


def _validate(tmp_path, text: str) -> str:
    path = tmp_path / "doc.ag"
    path.write_text(text, encoding="utf-8")
    res = CliRunner().invoke(cli, ["validate", str(path)])
    assert res.exit_code == 1
    return res.stderr


def test_bad_values_and_names_get_the_codes_of_their_rules(tmp_path):
    recipe = ("recipe r {\n  raw A\n  resource fixture capacity 0\n"
              "  operation a { type t inputs A -> FINAL team 1 roles w(A) duration 2.5 }\n}\n")
    out = _validate(tmp_path, recipe)
    assert "doc.ag:3:3: error[AG361]: resource `fixture`: capacity must be an integer >= 1, got 0" in out
    assert re.search(r"doc\.ag:4:\d+: error\[AG350\]: operation `a`: duration must be a positive integer", out)
    scenario = ("scenario s {\n  family flow\n  level easy\n  recipes nope\n  profile abstract-v2\n"
                "  release every 8\n  wip 3\n}\n")
    out = _validate(tmp_path, scenario)
    assert "doc.ag:4:11: error[AG412]: unknown recipe `nope`" in out
    assert "error[AG414]: unknown geometry profile `abstract-v2`" in out and "AG005" not in out


def test_a_wrong_container_type_is_named_once(tmp_path):
    path = tmp_path / "r.json"
    path.write_text('{"ir_version": "agspec-ir/1", "kind": "recipe", "id": "r", "raw": {"A": 1}, '
                    '"operations": []}', encoding="utf-8")
    res = CliRunner().invoke(cli, ["validate", str(path)])
    assert res.exit_code == 1 and "must be an array, found an object" in res.stderr
    assert "an object an object" not in res.stderr
