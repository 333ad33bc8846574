"""The interpreter's memos are caches, not state: a run with them is byte for byte a run without them.

``Model.realized`` (R-CANDIDATES realizations) and ``Model.plans`` (G-MOTION plans) are keyed by
everything the remembered function reads.  A key missing an input would hand an epoch a candidate or
plan computed for other poses or holders; the traces below (states, events, observation records
and masks of every epoch, metrics) would then differ from the unmemoized run's.
"""

from __future__ import annotations

import io

import pytest

from agspec.catalogue import load_instance
from agspec.controllers import make_controller
from agspec.evaluate import run_episode
from agspec.formats.trace import TraceWriter
from agspec.interp import candidates, geometry
from agspec.interp.tick import Simulator

CELLS = [("coalition-medium", "random"), ("concurrency-hard", "greedy"), ("flow-hard", "centralized"),
         ("coalition-easy", "parallel-aware")]


def _trace(scenario: str, controller: str, ticks: int = 150) -> str:
    buf = io.StringIO()
    run_episode(load_instance(scenario, index=1000), controller, horizon=ticks, trace=TraceWriter(buf),
                observations_in_trace=True)
    return buf.getvalue()


def _unmemoized(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(candidates, "realized", lambda state, model, product, op, members, holders, holder_of:
                        candidates.realize(state, model, product, op, members, holders, holder_of))
    monkeypatch.setattr(geometry.PlanMemo, "plan", lambda self, members, process, common_target:
                        geometry.plan_activity(members, process, self.profile, common_target=common_target))


@pytest.mark.parametrize("scenario,controller", CELLS)
def test_memoized_run_is_the_unmemoized_run(scenario, controller, monkeypatch):
    memoized = _trace(scenario, controller)
    with monkeypatch.context() as m:
        _unmemoized(m)
        plain = _trace(scenario, controller)
    assert memoized == plain


def test_a_realization_memo_that_ignores_poses_is_caught(monkeypatch):
    """The seeded mutant: a key without the members' poses reuses stale plans and changes the trace."""
    plain = _trace("coalition-medium", "random")
    memo: dict = {}

    def stale(state, model, product, op, members, holders, holder_of):
        key = (product.pid, op.id, members)  # BUG: the poses and holders are not part of the key
        if key not in memo:
            memo[key] = candidates.realize(state, model, product, op, members, holders, holder_of)
        return memo[key]

    monkeypatch.setattr(candidates, "realized", stale)
    assert _trace("coalition-medium", "random") != plain


def test_the_realization_memo_is_bounded(monkeypatch):
    """Past REALIZED_LIMIT entries the memo starts over; the run is unchanged."""
    monkeypatch.setattr(candidates, "REALIZED_LIMIT", 5)
    sim = Simulator(load_instance("coalition-medium", index=1000))
    controller = make_controller("random")
    controller.reset(0)
    sizes = []
    for _ in range(150):
        sim.step(controller.act(sim.observe()))
        sizes.append(len(sim.model.realized))
    assert max(sizes) <= 5 and max(sizes) > 0
    buf = io.StringIO()
    run_episode(load_instance("coalition-medium", index=1000), "random", horizon=150, trace=TraceWriter(buf),
                observations_in_trace=True)
    assert buf.getvalue() == _trace("coalition-medium", "random")
