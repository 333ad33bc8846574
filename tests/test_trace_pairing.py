"""`agspec check` holds a trace's events and states to each other (F-TRACE-PAIRING, AG609) and to the
order in which the steps emit them (F-TRACE-EMISSION).

* the emission table of the spec is the table the check uses (parsed from spec/09-formats.md);
* the reference passes on every catalogue scenario under every controller, on the conformance
  instances (with illegal actions too) and on the shipped traces — the check is not over-eager, and
  the reference emits what the table says, in its order, across all those episodes;
* lying traces (tests/trace_lies.py: an event dropped, doubled, delayed, advanced or altered, a state
  changed without its event, the footer rewritten to match) all fail — a bounded hypothesis run;
  benchmarks/fuzz_trace_pairing.py is the long one;
* the three lies found by hand fail through the command line with AG609.
"""

from __future__ import annotations

import copy
import json
import re
from functools import lru_cache
from pathlib import Path

import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from agspec.catalogue import load_instance
from agspec.cli.main import cli
from agspec.controllers import CONTROLLERS
from agspec.resources import conformance_dir
from agspec.trace.emission import EMISSION, RESET
from agspec.trace.pairing import pair_records
from trace_lies import PHASES, fix_footer, judge, mutants, reference_trace

ROOT = Path(__file__).resolve().parent.parent
INSTANCES = conformance_dir() / "instances"
SCENARIOS = sorted(p.stem for p in (ROOT / "catalogue" / "scenarios").glob("*.ag"))


# --------------------------------------------------------------------------- the table


def spec_emission_table() -> list[tuple[int, tuple[str, ...], tuple[str, ...], str]]:
    """F-TRACE-EMISSION's rows: (step, rules, event keys in order, order)."""
    text = (ROOT / "spec" / "09-formats.md").read_text(encoding="utf-8")
    block = text[text.index("<!-- EMISSION-TABLE-START -->"):text.index("<!-- EMISSION-TABLE-END -->")]
    rows = []
    for line in block.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) != 4 or not cells[0].isdigit():
            continue
        rules = tuple(re.findall(r"R-[A-Z-]+[A-Z]", cells[1]))
        events = tuple(re.findall(r"`([a-z_]+(?::[a-z]+)?)`", cells[2]))
        rows.append((int(cells[0]), rules, events, cells[3]))
    return rows


def test_f_trace_emission_the_spec_table_is_the_checked_table():
    code = [(s.step, s.rules, s.events, s.order) for s in (RESET,) + EMISSION]
    assert spec_emission_table() == code
    # and the independent copy the lie generator uses agrees on which step emits what
    assert [tuple(sorted(s.events)) for s in EMISSION] == [tuple(sorted(p)) for p in PHASES]


def test_f_trace_emission_a_reordered_spec_table_is_noticed(tmp_path):
    """The comparison above can fail: the table with two steps swapped is not the code's."""
    rows = spec_emission_table()
    swapped = rows[:2] + [rows[3], rows[2]] + rows[4:]
    assert swapped != [(s.step, s.rules, s.events, s.order) for s in (RESET,) + EMISSION]


# --------------------------------------------------------------------------- the reference passes


@lru_cache(maxsize=None)
def catalogue_trace(scenario: str, controller: str, horizon: int) -> tuple:
    return tuple(reference_trace(load_instance(scenario, 0, None), controller, horizon))


@lru_cache(maxsize=None)
def instance_trace(name: str, controller: str) -> tuple:
    inst = json.loads((INSTANCES / f"{name}.json").read_text(encoding="utf-8"))
    return tuple(reference_trace(inst, controller, illegal=0.25, seed=3))


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_f_trace_pairing_the_reference_pairs_on_every_catalogue_scenario(scenario):
    for controller in CONTROLLERS:
        records = list(catalogue_trace(scenario, controller, 70))
        problems, paired = pair_records(records)
        assert problems == [], (controller, problems[:3])
        assert paired == len(records) - 1  # the header and every tick record (not vacuous)


@pytest.mark.parametrize("name", sorted(p.stem for p in INSTANCES.glob("*.json")))
def test_f_trace_pairing_the_reference_pairs_on_every_conformance_instance(name):
    for controller in ("greedy", "illegal"):
        records = list(instance_trace(name, controller))
        assert judge(records) == [], controller
    coerced = [e for r in instance_trace(name, "illegal")[1:] for e in r.get("events") or []
               if e["type"] == "action_coerced"]
    assert coerced  # the illegal actions were made, and paired with `chosen`


@pytest.mark.parametrize("path", sorted((conformance_dir() / "traces").glob("*.jsonl")), ids=lambda p: p.stem)
def test_f_trace_pairing_the_shipped_traces_pass(path):
    result = CliRunner().invoke(cli, ["check", str(path), "--format", "json"])
    out = json.loads(result.output)
    assert result.exit_code == 0 and out["whole_trace"] == [], out["whole_trace"][:3]
    assert out["events_paired_records"] == out["states"] > 0  # every record was paired: not vacuous


# --------------------------------------------------------------------------- lies fail


def lie_sources() -> list[tuple]:
    return [
        instance_trace("xor-2x2-flat", "greedy"), instance_trace("xor-2x2-flat", "illegal"),
        instance_trace("insert4-2x2-flat", "greedy"), instance_trace("solo-1x2-stock-flat", "greedy"),
        instance_trace("duo-1x2-lock2-flat", "illegal"), instance_trace("pair-2x2-official", "greedy"),
        catalogue_trace("coalition-easy", "greedy", 70), catalogue_trace("concurrency-easy", "random", 50),
    ]


