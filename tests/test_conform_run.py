"""`agspec conform` end to end: the reference, `agspec serve` and an in-process adapter pass; the
report is schema-valid and complete; -k, -j, --coverage, usage errors (F-CONFORM, F-REPORT, F-EXIT-CODES)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner

from agspec.cli.main import cli
from agspec.formats.report import read_report

FAKES = Path(__file__).resolve().parent / "fakes"
SERVE = shutil.which("agspec")


@pytest.fixture(autouse=True)
def _in_tmp(tmp_path, monkeypatch):
    """Reproducers (default --repro-dir .agspec/repro) land in a temporary directory, never in the repo."""
    monkeypatch.chdir(tmp_path)


def conform(*args: str, cwd: Path | None = None):
    result = CliRunner().invoke(cli, ["conform", *args], catch_exceptions=False)
    return result


def json_run(*args: str):
    result = conform(*args, "--format", "json")
    return result.exit_code, json.loads(result.output)


def test_reference_passes_suite_and_episodes(tmp_path: Path):
    report = tmp_path / "report.jsonl"
    code, out = json_run("--impl", "reference", "--episodes", "1", "--horizon", "15", "-o", str(report))
    assert code == 0, [r for r in out["results"] if r["outcome"] != "pass"][:3]
    footer = out["footer"]
    assert footer["conformant"] and footer["counts"]["pass"] == footer["total"]
    assert footer["total"] > 9  # the suite and one episode per official scenario
    assert footer["states_compared"] > footer["total"] and footer["invariant_checks"] > 1000  # vacuity numbers
    kinds = {r["kind"] for r in out["results"]}
    assert kinds == {"case", "episode"}
    records, problems = read_report(report)
    assert problems == []
    assert records[0]["type"] == "header" and records[-1]["type"] == "footer"
    assert len([r for r in records if r["type"] == "case"]) == footer["total"]


@pytest.mark.skipif(SERVE is None, reason="the agspec console script is not installed")
def test_agspec_serve_passes_over_the_wire():
    code, out = json_run("--impl", "agspec serve", "--episodes", "1", "--horizon", "8",
                         "-k", "episode or handoff or support or coalition")
    assert code == 0, [r for r in out["results"] if r["outcome"] != "pass"][:3]
    assert out["header"]["implementation"]["implementation"]["name"] == "agspec-reference"
    assert out["header"]["implementation"]["capabilities"]["observations"] is True
    assert out["footer"]["counts"]["pass"] >= 10


@pytest.mark.skipif(SERVE is None, reason="the agspec console script is not installed")
def test_agspec_serve_speaks_the_protocol_exactly():
    """--validate-protocol: every request and reply of a session checked against schemas/protocol/."""
    code, out = json_run("--impl", "agspec serve", "--no-suite", "--episodes", "2", "--horizon", "3",
                         "-k", "flow-easy", "--validate-protocol")
    assert code == 0 and out["footer"]["counts"]["pass"] == 2


def test_python_adapter_passes():
    spec = f"python:{FAKES / 'tiny_adapter.py'}:make"
    code, out = json_run("--impl", spec, "--episodes", "1", "--horizon", "10", "-k", "episode or release or pick")
    assert code == 0, [r for r in out["results"] if r["outcome"] != "pass"][:3]
    assert out["header"]["implementation"]["implementation"]["name"] == "tiny"
    # the tiny adapter declares no observations: their assertions are skipped, never failed
    assert out["footer"]["counts"]["fail"] == 0


def test_python_adapter_runs_observation_cases_at_its_level():
    """RES-ASSERTION-LEVEL: a case that also asserts observations runs its state and event assertions
    on an adapter without observations; only the observation assertions are skipped, and counted."""
    spec = f"python:{FAKES / 'tiny_adapter.py'}:make"
    code, out = json_run("--impl", spec, "--episodes", "0")
    assert code == 0 and not [r for r in out["results"] if r["outcome"] == "skip"]
    partial = [r for r in out["results"] if r["checks"]["assertions"]["skipped"]]
    assert partial and all(r["outcome"] == "pass" and r["checks"]["assertions"]["checked"] for r in partial)
    assert set(out["footer"]["assertions"]["skipped_by_part"]) <= {"observations", "masks", "diagnostic_state"}


def test_parallel_equals_sequential():
    args = ("--impl", "reference", "--no-suite", "--episodes", "1", "--horizon", "5", "-k", "flow or coalition-easy")
    code1, one = json_run(*args, "-j", "1")
    code2, two = json_run(*args, "-j", "2")
    assert code1 == code2 == 0
    strip = lambda out: [(r["id"], r["outcome"], r["ticks"], r["checks"]) for r in out["results"]]  # noqa: E731
    assert strip(one) == strip(two)


def test_keyword_selection_and_empty_selection():
    code, out = json_run("--impl", "reference", "--no-suite", "--episodes", "2", "--horizon", "3",
                         "-k", "flow-easy and not random")
    assert code == 0 and [r["id"] for r in out["results"]] == ["e-flow-easy-greedy"]
    result = conform("--impl", "reference", "--no-suite", "-k", "no-such-thing")
    assert result.exit_code == 2 and "no case or episode selected" in result.output
    result = conform("--impl", "reference", "-k", "flow and (")
    assert result.exit_code == 2


def test_usage_errors_exit_2():
    assert conform("--no-suite").exit_code == 2  # no --impl
    assert conform("--impl", "python:no_such_module_xyz:make").exit_code == 2
    assert conform("--impl", "reference", "--episodes", "-1").exit_code == 2
    assert conform("--replay", "/nonexistent/file.json").exit_code == 2
    result = conform("--impl", "/nonexistent/simulator --flag", "--no-suite", "--episodes", "1", "--horizon", "2",
                     "-k", "flow-easy")
    assert result.exit_code == 3 and "cannot start" in result.output  # spawn failure: a harness error


def test_coverage_json():
    # a short run: the variant space is measured over the items --episodes and --horizon select
    result = conform("--coverage", "--format", "json", "--episodes", "1", "--horizon", "5")
    cov = json.loads(result.output)
    # values and variants: F-CONFORM-COVERAGE
    assert set(cov) == {"rules", "invariants", "values", "variants", "unreachable", "uncovered"}
    assert all(k.startswith("R-") for k in cov["rules"]) and all(k.startswith("INV-") for k in cov["invariants"])
    assert cov["values"]["value:support_fraction_1/3"] and cov["values"]["event:release"]
    rho = cov["variants"]["profile:rho_conf=0.4"]
    assert rho["spec"] == "PR-VARIANT" and rho["asserted"] and set(rho["asserted"]) <= set(rho["items"])
    assert all(f["tick"] >= -1 and f["where"] for f in rho["findings"].values())
    assert {e for e in cov["uncovered"] if not e.startswith("topology:")} == set()
    from agspec.invariants import INVARIANT_IDS

    assert set(INVARIANT_IDS) <= set(cov["invariants"])
    assert result.exit_code == (1 if cov["uncovered"] else 0)


def test_no_traceback_on_garbage_suite(tmp_path: Path):
    (tmp_path / "cases").mkdir()
    (tmp_path / "cases" / "bad.yaml").write_text("title: [unclosed\n", encoding="utf-8")
    result = conform("--impl", "reference", "--suite", str(tmp_path))
    assert result.exit_code == 1  # F-EXIT-CODES: a case file with bad content is invalid input
    assert "Traceback" not in result.output
