"""Chapter 07 metrics recomputed from a reference trace's own records (an oracle independent of the
interpreter's accumulator): the footer of each suite trace must agree with its states and events."""

from __future__ import annotations

from pathlib import Path

import pytest

from agspec.formats.trace import read_records
from agspec.resources import conformance_dir

TRACES = sorted((conformance_dir() / "traces").glob("*.jsonl"))


def load(path: Path):
    records = read_records(path)
    ticks = [r for r in records if r["type"] == "tick"]
    events = [e for r in ticks for e in r["events"]]
    return records[0], ticks, events, records[-1]["metrics"]


@pytest.mark.parametrize("path", TRACES, ids=lambda p: p.stem)
def test_outcome_measures_follow_from_the_trace(path):
    _, ticks, events, m = load(path)
    final = ticks[-1]["state"]
    t_end = len(ticks)
    products = final["products"]
    delivered = [p for p in products if p["delivered_at"] is not None]
    lost = sum(1 for e in events if e["type"] == "release_lost")
    assert m["delivered"] == final["delivered"] == len(delivered)  # M-DELIVERED
    assert m["throughput"] == len(delivered) / t_end  # M-THROUGHPUT
    assert m["completion_rate"] == final["delivered"] / final["released"]  # M-COMPLETION
    assert m["unfinished_count"] == final["released"] - final["delivered"]
    assert m["lost_releases"] == final["lost_releases"] == lost  # M-LOST-RELEASES
    assert m["release_opportunities"] == final["released"] + lost
    assert m["release_acceptance"] == final["released"] / (final["released"] + lost)  # M-RELEASE-ACCEPTANCE
    assert m["demand_fulfillment"] == final["delivered"] / (final["released"] + lost)  # M-DEMAND-FULFILLMENT
    assert m["mean_wip"] == sum(r["state"]["wip"] for r in ticks) / t_end  # M-MEAN-WIP
    terms = [(p["delivered_at"] if p["delivered_at"] is not None else t_end) - p["released_at"] for p in products]
    assert m["restricted_mean_flow_time"] == sum(terms) / len(terms)  # M-RMFT
    flow = [p["delivered_at"] - p["released_at"] for p in delivered]
    assert m["mean_flow_time"] == (sum(flow) / len(flow) if flow else None)  # M-FLOW-TIME
    assert m["makespan"] is None  # M-MAKESPAN: continuing production has none


@pytest.mark.parametrize("path", TRACES, ids=lambda p: p.stem)
def test_admission_and_blocking_counts_follow_from_the_events(path):
    header, _, events, m = load(path)
    admitted = sum(1 for e in events if e["type"] == "admitted")
    assert m["admissions"] == admitted  # M-ADMISSIONS
    total = m["admissions"] + m["admission_failures"]
    assert m["admission_success"] == (m["admissions"] / total if total else None)  # M-ADM-SUCCESS
    blocked = [e for e in events if e["type"] == "blocked"]
    assert m["blocked_activities"] == len(blocked)  # M-BLOCKED
    assert m["geometry_blocked"] + m["resource_blocked"] + m["robot_blocked"] == len(blocked)
    handoffs = sum(1 for e in events if e["type"] == "handoff_completed")
    assert m["handoffs"] == handoffs and m["handoffs_per_delivered"] == handoffs / max(1, m["delivered"])  # M-HANDOFFS
    if header["instance"]["scenario"]["family"] == "coalition":  # M-COALITION: every team has >= 2 robots
        assert (m["coalition_admissions"], m["coalition_success"]) == (m["admissions"], m["admission_success"])
