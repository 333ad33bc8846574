"""Failure reports an author acts on in one read (F-EVENT-DIFF, F-CONFORM-KNOWN, F-REPORT,
RES-ASSERTION-LEVEL): events compared as sequences, the joint action of the failing step shown in
one wording, `render --diff` drawing what the implementation sent, known divergences named, and
suite assertions scoped to the parts a simulator declares.

The generators and oracles are in tests/report_edits.py; benchmarks/fuzz_reports.py runs them long.
"""

from __future__ import annotations

import json
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import report_edits as R
from agspec.trace.check import trace_diag
from agspec.conform import runner
from agspec.conform.cases import load_suite
from agspec.conform.lockstep.compare import compare_reply, reply_name
from agspec.conform.expect import Expected
from agspec.conform.impl import PythonImpl
from agspec.conform.items import catalogue_episodes, from_case
from agspec.conform.run_item import Options
from agspec.formats import divergences
from agspec.formats.report import read_report
from agspec.trace.verify import verify
from agspec.viewer.divergence import build_diff
from agspec.viewer.encode import decode_states

FAKES = Path(__file__).resolve().parent / "fakes"
sys.path.insert(0, str(FAKES))
from level_adapter import Declares, Tamper  # noqa: E402

SETTINGS = dict(deadline=None, database=None, suppress_health_check=list(HealthCheck))


@pytest.fixture(autouse=True)
def _in_tmp(tmp_path, monkeypatch):
    """Reproducers land in a temporary directory, never in the repository."""
    monkeypatch.chdir(tmp_path)


def suite_items(*titles: str):
    return [from_case(c) for c in load_suite() if any(t in c.title for t in titles)]


def run_inprocess(items, adapter, tmp_path: Path, **kw):
    impl = PythonImpl(lambda: adapter, spec="python:tamper")
    try:
        return runner.run(items, "python:tamper", impl=impl, opts=Options(repro_dir=str(tmp_path / "repro"),
                                                                           impl_spec="python:tamper"),
                          report_path=str(tmp_path / "r.jsonl"), replays=0, **kw)
    finally:
        impl.close()


def failure_of(summary):
    (failed,) = [r for r, o in summary.results if r.outcome == "fail"]
    return failed


# ============================================================================== events as sequences


@settings(max_examples=150, **SETTINGS)
@given(R.event_edits())
def test_one_edit_of_an_event_list_is_named_as_that_edit(edit):  # F-EVENT-DIFF
    expected, actual, what = edit
    div = compare_reply(0, {"events": expected}, {"events": actual}, ["events"])
    assert R.misnamed_edit(what, div) is None


def test_a_missing_support_event_reads_as_a_missing_support(tmp_path: Path):
    """The simulator's state is right and only its `support` events are missing: the report says so,
    instead of a field difference of the event that took the missing one's place."""
    summary = run_inprocess(suite_items("competing coalitions"), Tamper("drop_support"), tmp_path)
    res = failure_of(summary)
    f = res.failure
    assert f["where"] == "events" and f["message"].count("missing support(") == 1
    assert f["expected"]["type"] == "support" and f["actual_absent"]
    rows = [r for r in f["events"]["rows"] if r["op"] != "same"]
    assert rows and all(r["op"] == "missing" and r["type"] == "support" for r in rows)
    assert f["events"]["counts"]["missing"] == len(rows) and f["events"]["counts"]["extra"] == 0
    # the block shows both lists side by side, the missing event marked
    assert "aligned by type" in res.rendered
    assert any(line.lstrip().startswith("-") and "support(robot=" in line for line in res.rendered.splitlines())
    records, problems = read_report(tmp_path / "r.jsonl")
    assert problems == []  # F-REPORT: the event alignment is in the report, schema-valid


def test_the_events_of_a_reply_whose_state_differs_first_are_aligned_too():
    expected, actual = R.stock_replies()
    div = compare_reply(1, expected, actual, ["t", "state", "events", "done"])
    assert div.where == "state" and div.events is not None
    ops = {r["op"]: r["type"] for r in div.events["rows"] if r["op"] != "same"}
    assert ops == {"missing": "release_lost", "extra": "release"}


