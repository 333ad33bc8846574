"""The PettingZoo adapter (spec/12-adapters.md, A-PZ-*): official checkers on every official scenario,
fidelity to the interpreter, the A-OBS-VECTOR encoding, the coalition_milestone_v1 reward, determinism."""

from __future__ import annotations

import hashlib
import subprocess
import sys
import textwrap

import numpy as np
import pytest

pettingzoo = pytest.importorskip("pettingzoo", reason="the MARL extra is not installed: pip install 'agspec[marl]'")
from pettingzoo.test import parallel_api_test, parallel_seed_test  # noqa: E402

from agspec.catalogue import OFFICIAL_SCENARIOS  # noqa: E402
from agspec.controllers import make_controller  # noqa: E402
from agspec.evaluate import run_episode  # noqa: E402
from agspec.interp.observe import N_ACTIONS  # noqa: E402
from agspec.marl.encoding import OBS_DIM, PublicInfo, encode_observation, state_dim, str_hash  # noqa: E402
from agspec.marl.rewards import MilestoneTerms, support_credit  # noqa: E402
from agspec.pettingzoo import AdapterError, coalition_milestone_v1, parallel_env  # noqa: E402


def random_episode(env, seed: int, steps: int | None = None):
    """Masked random actions from the seeded action spaces; yields (obs, rewards, infos) per step."""
    obs, infos = env.reset(seed=seed)
    n = 0
    while env.agents and (steps is None or n < steps):
        actions = {a: env.action_space(a).sample(mask=obs[a]["action_mask"]) for a in env.agents}
        obs, rewards, terms, truncs, infos = env.step(actions)
        n += 1
        yield obs, rewards, terms, truncs, infos


# --------------------------------------------------------------------------- official checkers


@pytest.mark.parametrize("scenario", OFFICIAL_SCENARIOS)
def test_parallel_api_test_passes_on_every_official_scenario(scenario):
    """A-PZ-ENV: PettingZoo's own API checker, two full 400-tick episodes of masked random play."""
    env = parallel_env(scenario, index=1000)
    parallel_api_test(env, num_cycles=1000)
    assert env.agents == []  # the episode ran to its horizon and every agent left (A-PZ-STEP)
    assert env.sim.t == env.sim.model.horizon


@pytest.mark.parametrize("scenario", OFFICIAL_SCENARIOS)
def test_parallel_seed_test_passes_on_every_official_scenario(scenario):
    parallel_seed_test(lambda: parallel_env(scenario, index=1000), num_cycles=50)


@pytest.mark.parametrize("scenario", ["coalition-medium", "concurrency-hard", "flow-easy"])
def test_the_milestone_wrapper_passes_the_api_test(scenario):
    parallel_api_test(coalition_milestone_v1(parallel_env(scenario, index=1000)), num_cycles=60)


# --------------------------------------------------------------------------- spaces and observations


def test_spaces_observations_and_masks_match_the_interpreter():
    env = parallel_env("coalition-medium", index=1000)
    obs, infos = env.reset(seed=0)
    assert env.possible_agents == [f"{i},{j}" for i in range(5) for j in range(6)]  # R-IDS, row-major
    for agent in env.agents:
        assert env.action_space(agent).n == N_ACTIONS
        assert env.observation_space(agent)["observation"].shape == (OBS_DIM,) == (1566,)
        assert obs[agent] in env.observation_space(agent)
        np.testing.assert_array_equal(infos[agent]["action_mask"], obs[agent]["action_mask"])
    for obs, *_ in random_episode(env, seed=5, steps=40):
        pass
    masks = env.sim.masks()  # O-MASK of the interpreter, after 40 ticks
    for agent in env.agents:
        assert obs[agent]["action_mask"].tolist() == [int(b) for b in masks[agent]]
        assert obs[agent] in env.observation_space(agent)
    assert env.state().shape == env.state_space.shape == (state_dim(env.sim.model),)
    assert env.state() in env.state_space


def test_illegal_actions_are_executed_as_idle_and_counted():
    """R-ACTION-VALIDATION through the adapter: a masked action idles the robot and is counted."""
    env = parallel_env("coalition-medium", index=1000)
    obs, _ = env.reset(seed=0)
    illegal = {a: int(np.flatnonzero(obs[a]["action_mask"] == 0)[0]) for a in env.agents}
    _, _, _, _, infos = env.step(illegal)
    assert all(infos[a]["applied_action"] == 0 for a in env.agents)
    assert env.sim.state.counters["unmasked_invalid_attempts"] == len(env.agents)


def _corner_observation():
    env = parallel_env("coalition-medium", index=1000)
    env.reset(seed=0)
    o = env.sim.observe("0,0")
    return env, o