@settings(max_examples=100, deadline=None, database=None, suppress_health_check=list(HealthCheck))
@given(source=st.integers(0, 7), rnd=st.randoms(use_true_random=False))
def test_f_trace_pairing_every_generated_lie_fails(source, rnd):
    records = list(lie_sources()[source])
    for m in mutants(records, rnd, 1):
        assert judge(m.records), f"a lie passed `agspec check`: {m.label}"


def _check(tmp_path: Path, records: list[dict]) -> tuple[int, dict]:
    path = tmp_path / "t.jsonl"
    path.write_text("".join(json.dumps(r, sort_keys=True, separators=(",", ":")) + "\n" for r in records),
                    encoding="utf-8")
    result = CliRunner().invoke(cli, ["check", str(path), "--format", "json"])
    return result.exit_code, json.loads(result.output)


def _find(records: list[dict], kind: str) -> tuple[int, int]:
    return next((r, e) for r, rec in enumerate(records) for e, ev in enumerate(rec.get("events") or [])
                if ev["type"] == kind)


@pytest.fixture(scope="module")
def served() -> list[dict]:
    """A trace with handoffs, picks and deliveries of their own record each (official durations)."""
    records = list(catalogue_trace("flow-easy", "greedy", 60))
    assert {e["type"] for r in records[1:-1] for e in r["events"]} >= {"handoff_completed", "delivered"}
    return records


def test_f_trace_pairing_a_dropped_handoff_with_its_footer_lowered_fails(served, tmp_path):
    records = copy.deepcopy(served)
    r, e = _find(records, "handoff_completed")
    del records[r]["events"][e]
    fix_footer(records)  # the footer now agrees with the events
    code, out = _check(tmp_path, records)
    assert code == 1 and out["violations"] == []  # every invariant still holds
    codes = {(d["code"], d["line"]) for d in out["whole_trace"]}
    assert ("AG609", r + 1) in codes  # the record that lost its event
    assert any(d["code"] == "AG605" and d["pointer"] == "/metrics/handoffs" for d in out["whole_trace"])  # states


def test_f_trace_pairing_a_completion_one_record_late_fails(served, tmp_path):
    records = copy.deepcopy(served)
    r, e = _find(records, "pick_completed")
    ev = records[r]["events"].pop(e)
    records[r + 1]["events"].insert(0, ev)
    fix_footer(records)
    code, out = _check(tmp_path, records)
    assert code == 1 and out["violations"] == []
    lines = {d["line"] for d in out["whole_trace"] if d["code"] == "AG609"}
    assert {r + 1, r + 2} <= lines  # the record without it and the record with it


def test_f_trace_pairing_a_doubled_delivery_fails(served, tmp_path):
    records = copy.deepcopy(served)
    r, e = _find(records, "delivered")
    records[r]["events"].insert(e + 1, dict(records[r]["events"][e]))
    fix_footer(records)
    code, out = _check(tmp_path, records)
    assert code == 1
    (d,) = [d for d in out["whole_trace"] if d["code"] == "AG609"]
    assert d["line"] == r + 1 and d["pointer"] == f"/events/{e + 1}" and "completed already" in d["message"]


def test_f_trace_pairing_the_text_report_says_what_disagrees(served, tmp_path):
    records = copy.deepcopy(served)
    r, e = _find(records, "delivered")
    del records[r]["events"][e]
    path = tmp_path / "t.jsonl"
    path.write_text("".join(json.dumps(x) + "\n" for x in records), encoding="utf-8")
    result = CliRunner().invoke(cli, ["check", str(path)])
    assert result.exit_code == 1
    assert f"t.jsonl:{r + 1}: error[AG609]" in result.output and "no completion event" in result.output


# --------------------------------------------------------------------------- emission order, by example


def test_f_trace_emission_a_switch_to_a_new_record_emits_switched_created_support():
    """R-SUPPORT: the three events of one robot, contiguous and in that order, before any admission."""
    seen = 0
    for scenario in ("coalition-easy", "coalition-medium", "geometry-matched-low"):
        for rec in catalogue_trace(scenario, "random", 90)[1:-1]:
            events = rec["events"]
            for i, ev in enumerate(events):
                if ev["type"] != "support_switched":
                    continue
                if ev["to"] in rec_proposals_before(scenario, rec) or any(
                        x["type"] == "proposal_created" and x["candidate"] == ev["to"] for x in events[:i]):
                    assert [x["type"] for x in events[i:i + 2]] == ["support_switched", "support"]
                    continue  # a record of the new candidate exists: no proposal_created
                assert [x["type"] for x in events[i:i + 3]] == ["support_switched", "proposal_created", "support"]
                assert events[i + 1]["candidate"] == events[i + 2]["candidate"] == ev["to"]
                assert events[i + 2]["robot"] == ev["robot"]
                assert not any(x["type"] == "admitted" for x in events[:i])
                seen += 1
    assert seen > 0


def rec_proposals_before(scenario: str, rec: dict) -> dict:
    records = catalogue_trace(scenario, "random", 90)
    index = next(i for i, r in enumerate(records) if r is rec)
    return records[index - 1]["state"]["proposals"]


def test_f_trace_pairing_records_without_events_are_judged_on_states_only(served, tmp_path):
    """`events: null` (an implementation without the events capability, F-TRACE): nothing to pair."""
    records = copy.deepcopy(served)
    for rec in records[:-1]:
        rec["events"] = None
    records[-1]["metrics"] = {}
    assert pair_records(records) == ([], 0)
    code, out = _check(tmp_path, records)
    assert code == 0 and out["whole_trace"] == [] and out["diagnostics"] == []
    assert out["events_paired_records"] == 0  # and the report says nothing was paired