def test_diff_shrinks_and_saves_an_event_divergence_by_its_kind():
    """`agspec diff` keeps what differs (a missing support) while shrinking, and its saved case asserts
    the missing event itself."""
    from agspec.conform.explore.shrink import expectation

    support = {"type": "support", "robot": "0,1", "candidate": "op:0:fit:0,0;0,1"}
    created = {"type": "proposal_created", "candidate": "op:0:fit:0,0;0,1", "expires_at": 4}
    div = compare_reply(2, {"events": [created, support]}, {"events": [created]}, ["events"])
    assert div.signature() == ("events", "missing support")
    assert expectation(div) == {"after_tick": 2, "events": [support]}
    extra = compare_reply(2, {"events": [created]}, {"events": [created, support]}, ["events"])
    assert extra.signature() == ("events", "extra support") and expectation(extra) == {"after_tick": 2,
                                                                                       "no_events": [support]}


# ===================================================================== the failing step and its actions


@settings(max_examples=5, **SETTINGS)
@given(at=st.integers(0, 4))
def test_the_failure_block_shows_the_joint_action_of_the_failing_step(at, tmp_path_factory):
    tmp_path = tmp_path_factory.mktemp("ctx")
    items = catalogue_episodes(1, 8, ["flow-easy"])
    summary = run_inprocess(items, Tamper("mutate", at), tmp_path)
    res = failure_of(summary)
    f = res.failure
    assert f["tick"] == at and f["reply"] == reply_name(at)
    sent = json.loads(Path(f["reproducer"]).read_text())["actions"]
    assert f["context"][-1] == {**f["context"][-1], "t": at, "actions": sent[at]}  # the failing step itself
    assert [c["t"] for c in f["context"]] == list(range(max(0, at - 3), at + 1))
    assert f"first divergence {reply_name(at)}" in res.rendered
    marked = [line for line in res.rendered.splitlines() if "its reply is the one that failed" in line]
    assert len(marked) == 1 and f"epoch {at} " in marked[0]


def test_one_wording_names_the_reply_everywhere():
    assert reply_name(-1) == "in the reply to reset (the state of epoch 0)"
    assert reply_name(0) == "in the reply to step 0 (the joint action of epoch 0 \u2192 the state of epoch 1)"
    assert reply_name(3, short=True) == "in the reply to step 3"
    case = next(c for c in load_suite() if R.STOCK_CASE in c.title)
    from agspec.conform.cases.expectations import mismatches

    (m, *_) = mismatches(case, 1, {}, [])
    assert f"{reply_name(1, short=True)}:" in str(m)


# ============================================================================= render --diff: observed


@pytest.mark.parametrize("at", [0, 2])
def test_render_diff_draws_what_the_implementation_sent(tmp_path: Path, monkeypatch, at):
    """A simulator that starts nothing it is asked to: the observed side shows no activity where the
    reference has one, labelled as the implementation's, never the reference's states patched."""
    monkeypatch.chdir(tmp_path)
    summary = run_inprocess(catalogue_episodes(1, 8, ["flow-easy"]), Tamper("ignore_actions", at), tmp_path)
    f = failure_of(summary).failure
    data = build_diff(tmp_path / "r.jsonl")
    focus = f["tick"] + 1
    observed, expected = decode_states(data["actual"]), decode_states(data["expected"])
    assert observed[focus] == f["observed"]["state"]  # exactly what the implementation sent
    assert expected[focus]["activities"] and not observed[focus]["activities"]
    assert observed[:focus] == expected[:focus]  # the states compared equal before it
    assert data["actual"]["source"]["implementation"]["name"] == "tamper"
    assert data["labels"]["actual"].startswith("tamper") and "reference" in data["labels"]["expected"]
    assert data["failure"]["reply"] == reply_name(f["tick"])
    assert "/state/activities/0" in data["differences"][str(focus)]


