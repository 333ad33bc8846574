"""The decision snapshot that reuses the previous epoch's parts is the snapshot built from scratch.

``Simulator._enter_epoch`` keeps the previous epoch's candidates when the transition started,
completed and released nothing (R-CANDIDATES reads nothing else that changes), and hands out the
previous epoch's option lists and masks where they are equal (R-TICK-ORDER step 1, O-MASK).  At
every epoch of masked random episodes, on the official cells and on generated scenarios of every
topology and variant, the snapshot must equal R-CANDIDATES, O-OPERATION-OPTIONS and O-MASK computed
afresh from the state; a snapshot that reuses candidates after a change (the seeded mutant) must not.
"""

from __future__ import annotations

import random

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from agspec.catalogue import load_instance
from agspec.interp.candidates import build_candidates
from agspec.interp.geometry import PlanMemo
from agspec.interp.observe import IDLE, SlotOverflow, action_mask, build_options
from agspec.interp.tick import Simulator
from strategies_scenarios import bundles


def _stale_parts(sim: Simulator) -> list[str]:
    """What of the decision snapshot differs from the one built afresh from the state (empty: none)."""
    state, model, d = sim.state, sim.model, sim.decision
    memos = model.realized, model.plans
    model.__dict__["realized"], model.__dict__["plans"] = {}, PlanMemo(model.profile)  # afresh, memos empty
    try:
        candidates, rejected = build_candidates(state, model)
    finally:
        model.__dict__["realized"], model.__dict__["plans"] = memos
    options = build_options(state, model, candidates)
    out = []
    if d.candidates != candidates or d.rejected != rejected:
        out.append("candidates")
    if d.by_id != {c.cid: c for c in candidates}:
        out.append("by_id")
    out += [f"options {c}" for c in model.cells if d.options[c] != options[c]]
    out += [f"mask {c}" for c in model.cells if d.masks[c] != action_mask(state, model, c, options[c])]
    return out


def _random_episode(sim: Simulator, seed: int, ticks: int) -> list[str]:
    """Masked random actions (idle half the time, so quiet epochs occur); the stale parts, by epoch."""
    rng = random.Random(seed)
    problems = []
    for _ in range(ticks):
        problems += [f"t={sim.t}: {p}" for p in _stale_parts(sim)]
        if sim.done:
            break
        joint = []
        for c in sim.model.cells:
            legal = [a for a, ok in enumerate(sim.decision.masks[c]) if ok]
            joint.append(IDLE if rng.random() < 0.5 else rng.choice(legal))
        sim.step(joint)
    return problems


@pytest.mark.parametrize("scenario", ["coalition-medium", "concurrency-hard", "flow-hard", "coalition-easy"])
def test_the_reused_snapshot_is_the_fresh_one_on_the_official_cells(scenario):
    sim = Simulator(load_instance(scenario, index=1000), capacity=False)
    assert _random_episode(sim, 0, 200) == []


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(bundles(), st.integers(0, 2**16))
def test_the_reused_snapshot_is_the_fresh_one_on_generated_scenarios(bundle, seed):
    """Every topology, radius and rule variant; two episodes (the second after a reset)."""
    for episode in range(2):
        try:
            sim = Simulator(bundle.instance)
            sim.reset()
            assert _random_episode(sim, seed + episode, 40) == [], bundle.describe()
        except SlotOverflow:  # O-ACTION-ENCODING: the reference refuses such a state; nothing to compare
            continue


def test_a_snapshot_that_keeps_stale_candidates_is_caught(monkeypatch):
    """The seeded mutant: candidates kept across a transition that completed something."""
    enter = Simulator._enter_epoch

    def stale(self, candidates_unchanged=False, **_):
        enter(self, candidates_unchanged=self.state.t > 1)  # BUG: ignores what the transition changed

    monkeypatch.setattr(Simulator, "_enter_epoch", stale)
    sim = Simulator(load_instance("coalition-medium", index=1000), capacity=False)
    assert any("candidates" in p for p in _random_episode(sim, 0, 200))


def test_surviving_candidates_that_keep_committed_members_are_caught(monkeypatch):
    """The seeded mutant of the only-commitments path: the previous candidates are kept whole, also
    those with a member that the transition committed to a pick, handoff or delivery."""
    from agspec.interp import tick

    monkeypatch.setattr(tick, "surviving_candidates", lambda state, candidates: list(candidates))  # BUG: no filter
    sim = Simulator(load_instance("concurrency-hard", index=1000), capacity=False)
    assert any("candidates" in p for p in _random_episode(sim, 0, 200))


def test_a_snapshot_that_keeps_stale_readiness_is_caught(monkeypatch):
    """The seeded mutant of the kept R-READY list: kept also after admissions and completed operations."""
    enter = Simulator._enter_epoch

    def stale(self, candidates_unchanged=False, only_commitments=False, ready_unchanged=False):
        enter(self, candidates_unchanged, only_commitments, ready_unchanged=self.state.t > 1)  # BUG

    monkeypatch.setattr(Simulator, "_enter_epoch", stale)
    sim = Simulator(load_instance("coalition-medium", index=1000), capacity=False)
    assert any("candidates" in p for p in _random_episode(sim, 0, 200))
