"""`agspec validate`, `compile` and `fmt` through click's CliRunner (F-DIAGNOSTICS, F-EXIT-CODES; a decimal
duration is AG350, its rule's code, F-CODES)."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner
from jsonschema import Draft202012Validator

from agspec.cli.main import cli
from agspec.ir.schemas import load_schema
from agspec.resources import catalogue_dir

CATALOGUE = sorted(str(p) for p in catalogue_dir().glob("**/*.ag"))
BROKEN = """recipe broken {
    raw A
    operation a {
        type t
        inputs A -> FINAL
        team 1
        duration 2.5
    }
}
"""


def run(*args: str):
    return CliRunner().invoke(cli, list(args), catch_exceptions=False)


@pytest.fixture
def broken(tmp_path: Path) -> Path:
    path = tmp_path / "broken.ag"
    path.write_text(BROKEN, encoding="utf-8")
    return path


def test_validate_catalogue_exits_0():
    result = run("validate", *CATALOGUE)
    assert result.exit_code == 0, result.stderr
    assert f"{len(CATALOGUE)}/{len(CATALOGUE)} valid" in result.stdout


def test_validate_official_scenario_names_and_directories():
    assert run("validate", "coalition-medium", "flow-easy").exit_code == 0
    result = run("validate", str(catalogue_dir()))
    assert result.exit_code == 0 and f"{len(CATALOGUE)}/{len(CATALOGUE)} valid" in result.stdout


def test_validate_broken_file_exits_1_with_located_diagnostic(broken: Path):
    result = run("validate", str(broken))
    assert result.exit_code == 1
    assert re.search(rf"{re.escape(str(broken))}:7:18: error\[AG350\]: ", result.stderr)
    assert " 7 |         duration 2.5" in result.stderr and "^^^" in result.stderr
    assert "Traceback" not in result.stderr + result.stdout


def test_validate_reports_every_file(broken: Path, tmp_path: Path):
    other = tmp_path / "other.ag"
    other.write_text("recipe r { raw A\n", encoding="utf-8")
    result = run("validate", str(broken), str(other), CATALOGUE[0])
    assert result.exit_code == 1
    assert "error[AG350]" in result.stderr and "error[AG103]" in result.stderr
    assert "1/3 valid" in result.stdout


def test_validate_json_output_matches_schema(broken: Path, tmp_path: Path):
    garbage = tmp_path / "garbage.ag"
    garbage.write_text('recipe { raw @ }\n"unterminated', encoding="utf-8")
    result = run("validate", "--format", "json", str(broken), str(garbage), CATALOGUE[0])
    assert result.exit_code == 1
    data = json.loads(result.stdout)
    Draft202012Validator(load_schema("diagnostics")).validate(data)
    assert data and all(set(d) >= {"code", "message", "file", "line", "col", "hint"} for d in data)
    assert ("AG350", 7, 18) in {(d["code"], d["line"], d["col"]) for d in data}


def test_validate_missing_file_is_usage_error(tmp_path: Path):
    result = run("validate", str(tmp_path / "nope.ag"))
    assert result.exit_code == 2 and "error[AG001]" in result.stderr


def test_validate_needs_an_argument():
    assert run("validate").exit_code == 2


def test_compile_prints_ir(tmp_path: Path):
    result = run("compile", "--compact", str(catalogue_dir() / "recipes" / "pair_assembly.ag"))
    assert result.exit_code == 0
    assert "\n" not in result.stdout.strip()
    ir = json.loads(result.stdout)
    assert ir["id"] == "pair_assembly" and ir["operations"][0]["weight"] == 1.2
    pretty = run("compile", "coalition-medium")
    assert pretty.exit_code == 0 and json.loads(pretty.stdout)["release"] == {"interval": 5, "wip_cap": 4}
    out = tmp_path / "ir.json"
    assert run("compile", "flow-easy", "-o", str(out)).exit_code == 0
    assert json.loads(out.read_text())["id"] == "flow-easy"


def test_compile_broken_file_exits_1(broken: Path):
    result = run("compile", str(broken))
    assert result.exit_code == 1 and result.stdout == "" and "error[AG350]" in result.stderr


def test_fmt_prints_canonical_text_and_check(tmp_path: Path):
    path = catalogue_dir() / "profiles" / "abstract-v1.ag"
    result = run("fmt", str(path))
    assert result.exit_code == 0 and result.stdout == path.read_text(encoding="utf-8")
    assert run("fmt", "--check", str(path)).exit_code == 0
    messy = tmp_path / "messy.ag"
    messy.write_text("recipe r{raw A operation a{type t inputs A->FINAL team 1 duration 2}}", encoding="utf-8")
    check = run("fmt", "--check", str(messy))
    assert check.exit_code == 1 and "not in canonical form" in check.stderr and "+recipe r {" in check.stderr
    assert run("fmt", "--write", str(messy)).exit_code == 0
    assert run("fmt", "--check", str(messy)).exit_code == 0


def test_fmt_of_json_ir_gives_dsl(tmp_path: Path):
    ir = json.loads(run("compile", "coalition-medium").stdout)
    path = tmp_path / "s.json"
    path.write_text(json.dumps(ir), encoding="utf-8")
    result = run("fmt", str(path))
    assert result.exit_code == 0 and result.stdout.startswith("scenario coalition-medium {\n")


def test_fmt_refuses_invalid_input(broken: Path):
    result = run("fmt", str(broken))
    assert result.exit_code == 1 and "error[AG350]" in result.stderr and result.stdout == ""


def test_validate_keeps_diagnostics_before_the_summary_in_one_pipe(tmp_path):  # F-DIAGNOSTICS
    bad = tmp_path / "bad.ag"
    bad.write_text("recipe r {\n  operation a { duration two }\n}\n", encoding="utf-8")
    good = Path(__file__).resolve().parents[1] / "catalogue" / "recipes" / "pair_assembly.ag"
    out = subprocess.run([sys.executable, "-m", "agspec.cli.main", "validate", str(bad), str(good)],
                         stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=120).stdout
    assert out.index("error[AG102]") < out.index("status") < out.index("1/2 valid")
