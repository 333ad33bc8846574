"""The Gymnasium centralized adapter (spec/12-adapters.md, A-GYM-ENV): the official env checker on every
official scenario, registration, fidelity to the interpreter, rewards and bad input."""

from __future__ import annotations

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium", reason="the MARL extra is not installed: pip install 'agspec[marl]'")
pytest.importorskip("pettingzoo", reason="the MARL extra is not installed: pip install 'agspec[marl]'")
from gymnasium.utils.env_checker import check_env  # noqa: E402

import agspec.gymnasium as agym  # noqa: E402
from agspec.catalogue import OFFICIAL_SCENARIOS  # noqa: E402
from agspec.controllers import make_controller  # noqa: E402
from agspec.evaluate import run_episode  # noqa: E402
from agspec.pettingzoo import AdapterError  # noqa: E402


@pytest.mark.parametrize("scenario", OFFICIAL_SCENARIOS)
def test_check_env_passes_on_every_official_scenario(scenario):
    env = gymnasium.make(agym.ENV_ID, scenario=scenario, index=1000).unwrapped
    check_env(env, skip_render_check=False)  # also renders in every declared mode (ansi, human)
    n = len(env.robots)
    assert env.action_space.shape == (n,) and env.observation_space["observation"].shape == (n, 1566)


def test_registered_and_made_through_gymnasium_make_with_both_render_modes():
    env = gymnasium.make(agym.ENV_ID, scenario="flow-medium", index=1000, render_mode="ansi")
    check_env(env.unwrapped)
    obs, info = env.reset(seed=3)
    assert obs in env.observation_space
    assert env.render().startswith("t=0 ")
    env.close()


def test_centralized_control_of_the_reference_reproduces_run():
    """The joint action of the Centralized reference, fed through the env, gives agspec run's metrics."""
    env = agym.make_env("coalition-easy", index=1000, capacity=True)  # A-PZ-CAPACITY
    seed = env.par.instance["seeds"]["execution"]
    env.reset(seed=seed)
    ctl = make_controller("centralized")
    ctl.reset(seed)
    total, done = 0.0, False
    while not done:
        joint = ctl.act(env.sim.observe(), env.sim)
        action = np.array([joint.get(r, 0) for r in env.robots])
        obs, reward, terminated, truncated, info = env.step(action)
        total += reward
        done = terminated or truncated
    expected = run_episode(env.par.instance, "centralized").metrics
    assert env.final_metrics() == expected
    assert total == expected["delivered"] > 0
    np.testing.assert_array_equal(info["action_mask"], obs["action_mask"])


def test_milestone_reward_is_the_team_reward_with_the_mean_support_credit():
    env = agym.make_env("coalition-medium", index=1000, reward="coalition_milestone_v1")
    env.reset(seed=0)
    rewards = [env.step(env.action_space.sample())[1] for _ in range(30)]
    assert all(isinstance(r, float) for r in rewards)
    assert min(rewards) == pytest.approx(-0.001)  # a step with no event: only the step cost


def test_bad_input():
    with pytest.raises(AdapterError, match="reward must be one of"):
        agym.make_env("flow-easy", reward="dense")
    env = agym.make_env("flow-easy", index=0)
    env.reset(seed=0)
    with pytest.raises(AdapterError, match="one integer per robot"):
        env.step(np.zeros(3, dtype=np.int64))
