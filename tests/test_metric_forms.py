"""M-RATIO-FORMS: ratios are computed in the arithmetic form the spec states (bit for bit)."""

from __future__ import annotations

from agspec.catalogue import load_scenario_bundle
from agspec.interp.metrics import CapacitySnapshot, MetricsAccumulator
from agspec.interp.tick import Simulator
from agspec.ir.instance import make_instance


def accumulator() -> tuple[MetricsAccumulator, Simulator]:
    sc, recipes, profile = load_scenario_bundle("flow-easy")
    sim = Simulator(make_instance(sc, recipes, profile, index=0))
    sim.reset(0)
    return MetricsAccumulator(sim.model), sim


def test_blocked_ready_rate_material_is_ready_minus_feasible_over_ready():
    # 1 - 1/3 and (3 - 1)/3 differ in the last bit: the original's form is the latter
    assert 1 - 1 / 3 != (3 - 1) / 3
    acc, sim = accumulator()
    snap = CapacitySnapshot(k_star=0, running=0, exact=True)
    acc.pre_action(snap, n_ready=3, n_ready_material=3, n_feasible=1)
    acc.sample(sim.state)
    got = acc.final(sim.state)
    assert got["blocked_ready_rate_material"] == (3 - 1) / 3
    assert got["blocked_ready_rate"] == 1 - 1 / 3  # the paper's BR = 1 - RF (M-RF-BR)
    assert got["ready_feasible_fraction"] == 1 / 3
