"""The training environment copies (spec/16-training.md, T-COPIES, T-EPISODES, T-REWARD): all agents of one
PettingZoo environment as one batch, the paper's reward per agent, episodes that replay one realization.
No torch needed."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("gymnasium", reason="the training environment needs Gymnasium: pip install 'agspec[train]'")

from agspec.catalogue import load_instance  # noqa: E402
from agspec.marl.rewards import SUPPORT_CREDIT  # noqa: E402
from agspec.pettingzoo import coalition_milestone_v1, parallel_env  # noqa: E402
from agspec.train.rollout import EpisodeStats, TeamEnv, make_vector, restart, start_block  # noqa: E402


def random_joint(mask: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    return np.array([rng.choice(np.flatnonzero(m)) for m in mask])


@pytest.mark.parametrize("credit", ["agent", "mean"])
def test_team_env_rewards_are_the_milestone_wrappers(credit):  # T-REWARD, A-REWARD-MILESTONE
    instance = load_instance("coalition-easy", 0)
    team = TeamEnv(instance, credit, with_state=True)
    wrapped = coalition_milestone_v1(parallel_env(instance), support_credit=credit)
    obs, _ = team.reset()
    ref_obs, _ = wrapped.reset(seed=instance["seeds"]["execution"])
    agents = team.agents
    rng = np.random.default_rng(1)
    milestones = admitted = 0
    for _ in range(60):
        assert np.array_equal(obs["obs"], np.stack([ref_obs[a]["observation"] for a in agents]))
        assert obs["state"].shape == team.observation_space["state"].shape
        joint = random_joint(obs["mask"], rng)
        obs, scalar, term, trunc, info = team.step(joint)
        ref_obs, ref_rewards, *_rest, ref_infos = wrapped.step({a: int(x) for a, x in zip(agents, joint)})
        assert info["rewards"].tolist() == pytest.approx([ref_rewards[a] for a in agents])
        credits = [ref_infos[a]["support_credit"] for a in agents]
        m = ref_infos[agents[0]]["milestone"]
        team_reward = (0.10 * m["progress"] + 2.0 * m["coalition"] + 3.0 * m["operation"] + 11.0 * m["delivery"]
                       - 0.25 * m["failure"] - 0.05 * m["churn"] - 0.001)
        # RES-MILESTONE-RETURN: delivery coefficient 10 and the agents' mean credit, whatever the method's credit
        assert info["milestone"] == pytest.approx(team_reward - m["delivery"] + SUPPORT_CREDIT * np.mean(credits))
        assert info["admitted"] == m["coalition"] and info["delivered"] == m["delivery"]
        if credit == "mean":
            assert len(set(info["rewards"].tolist())) == 1  # QMIX: one team reward
        milestones += int(any(credits))
        admitted += m["coalition"]
    assert milestones > 0  # the support credit was exercised


def test_every_episode_replays_the_realization_from_its_start():  # T-EPISODES
    instance = load_instance("flow-easy", 0)
    env = TeamEnv(instance, "agent", with_state=False)
    first, _ = env.reset()
    rng = np.random.default_rng(0)
    obs = first
    for _ in range(10):
        obs, *_ = env.step(random_joint(obs["mask"], rng))
    again, _ = env.reset()
    assert np.array_equal(first["obs"], again["obs"]) and np.array_equal(first["mask"], again["mask"])
    other = load_instance("flow-easy", 1)
    switched, _ = env.reset(options={"instance": other})
    assert env.instance["id"] == other["id"]
    repeat, _ = env.reset()
    assert np.array_equal(switched["obs"], repeat["obs"])  # the new realization stays


def test_a_copy_whose_episode_ended_restarts_and_the_step_counts(tmp_path):  # T-ENV-STEP, T-EPISODES
    text = load_instance("flow-easy", 0)
    text = {**text, "scenario": {**text["scenario"], "evaluation": {**text["scenario"]["evaluation"], "horizon": 3}}}
    vec = make_vector(text, 2, "agent", False, "sync")
    try:
        obs = start_block(vec, text)
        stats = EpisodeStats(2)
        rng = np.random.default_rng(0)
        for _tick in range(7):  # 7 ticks of 2 copies: 14 environment steps, 2 whole 3-tick episodes per copy
            joint = np.stack([random_joint(m, rng) for m in obs["mask"]])
            nxt, _r, term, trunc, infos = vec.step(joint)
            ended = np.logical_or(term, trunc)
            stats.add(infos, ended)
            obs = restart(vec, nxt, ended)
        done = stats.drain()
        assert len(done) == 4 and {e["length"] for e in done} == {3}
        assert [ep["length"] for ep in stats.open] == [1, 1]
    finally:
        vec.close()
