"""Fake broken simulators (tests/fakes/fake_sim.py): each fault gives the right outcome class and
classification, the run continues with the next item, and divergences come with an exact JSON
Pointer and a reproducer that --replay re-runs (F-PROTOCOL-ERRORS, F-REPRO, F-EXIT-CODES)."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

from agspec.cli.main import cli

FAKE = Path(__file__).resolve().parent / "fakes" / "fake_sim.py"
# two short greedy episodes; the fault hits only the first (flow-easy), the second must still pass
WORKLOAD = ("--no-suite", "--episodes", "1", "--horizon", "5", "-k", "flow-easy or flow-medium")


@pytest.fixture(autouse=True)
def _in_tmp(tmp_path, monkeypatch):
    """Reproducers (default --repro-dir .agspec/repro) land in a temporary directory, never in the repo."""
    monkeypatch.chdir(tmp_path)


def fake(mode: str, *extra: str) -> str:
    return " ".join([sys.executable, str(FAKE), mode, "--only", "flow-easy", *extra])


def conform(*args: str):
    result = CliRunner().invoke(cli, ["conform", *args, "--format", "json"], catch_exceptions=False)
    return result.exit_code, json.loads(result.output)


def by_id(out: dict) -> dict[str, dict]:
    return {r["id"]: r for r in out["results"]}


@pytest.mark.parametrize("mode, kind, code", [
    ("crash", "crash", "exit"),
    ("garbage", "protocol", "malformed_json"),
    ("wrong_seq", "protocol", "wrong_seq"),
    ("stale_seq", "protocol", "out_of_order"),
    ("missing", "protocol", "missing_field"),
])
def test_fault_is_an_error_and_the_run_continues(mode: str, kind: str, code: str):
    exit_code, out = conform("--impl", fake(mode), *WORKLOAD)
    results = by_id(out)
    bad, good = results["e-flow-easy-greedy"], results["e-flow-medium-greedy"]
    assert bad["outcome"] == "error"
    assert bad["failure"]["type"] == kind and bad["failure"]["code"] == code
    assert good["outcome"] == "pass"  # restarted for the next item
    assert exit_code == 3  # F-EXIT-CODES: harness/protocol error, no failure


def test_crash_reports_stderr():
    _, out = conform("--impl", fake("crash"), *WORKLOAD)
    failure = by_id(out)["e-flow-easy-greedy"]["failure"]
    assert "simulated fatal error" in failure["stderr"]
    assert failure["tick"] == 2


def test_hang_times_out_and_the_next_item_runs():
    exit_code, out = conform("--impl", fake("hang"), "--timeout", "1", *WORKLOAD)
    results = by_id(out)
    assert results["e-flow-easy-greedy"]["outcome"] == "error"
    assert results["e-flow-easy-greedy"]["failure"]["type"] == "timeout"
    assert results["e-flow-medium-greedy"]["outcome"] == "pass"
    assert exit_code == 3


def test_validate_protocol_reports_schema_violations():
    exit_code, out = conform("--impl", fake("schema"), "--validate-protocol", *WORKLOAD)
    failure = by_id(out)["e-flow-easy-greedy"]["failure"]
    assert failure["type"] == "protocol" and failure["code"] == "schema"
    assert "/t" in failure["message"]
    assert exit_code == 3
    # without --validate-protocol the reply checks still refuse a non-integer t
    _, out = conform("--impl", fake("schema"), *WORKLOAD)
    assert by_id(out)["e-flow-easy-greedy"]["failure"]["code"] == "bad_field"


def test_divergence_pointer_and_replay(tmp_path: Path):
    repro = tmp_path / "repro"
    exit_code, out = conform("--impl", fake("mutate"), "--repro-dir", str(repro), *WORKLOAD)
    assert exit_code == 1  # nonconformant
    bad = by_id(out)["e-flow-easy-greedy"]
    assert bad["outcome"] == "fail"
    f = bad["failure"]
    assert f["type"] == "divergence" and f["where"] == "state"
    assert f["pointer"] == "/robots/0,0/switch_lock" and f["path"] == "/state/robots/0,0/switch_lock"
    assert f["tick"] == 2 and f["actual"] == f["expected"] + 1
    # the joint actions up to and including the step whose reply diverged: ticks 0, 1 and 2
    assert [c["t"] for c in f["context"]] == [0, 1, 2]
    path = Path(f["reproducer"])
    data = json.loads(path.read_text())
    assert data["format"] == "agspec-repro/1" and len(data["actions"]) == 3  # ticks 0, 1, 2
    assert data["impl"] == fake("mutate")

    # --replay re-runs the action prefix against the implementation named in the file: same divergence
    exit_code, out = conform("--replay", str(path))
    (replayed,) = out["results"]
    assert exit_code == 1 and replayed["kind"] == "replay"
    g = replayed["failure"]
    assert (g["tick"], g["path"], g["expected"], g["actual"]) == (f["tick"], f["path"], f["expected"], f["actual"])
    # ... and against the reference it passes ("fixed")
    exit_code, out = conform("--replay", str(path), "--impl", "reference")
    assert exit_code == 0 and out["results"][0]["outcome"] == "pass"


def test_table_output_is_commonmark_style(tmp_path: Path):
    result = CliRunner().invoke(cli, ["conform", "--impl", fake("mutate"), "--repro-dir", str(tmp_path), *WORKLOAD],
                                catch_exceptions=False)
    text = result.output
    assert result.exit_code == 1
    assert ("first divergence in the reply to step 2 (the joint action of epoch 2 \u2192 the state of epoch 3): "
            "state /robots/0,0/switch_lock") in text
    assert "joint actions up to that reply" in text and "replay:" in text
    assert "NONCONFORMANT" in text


def test_two_simulators_keep_their_reproducers_apart(tmp_path: Path):
    """F-REPRO: {--repro-dir}/{impl}/{id}.repro.json, one directory per implementation, named in the output."""
    from agspec.cli.conform_view import impl_slug

    repro = tmp_path / "repro"
    first, second = fake("mutate"), fake("mutate", "--at", "2")  # the same bug, another command
    paths = []
    for spec in (first, second):
        result = CliRunner().invoke(cli, ["conform", "--impl", spec, "--repro-dir", str(repro), *WORKLOAD],
                                    catch_exceptions=False)
        assert result.exit_code == 1, result.output
        where = repro / impl_slug(spec)
        assert f"reproducers of this implementation are in {where}/" in result.output
        (path,) = where.glob("*.repro.json")
        assert path.name == "e-flow-easy-greedy.repro.json" and json.loads(path.read_text())["impl"] == spec
        paths.append(path)
    assert paths[0].parent != paths[1].parent and all(p.exists() for p in paths)  # neither overwrote the other
    assert impl_slug("python my_sim.py --bug") == "python-my_sim.py-bug-f473b231"
    assert impl_slug(f"{sys.executable} /x/y/sim.py --mutant dup").startswith(Path(sys.executable).name + "-sim.py-mutant-dup-")