def test_observation_vector_encodes_the_structured_observation():
    """A-OBS-VECTOR: blocks at their documented offsets, values in [0, 1]."""
    env, o = _corner_observation()
    pub = PublicInfo.of(env.sim.model)
    v = encode_observation(o, pub)
    assert v.shape == (1566,) and v.dtype == np.float32 and v.min() >= 0.0 and v.max() <= 1.0
    assert v[0] == 1.0 and v[1:4].sum() == 0  # holds nothing
    present = [v[12 + 10 * d] for d in range(8)]
    assert present == [0, 0, 1, 1, 1, 0, 0, 0]  # corner (0,0): only E, SE, S exist
    assert v[92] == len(o["pick_options"]) / 32 and v[93] == len(o["operation_options"]) / 64
    assert v[94] == 0.0  # no pick option here: slot 0 is empty
    pickers = [o for o in env.sim.observe().values() if o["pick_options"]]
    assert pickers, "a released product must be pickable by some left-column robot at t = 0"
    first_pick = pickers[0]["pick_options"][0]
    w = encode_observation(pickers[0], pub)
    assert w[94] == 1.0 and w[95] == pytest.approx(str_hash(first_pick["token"]))
    assert w[97] == pytest.approx(first_pick["stock"])
    # the vector is a function of the observation only: a changed holding changes exactly the self block
    o2 = dict(o, holding={"product": 0, "token": "A", "final": False})
    v2 = encode_observation(o2, pub)
    changed = np.flatnonzero(v != v2)
    assert set(changed) == {0, 1}


def test_operation_slots_carry_support_members_and_own_pending_support():
    env = parallel_env("coalition-medium", index=1000)
    pub = PublicInfo.of(env.sim.model)
    obs, _ = env.reset(seed=0)
    ctl = make_controller("greedy")
    ctl.reset(0)
    for _ in range(120):  # play the greedy reference until some robot has an operation option
        structured = env.sim.observe()
        rich = [r for r, o in structured.items() if o["operation_options"]]
        if rich:
            break
        env.step(ctl.act(structured))
    assert rich, "greedy play produced no operation option in 120 ticks"
    o = env.sim.observe(rich[0])
    v = encode_observation(o, pub)
    op0 = 12 + 80 + 2 + 32 * 6
    first = o["operation_options"][0]
    assert v[op0] == 1.0
    assert v[op0 + 4] == pytest.approx(first["size"] / 4)
    assert v[op0 + 8] == pytest.approx(first["support"])
    assert v[op0 + 12] == pytest.approx(0.5 + (int(first["members"][0].split(",")[0]) - int(rich[0].split(",")[0])) / 8)
    assert v[op0 + 20 * len(o["operation_options"])] == 0.0  # first unused slot is empty


# --------------------------------------------------------------------------- fidelity and determinism


@pytest.mark.parametrize("scenario,controller", [("coalition-medium", "greedy"), ("concurrency-easy", "parallel-aware")])
def test_the_adapter_does_not_change_the_dynamics(scenario, controller):
    """A reference controller driven through the env gives exactly the metrics of agspec run
    (with ``capacity=True``, A-PZ-CAPACITY: the M-CAPACITY samples an evaluation reports)."""
    env = parallel_env(scenario, index=1000, capacity=True)
    env.reset(seed=env.instance["seeds"]["execution"])
    ctl = make_controller(controller)
    ctl.reset(env.instance["seeds"]["execution"])
    delivered = 0.0
    while env.agents:
        _, rewards, _, _, _ = env.step(ctl.act(env.sim.observe()))
        delivered += rewards["0,0"]  # A-REWARD-SPARSE: every agent gets the delivered value
    expected = run_episode(env.instance, controller).metrics
    assert env.final_metrics() == expected
    assert delivered == expected["delivered"] > 0


def test_capacity_is_computed_only_when_asked_for(monkeypatch):
    """A-PZ-CAPACITY: a plain env never solves M-CAPACITY; its other measures are agspec run's and the
    measures of the samples it did not take are null; ``capacity=True`` takes them."""
    import agspec.interp.tick as tick
    from agspec.interp.metrics import CAPACITY_MEASURES

    calls = []
    real = tick.capacity_snapshot
    monkeypatch.setattr(tick, "capacity_snapshot", lambda *a, **k: calls.append(1) or real(*a, **k))
    env = parallel_env("coalition-medium", index=1000)
    env.reset(seed=env.instance["seeds"]["execution"])
    ctl = make_controller("greedy")
    ctl.reset(env.instance["seeds"]["execution"])
    while env.agents:
        env.step(ctl.act(env.sim.observe()))
    assert calls == []
    expected = run_episode(env.instance, "greedy").metrics
    got = env.final_metrics()
    assert set(got) == set(expected) and expected["capacity_mean"] > 0
    assert {k: v for k, v in got.items() if k not in CAPACITY_MEASURES} == \
        {k: v for k, v in expected.items() if k not in CAPACITY_MEASURES}
    assert all(got[k] is None for k in CAPACITY_MEASURES)
    asked = parallel_env("coalition-medium", index=1000, capacity=True)
    asked.reset(seed=0)
    calls.clear()
    asked.step({})
    assert len(calls) == 1


