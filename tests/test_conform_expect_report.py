"""Expected-failures files (xfail, xpass, stale; F-EXPECT) and the incremental report (F-REPORT):
schema-valid, and complete up to the last finished item after a crash of the harness."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from click.testing import CliRunner

from agspec.cli.main import cli
from agspec.formats.report import read_report

FAKE = Path(__file__).resolve().parent / "fakes" / "fake_sim.py"
WORKLOAD = ("--no-suite", "--episodes", "1", "--horizon", "5", "-k", "flow-easy or flow-medium")


@pytest.fixture(autouse=True)
def _in_tmp(tmp_path, monkeypatch):
    """Reproducers (default --repro-dir .agspec/repro) land in a temporary directory, never in the repo."""
    monkeypatch.chdir(tmp_path)


def conform(*args: str):
    result = CliRunner().invoke(cli, ["conform", *args, "--format", "json"], catch_exceptions=False)
    return result.exit_code, json.loads(result.output) if result.output.startswith("{") else result.output


def write(path: Path, data: dict) -> Path:
    path.write_text(json.dumps(data), encoding="utf-8")
    return path


def mutate() -> str:
    return f"{sys.executable} {FAKE} mutate --only flow-easy"


def test_expected_failure_is_xfail(tmp_path: Path):
    expect = write(tmp_path / "expect.json", {"e-flow-easy-greedy": {"outcome": "fail", "reason": "known gap"}})
    code, out = conform("--impl", mutate(), "--expect", str(expect), "--repro-dir", str(tmp_path), *WORKLOAD)
    outcomes = {r["id"]: r["outcome"] for r in out["results"]}
    assert outcomes == {"e-flow-easy-greedy": "xfail", "e-flow-medium-greedy": "pass"}
    rec = next(r for r in out["results"] if r["id"] == "e-flow-easy-greedy")
    assert rec["raw_outcome"] == "fail" and rec["expected"] == {"outcome": "fail", "reason": "known gap"}
    assert code == 0


def test_unexpected_pass_is_xpass_and_fails_the_run(tmp_path: Path):
    expect = tmp_path / "expect.yaml"
    expect.write_text("e-flow-medium-greedy:\n  outcome: fail\n  reason: was broken once\n", encoding="utf-8")
    code, out = conform("--impl", "reference", "--expect", str(expect), *WORKLOAD)
    assert {r["id"]: r["outcome"] for r in out["results"]}["e-flow-medium-greedy"] == "xpass"
    assert out["footer"]["counts"]["xpass"] == 1 and not out["footer"]["conformant"]
    assert code == 1


def test_expected_error_class_mismatch_keeps_real_outcome(tmp_path: Path):
    expect = write(tmp_path / "e.json", {"e-flow-easy-greedy": {"outcome": "error"}})
    code, out = conform("--impl", mutate(), "--expect", str(expect), "--repro-dir", str(tmp_path), *WORKLOAD)
    assert {r["id"]: r["outcome"] for r in out["results"]}["e-flow-easy-greedy"] == "fail"
    assert code == 1


def test_stale_entry_fails_the_run(tmp_path: Path):
    expect = write(tmp_path / "e.json", {"c-000000000000": {"outcome": "fail", "reason": "renamed long ago"},
                                         "e-flow-easy-random-7": {"outcome": "fail"}})  # an episode id: not stale
    report = tmp_path / "r.jsonl"
    code, out = conform("--impl", "reference", "--expect", str(expect), "-o", str(report),
                        "--episodes", "1", "--horizon", "3", "-k", "flow-easy")
    assert out["stale"] == ["c-000000000000"]
    assert code == 1
    records, problems = read_report(report)
    assert problems == []
    assert [r["id"] for r in records if r["type"] == "stale"] == ["c-000000000000"]
    assert records[-1]["stale"] == 1 and records[-1]["exit_code"] == 1


def test_malformed_expectations_file_is_invalid_input_and_a_missing_one_a_usage_error(tmp_path: Path):
    """F-EXIT-CODES: bad content exits 1 (like every other input), a file that cannot be read 2."""
    bad = tmp_path / "bad.yaml"
    bad.write_text("c-1234:\n  outcome: maybe\n", encoding="utf-8")
    code, out = conform("--impl", "reference", "--expect", str(bad), *WORKLOAD)
    assert code == 1 and "outcome" in out
    code, out = conform("--impl", "reference", "--expect", str(tmp_path / "missing.yaml"), *WORKLOAD)
    assert code == 2 and "AG001" in out


def test_report_is_complete_when_the_simulator_crashes(tmp_path: Path):
    report = tmp_path / "r.jsonl"
    code, _ = conform("--impl", f"{sys.executable} {FAKE} crash --only flow-easy", "-o", str(report), *WORKLOAD)
    assert code == 3
    records, problems = read_report(report)
    assert problems == []
    assert [r["type"] for r in records] == ["header", "case", "case", "footer"]
    assert records[-1]["counts"]["error"] == 1 and records[-1]["counts"]["pass"] == 1


def test_report_survives_a_crash_of_the_harness(tmp_path: Path):
    """Kill the harness (SIGKILL) in the middle of a run: every line written so far is a valid record."""
    report = tmp_path / "r.jsonl"
    cmd = [sys.executable, "-m", "agspec.cli.main", "conform", "--impl", "reference", "--no-suite",
           "--episodes", "3", "--horizon", "40", "-o", str(report)]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=tmp_path)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            if report.exists() and report.read_text(encoding="utf-8").count('"type":"case"') >= 2:
                break
            if proc.poll() is not None:
                break
            time.sleep(0.05)
    finally:
        if proc.poll() is None:
            os.kill(proc.pid, signal.SIGKILL)
        proc.wait()
    records, problems = read_report(report)
    cases = [r for r in records if r["type"] == "case"]
    assert records[0]["type"] == "header" and len(cases) >= 2
    if records[-1]["type"] != "footer":  # killed mid-run (the expected path): only "incomplete" is wrong
        assert len(problems) == 1 and "incomplete" in problems[0]
    assert all(r["outcome"] == "pass" for r in cases)
