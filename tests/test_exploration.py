"""Exploration reaches what the suite reaches (F-DIFF-ACTIONS, F-CONFORM horizon, F-POLICY-DETERMINISM).

* ``agspec diff`` sends illegal and out-of-range actions at a stated rate: the generator is the family
  of simulators that mishandle R-ACTION-VALIDATION (tests/fakes/scripted_sim.py ``--coercion``:
  coercing without ``action_coerced``, only for out-of-range or only for masked actions, or with the
  wrong ``action``) — each is a divergence, where legal-only streams found none;
"""

from __future__ import annotations

import json
import shlex
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

from agspec.catalogue import load_scenario_bundle
from agspec.cli.main import cli
from agspec.conform.policies import GENE_RANGE, OUT_OF_RANGE, ControllerPolicy, GenePolicy, IllegalActions
from agspec.interp.tick import Simulator
from agspec.ir.instance import make_instance

HERE = Path(__file__).resolve().parent
SIM = HERE / "fakes" / "scripted_sim.py"
COERCIONS = ("silent", "silent-range", "silent-masked", "wrong-action")


def _diff(spec: str, tmp: Path, *extra: str) -> tuple[int, dict]:
    result = CliRunner().invoke(cli, ["diff", "--impl", "reference", "--impl", spec, "--scenario", "flow-easy",
                                      "--small", "0", "--ticks", "30", "--shrink-budget", "0", "--format", "json",
                                      "--out", str(tmp / "out"), *extra])
    return result.exit_code, json.loads(result.stdout)


@pytest.mark.parametrize("coercion", COERCIONS)
def test_diff_finds_a_simulator_that_mishandles_illegal_actions(coercion, tmp_path):
    spec = shlex.join([sys.executable, str(SIM), "--coercion", coercion])
    code, report = _diff(spec, tmp_path)
    assert code == 1, report
    assert report["illegal_rate"] == 0.05
    (finding,) = report["findings"]
    assert finding["divergence"]["where"] in ("events", "state"), finding


def test_legal_only_streams_do_not_see_it(tmp_path):
    """The class the default rate closes: with --illegal-rate 0 the same simulator is "conformant"."""
    spec = shlex.join([sys.executable, str(SIM), "--coercion", "silent"])
    code, report = _diff(spec, tmp_path, "--illegal-rate", "0")
    assert code == 0 and report["findings"] == [] and report["illegal_rate"] == 0


def _sim():
    sc, recipes, profile = load_scenario_bundle("flow-easy")
    sim = Simulator(make_instance(sc, recipes, profile, index=0))
    sim.reset(None)
    return sim


def test_illegal_actions_come_at_the_stated_rate_and_are_illegal():
    sim = _sim()
    robots = sorted(sim.agents())
    policy = IllegalActions(ControllerPolicy("greedy", 1), 0.25, seed=3)
    policy.reset()
    illegal = total = 0
    for t in range(40):
        obs = sim.observe()
        joint = policy.act(t, obs, robots)
        for robot in robots:
            total += 1
            a = joint.get(robot, 0)
            mask = obs[robot]["mask"]
            if not 0 <= a < len(mask) or not mask[a]:
                illegal += 1
                assert a in OUT_OF_RANGE or not mask[a]
        sim.step(joint)
    assert 0.15 < illegal / total < 0.35
    twins = [IllegalActions(ControllerPolicy("random", 2), 0.5, 9) for _ in range(2)]  # deterministic per seed
    for p in twins:
        p.reset()
    obs = _sim().observe()
    assert twins[0].act(0, obs, robots) == twins[1].act(0, obs, robots)


def test_hypothesis_genes_map_their_top_range_to_illegal_actions():
    sim = _sim()
    robots = sorted(sim.agents())
    obs = sim.observe()
    top = GenePolicy([[GENE_RANGE - 1] * len(robots)], illegal_rate=0.1).act(0, obs, robots)
    assert all(not 0 <= a < 114 or not obs[r]["mask"][a] for r, a in top.items()) and top
    legal = GenePolicy([[GENE_RANGE - 1] * len(robots)], illegal_rate=0.0).act(0, obs, robots)
    assert all(obs[r]["mask"][a] for r, a in legal.items())