def test_render_diff_of_a_simulator_without_state_draws_only_the_expected_side(tmp_path: Path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    run_inprocess(catalogue_episodes(1, 6, ["flow-easy"]), Tamper("drop_support", 0, parts=("events",)), tmp_path)
    run_inprocess(catalogue_episodes(1, 8, ["flow-easy"]), Tamper("ignore_actions", 1, parts=("events",)), tmp_path)
    data = build_diff(tmp_path / "r.jsonl")
    assert data["actual"] is None and "no state" in data["actual_source"]
    assert data["differences"][str(data["focus"])]


@pytest.mark.skipif(shutil.which("node") is None, reason="needs node to run the viewer script without a browser")
def test_the_viewer_script_draws_a_diff_with_and_without_an_observed_side(tmp_path: Path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    run_inprocess(catalogue_episodes(1, 8, ["flow-easy"]), Tamper("ignore_actions", 1), tmp_path)
    data = build_diff(tmp_path / "r.jsonl")
    scripts = [str(R.ROOT / "agspec" / "viewer" / "assets" / f) for f in ("model.js", "layout.js", "viewer.js")]
    for observed in (True, False):
        doc = tmp_path / "doc.json"
        doc.write_text(json.dumps(data if observed else {**data, "actual": None}), encoding="utf-8")
        proc = subprocess.run(["node", str(FAKES / "dom_stub.js"), str(doc), *scripts], capture_output=True,
                              text=True, timeout=60)
        assert proc.returncode == 0, proc.stderr
        out = json.loads(proc.stdout.splitlines()[-1])
        assert out["T"] == data["focus"]
        assert ("observed tamper" in out["subtitle"]) == observed and "expected agspec-reference" in out["subtitle"]
        assert data["failure"]["reply"] in out["panel"]  # the reply named as every report names it


# ========================================================================== known divergences named


@settings(max_examples=60, **SETTINGS)
@given(R.stock_failures())
def test_the_stock_divergence_is_named_exactly_when_nothing_else_differs(failure):  # F-CONFORM-KNOWN
    assert R.misnamed_stock(*failure) is None


STOCK_SIM = FAKES / "release_stock_sim.py"


@pytest.mark.parametrize("flags", [(), ("--no-events",), ("--no-state",)])
def test_a_simulator_releasing_despite_empty_stock_is_told_it_is_div_release_stock(tmp_path: Path, flags):
    spec = shlex.join([sys.executable, str(STOCK_SIM), *flags])
    items = suite_items(R.STOCK_CASE, "WIP cap 1: opportunities are lost", "2-robot coalition formed")
    assert len(items) >= 2
    summary = runner.run(items, spec, opts=Options(repro_dir=str(tmp_path), impl_spec=spec), replays=0,
                         report_path=str(tmp_path / "r.jsonl"))
    res = failure_of(summary)
    named = res.failure["known_divergence"]
    assert named["id"] == "DIV-RELEASE-STOCK" and named["spec"] == "spec/10-divergences.md"
    assert named["expect"] == divergences.expect_entry(res.item.id, "DIV-RELEASE-STOCK")
    assert "known divergence DIV-RELEASE-STOCK" in res.rendered and named["expect"] in res.rendered
    assert summary.footer()["known_divergences"] == {"DIV-RELEASE-STOCK": [res.item.id]}
    assert read_report(tmp_path / "r.jsonl")[1] == []
    # the printed entry, put in an expected-failures file, accepts exactly that failure
    from agspec.conform.expect import load_expectations

    expect = tmp_path / "expect.yaml"
    expect.write_text(named["expect"] + "\n", encoding="utf-8")
    again = runner.run(items, spec, expectations=load_expectations(expect), replays=0,
                       opts=Options(repro_dir=str(tmp_path), impl_spec=spec))
    assert [o for _, o in again.results].count("xfail") == 1 and again.exit_code == 0


@pytest.mark.parametrize("mode", ["mutate", "drop_support", "ignore_actions"])
def test_other_failures_are_not_named(tmp_path: Path, mode):
    items = suite_items(R.STOCK_CASE) + catalogue_episodes(1, 6, ["flow-easy"])
    summary = run_inprocess(items, Tamper(mode, 0), tmp_path, max_fail=None)
    failures = [r.failure for r, o in summary.results if o == "fail"]
    assert failures and not any("known_divergence" in f for f in failures)


def test_every_divergence_of_spec_10_has_a_valid_signature():
    spec = (R.ROOT / "spec" / "10-divergences.md").read_text(encoding="utf-8")
    headings = {line.split()[1] for line in spec.splitlines() if line.startswith("### DIV-")}
    assert set(divergences.signatures()) == headings
    assert "conformance/divergences.yaml" in spec  # spec/10 cites the data


def test_a_malformed_signature_file_is_refused(tmp_path: Path, monkeypatch):
    bad = tmp_path / "divergences.yaml"
    bad.write_text("DIV-" + "BROKEN:\n  title: x\n  scope: reply\n", encoding="utf-8")  # no reference_events
    monkeypatch.setattr(divergences, "path", lambda: bad)
    divergences.signatures.cache_clear()
    try:
        with pytest.raises(divergences.SignatureError, match="reference_events"):
            divergences.signatures()
    finally:
        divergences.signatures.cache_clear()


def _trace(name: str) -> list[dict]:
    path = R.ROOT / "conformance" / "traces" / name
    return [json.loads(line) for line in path.read_text(encoding="utf-8").splitlines()]


def test_agspec_check_names_a_makespan_reported_in_continuing_mode():  # DIV-MAKESPAN-CONTINUING
    records = _trace("flow-hard-s00-random-h60.jsonl")
    assert records[0]["instance"]["scenario"]["evaluation"]["mode"] == "continuing"
    records[-1]["metrics"]["makespan"] = 400.0  # what the original release reports
    (d,) = [d for d in verify(records, "t.jsonl", trace_diag) if d.code == "AG605"]
    assert "DIV-MAKESPAN-CONTINUING" in d.message
    records = _trace("flow-hard-s00-random-h60.jsonl")
    records[-1]["metrics"]["delivered"] += 1  # another wrong metric is not a known divergence
    assert not any("DIV-" in d.message for d in verify(records, "t.jsonl", trace_diag))


# =========================================================================== assertions at the level


@settings(max_examples=15, **SETTINGS)
@given(R.level_runs())
def test_a_case_runs_every_assertion_its_level_allows(run):  # RES-ASSERTION-LEVEL
    case, parts = run
    assert R.misjudged_level(case, parts, R.run_level(case, parts)) is None


def test_a_simulator_without_observations_runs_the_suite_and_says_what_it_skipped(tmp_path: Path):
    items = [from_case(c) for c in load_suite()]
    summary = run_inprocess(items, Declares({"state", "events"}), tmp_path)
    assert summary.exit_code == 0 and summary.counts["skip"] == 0
    obs_cases = [c.id for c in load_suite() if c.needs_observations]
    assert obs_cases
    by_id = {r.item.id: r for r, _ in summary.results}
    for ident in obs_cases:
        a = by_id[ident].assertions
        skipped = a["skipped_by_part"].get("observations", 0) + a["skipped_by_part"].get("masks", 0)
        assert by_id[ident].outcome == "pass" and a["checked"] > 0 and skipped > 0
    footer = summary.footer()
    assert footer["assertions"]["skipped_by_part"]["observations"] > 0
    assert footer["assertions"]["checked"] > footer["assertions"]["skipped"]
    records, problems = read_report(tmp_path / "r.jsonl")
    assert problems == [] and all("assertions" in r["checks"] for r in records if r["type"] == "case")


def test_a_case_none_of_whose_assertions_is_declared_is_skipped_not_passed(tmp_path: Path):
    """The vacuity guard per case: a state-only simulator cannot be judged on a case that asserts only
    events and observations."""
    cases = [c for c in load_suite() if R.allowed_assertions(c, frozenset({"state"})) == 0 and c.expectations]
    assert cases
    summary = run_inprocess([from_case(c) for c in cases], Declares({"state"}), tmp_path)
    assert [o for _, o in summary.results] == ["skip"] * len(cases)
    assert all("nothing of what it asserts could be checked" in r.message for r, _ in summary.results)


def test_expected_failure_entry_shape_matches_the_expectations_schema():
    from agspec.formats.schemas import validate
    from agspec.formats.limits import parse_yaml

    entry = parse_yaml(divergences.expect_entry("c-0123456789ab", "DIV-RELEASE-STOCK"))
    assert validate("expectations", entry) == []
    assert Expected(**entry["c-0123456789ab"]).outcome == "fail"