def _stream_digest(scenario: str, seed: int, steps: int) -> str:
    h = hashlib.sha256()
    env = parallel_env(scenario, index=1000)
    for obs, rewards, _, _, _ in random_episode(env, seed, steps):
        for a in sorted(obs):
            h.update(obs[a]["observation"].tobytes())
            h.update(obs[a]["action_mask"].tobytes())
            h.update(np.float64(rewards[a]).tobytes())
        h.update(env.state().tobytes())
    return h.hexdigest()


def test_same_seed_same_stream_across_processes():
    """D-DETERMINISM through the adapter: identical bytes in this process and in a fresh one."""
    here = _stream_digest("coalition-hard", 11, 80)
    assert here == _stream_digest("coalition-hard", 11, 80)
    code = textwrap.dedent("""
        import sys
        sys.path.insert(0, "tests")
        from test_pettingzoo import _stream_digest
        print(_stream_digest("coalition-hard", 11, 80))
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env={"PYTHONHASHSEED": "123", "PATH": ""}, cwd=str(__import__("pathlib").Path(__file__).parents[1]))
    assert out.stdout.strip() == here
    assert _stream_digest("coalition-hard", 12, 80) != here  # the seed drives the sampled actions


def test_reset_options_switch_the_instance():
    env = parallel_env("flow-easy", index=1000)
    env.reset(seed=0)
    first = env.instance["id"]
    env.reset(seed=0, options={"instance": 1001})
    assert env.instance["id"] != first and env.instance["id"].endswith("1001")
    env.reset(options={"instance": parallel_env("flow-easy", index=1002).instance})
    assert env.instance["id"].endswith("1002")
    with pytest.raises(AdapterError, match="options\\['instance'\\]"):
        env.reset(options={"instance": 1.5})
    with pytest.raises(AdapterError, match="grid size"):
        env.reset(options={"instance": parallel_env("coalition-hard", index=0).instance})


# --------------------------------------------------------------------------- rewards


def test_milestone_terms_add_up_to_the_episode_counters():
    """A-REWARD-MILESTONE counts come from events; the interpreter's counters are bumped elsewhere."""
    env = coalition_milestone_v1(parallel_env("coalition-medium", index=1000), support_credit="agent")
    base = env.unwrapped
    env.reset(seed=0)
    ctl = make_controller("greedy")
    ctl.reset(0)
    totals = dict.fromkeys(["progress", "coalition", "operation", "delivery", "failure", "churn"], 0)
    reward_sum, steps, credits = 0.0, 0, 0
    while env.agents:
        _, rewards, _, _, infos = env.step(ctl.act(base.sim.observe()))
        terms = infos["0,0"]["milestone"]
        for k in totals:
            totals[k] += terms[k]
        credits += sum(i["support_credit"] for i in infos.values())
        team = MilestoneTerms(**terms).team_reward()
        for a, r in rewards.items():
            assert r == pytest.approx(team + 0.05 * infos[a]["support_credit"])
        reward_sum += rewards["0,0"]
        steps += 1
    c = base.sim.state.counters
    m = base.final_metrics()
    assert totals["delivery"] == m["delivered"] > 0
    assert totals["progress"] == c["progress_events"]
    assert totals["coalition"] == c["team_formation_count"] > 0
    assert totals["failure"] == c.get("team_formation_failures", 0)
    assert totals["churn"] == c.get("team_proposal_churn", 0)
    assert totals["operation"] > 0 and credits > 0
    assert steps == 400


def test_support_credit_rules():
    before = {"a": False, "b": True, "c": False, "d": True}
    after = {"a": True, "b": True, "c": False, "d": False}
    # only a new pending support earns credit: a switch (b) or an admission in the same tick (c) does not
    assert support_credit(before, after) == {"a": 1, "b": 0, "c": 0, "d": 0}


def test_team_reward_coefficients():
    terms = MilestoneTerms(progress=3, coalition=1, operation=2, delivery=1, failure=2, churn=4)
    assert terms.team_reward() == pytest.approx(0.3 + 2.0 + 6.0 + 11.0 - 0.5 - 0.2 - 0.001)


def test_mean_credit_mode_gives_every_agent_the_same_reward():
    env = coalition_milestone_v1(parallel_env("coalition-easy", index=1000), support_credit="mean")
    for _, rewards, _, _, _ in random_episode(env, seed=2, steps=60):
        assert len(set(rewards.values())) == 1
    with pytest.raises(ValueError, match="support_credit"):
        coalition_milestone_v1(parallel_env("coalition-easy", index=1000), support_credit="each")


# --------------------------------------------------------------------------- render and bad input


def test_render_ansi_shows_the_grid_and_counters():
    env = parallel_env("coalition-medium", index=1000, render_mode="ansi")
    env.reset(seed=0)
    ctl = make_controller("greedy")
    ctl.reset(0)
    for _ in range(30):
        env.step(ctl.act(env.sim.observe()))
    text = env.render()
    lines = text.splitlines()
    assert lines[0].startswith("t=30 ") and f"released {env.sim.state.released}" in lines[0]
    assert len(lines) == 1 + 5 and all(line.count("[") == 6 for line in lines[1:])
    busy = sum(not r.free(env.sim.state.t) for r in env.sim.state.robots.values())
    assert text.count("*]") == busy
    assert parallel_env("flow-easy", index=0).render() is None  # no render_mode: nothing


def test_bad_input_gives_clear_errors():
    with pytest.raises(AdapterError, match="unknown scenario `no-such`"):
        parallel_env("no-such")
    with pytest.raises(AdapterError, match="render_mode"):
        parallel_env("flow-easy", render_mode="rgb_array")
    env = parallel_env("flow-easy", index=0)
    env.reset(seed=0)
    with pytest.raises(AdapterError, match="unknown agent"):
        env.step({"9,9": 0})
    with pytest.raises(AdapterError, match="must be an integer"):
        env.step({"0,0": "pick"})
    for _ in random_episode(env, seed=0):
        pass
    with pytest.raises(AdapterError, match="after the episode ended"):
        env.step({})


def test_step_joint_is_step_without_the_dicts():
    """A-PZ-ARRAYS: the batch consumers' step gives the epoch, events and arrays that step gives."""
    by_dict, by_list = parallel_env("coalition-medium", index=1000), parallel_env("coalition-medium", index=1000)
    by_dict.reset(seed=0)
    by_list.reset(seed=0)
    rng = np.random.default_rng(3)
    for tick in range(120):
        joint = [int(rng.choice(np.flatnonzero(row))) for row in by_dict.action_mask_array]
        by_dict.step(dict(zip(by_dict.possible_agents, joint)))
        by_list.step_joint([np.int64(a) for a in joint] if tick % 2 else joint)  # NumPy integers are actions too
        assert by_list.last_events == by_dict.last_events
        assert by_list.observation_array.tobytes() == by_dict.observation_array.tobytes()
        assert by_list.action_mask_array.tobytes() == by_dict.action_mask_array.tobytes()


def test_step_joint_refuses_a_joint_action_of_the_wrong_shape_or_kind():
    env = parallel_env("flow-easy", index=0)
    env.reset(seed=0)
    with pytest.raises(AdapterError, match="one action per robot"):
        env.step_joint([0, 0])
    with pytest.raises(AdapterError, match="must be an integer"):
        env.step_joint(["pick"] * len(env.possible_agents))


def test_instance_file_and_index_conflict(tmp_path):
    import json

    inst = parallel_env("flow-easy", index=7).instance
    path = tmp_path / "inst.json"
    path.write_text(json.dumps(inst))
    assert parallel_env(str(path)).instance == inst
    with pytest.raises(AdapterError, match="takes no index"):
        parallel_env(str(path), index=3)
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({**inst, "seeds": "none"}))
    with pytest.raises(AdapterError, match="bad.json/seeds: error\\[AG2"):  # schema-checked (S-INSTANCE)
        parallel_env(str(bad))


def test_the_per_agent_maps_of_a_step_are_the_callers_own():
    """A-PZ-STEP: rewards, terminations and truncations are new dicts every step (a caller may change
    them), typed as the spaces say: float rewards, bool flags."""
    env = parallel_env("flow-easy", index=0)
    env.reset(seed=0)
    _, rewards, terms, truncs, _ = env.step({})
    rewards[env.possible_agents[0]] = 99.0
    terms[env.possible_agents[0]] = True
    _, again, terms2, _, _ = env.step({})
    assert set(again.values()) == {0.0} and set(terms2.values()) == {False}
    assert again is not rewards and terms2 is not terms and truncs is not terms
    for got, kind in ((again, float), (terms2, bool), (truncs, bool)):
        assert list(got) == env.possible_agents
        assert all(type(v) is kind for v in got.values())
