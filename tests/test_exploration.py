"""Exploration reaches what the suite reaches (F-DIFF-ACTIONS, F-CONFORM horizon, F-POLICY-DETERMINISM).

* ``agspec diff`` sends illegal and out-of-range actions at a stated rate: the generator is the family
  of simulators that mishandle R-ACTION-VALIDATION (tests/fakes/scripted_sim.py ``--coercion``:
  coercing without ``action_coerced``, only for out-of-range or only for masked actions, or with the
  wrong ``action``) — each is a divergence, where legal-only streams found none;
* ``agspec conform`` runs catalogue episodes over their whole horizon by default: the generator is the
  family of liars wrong only from epoch T on (``--wrong-at T``), T anywhere in the horizon — each
  fails a default run, and a run cut short by ``--ticks`` says how much of the horizon it checked;
* ``agspec evaluate`` repeats an in-process policy's episode in a fresh process: the generator is the
  family of policies that pick by something fixed within a process and different between processes
  (``hash()``, the order of a set of strings, the pid, a draw at import; tests/fakes/policies.py) —
  each is reported nondeterministic, a deterministic policy is not.
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
from agspec.conform.lockstep.actions import GENE_RANGE, OUT_OF_RANGE, ControllerPolicy, GenePolicy, IllegalActions
from agspec.interp.tick import Simulator
from agspec.ir.instance import make_instance

HERE = Path(__file__).resolve().parent
SIM = HERE / "fakes" / "scripted_sim.py"
COERCIONS = ("silent", "silent-range", "silent-masked", "wrong-action")


def _diff(spec: str, tmp: Path, *extra: str) -> tuple[int, dict]:
    result = CliRunner().invoke(cli, ["diff", "--impl", "reference", "--impl", spec, "--scenario", "flow-easy",
                                      "--small", "0", "--horizon", "30", "--shrink-budget", "0", "--format", "json",
                                      "-o", str(tmp / "out"), *extra])
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


# --------------------------------------------------------------------------- the whole horizon (RES-CONFORM-HORIZON)


def _conform(spec: str, tmp: Path, *extra: str) -> tuple[int, dict]:
    result = CliRunner().invoke(cli, ["conform", "--impl", spec, "--no-suite", "--episodes", "1", "-k",
                                      "e-flow-easy-greedy", "--format", "json", "--golden-cache", "off",
                                      "--repro-dir", str(tmp / "repro"), *extra])
    return result.exit_code, json.loads(result.stdout)


@pytest.mark.parametrize("wrong_from", [1, 100, 250, 399])
def test_a_liar_wrong_late_in_the_horizon_fails_a_default_run(wrong_from, tmp_path):
    spec = shlex.join([sys.executable, str(SIM), "--wrong-at", str(wrong_from)])
    code, out = _conform(spec, tmp_path)
    assert code == 1, out["footer"]["verdict"]
    (record,) = out["results"]
    assert record["failure"]["tick"] == wrong_from
    assert out["footer"]["horizon"] == {"flow-easy": {"episodes": 1, "ticks": wrong_from + 1, "horizon": 400}}


def test_a_run_cut_short_says_how_much_of_the_horizon_it_checked(tmp_path):
    spec = shlex.join([sys.executable, str(SIM), "--wrong-at", "100"])
    code, out = _conform(spec, tmp_path, "--horizon", "60")
    assert code == 0
    assert out["footer"]["horizon"] == {"flow-easy": {"episodes": 1, "ticks": 60, "horizon": 400}}
    assert "checked 60 of 400 horizon ticks" in out["footer"]["verdict"]


# --------------------------------------------------------------------------- policies repeat in a fresh process


def _repeated(factory: str) -> list[dict]:
    pytest.importorskip("pettingzoo", reason="the MARL extra is not installed: pip install 'agspec[marl]'")
    from agspec.catalogue import load_instance
    from agspec.evaluate import Job, run_job
    from agspec.policy.contract import parse_policy

    inst = load_instance("coalition-easy", 0)
    inst["scenario"]["evaluation"]["horizon"] = 20
    spec = parse_policy(factory)
    return [run_job(Job("coalition-easy", 0, spec, inst)), run_job(Job("coalition-easy", 0, spec, inst, repeat=True))]


PROCESS_DEPENDENT = ("by_hash", "by_set_order", "by_pid", "by_process_draw")


@pytest.mark.parametrize("factory", PROCESS_DEPENDENT)
def test_a_policy_that_depends_on_its_process_is_nondeterministic(factory):
    from agspec.cli.evaluate_view import nondeterminism

    first, repeat = _repeated(f"{HERE / 'fakes' / 'policies.py'}:{factory}")
    assert first["status"] == repeat["status"] == "ok", (first.get("error"), repeat.get("error"))
    assert repeat["repeat"] is True
    (found,) = nondeterminism([first, repeat])
    assert "nondeterministic policy" in found["message"]


def test_a_deterministic_policy_repeats_itself_in_a_fresh_process():
    from agspec.cli.evaluate_view import nondeterminism

    first, repeat = _repeated(f"{HERE.parent / 'examples' / 'policies' / 'heuristic.py'}:make_policy")
    assert repeat["status"] == "ok" and nondeterminism([first, repeat]) == []
