"""Gymnasium single-agent env: centralized control of all robots (spec/12-adapters.md, A-GYM-ENV).

The one agent chooses the joint action (a MultiDiscrete of 114 per robot, row-major) and sees every
robot's A-OBS-VECTOR and mask plus the privileged A-STATE-VECTOR: a centralized controller's
information (C-INFORMATION "global"), like the Centralized reference.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from agspec.interp.observe import N_ACTIONS
from agspec.marl.encoding import OBS_DIM
from agspec.marl.parallel import AdapterError, AssemblyGridParallelEnv
from agspec.marl.rewards import delivered_value, milestone_rewards

REWARDS = ("sparse-delivery-v1", "coalition_milestone_v1")


class CentralizedEnv(gym.Env):
    """AssemblyGrid v1 as one Gymnasium agent controlling every robot (A-GYM-ENV)."""

    metadata = {"render_modes": ["ansi", "human"], "render_fps": 4}

    def __init__(self, scenario: str | Path | Mapping[str, Any] = "coalition-easy", index: int | None = None, *,
                 split: str | None = None, seed: int | None = None, stage: int = 0,
                 realization_steps: int | None = None, reward: str = "sparse-delivery-v1",
                 render_mode: str | None = None, max_cycles: int | None = None, capacity: bool = False,
                 search_paths: tuple[str, ...] = ()):
        if reward not in REWARDS:
            raise AdapterError(f"reward must be one of {REWARDS}, got {reward!r}")
        self.reward_name = reward
        self.render_mode = render_mode
        # A-PZ-SPLIT: the split options cycle the instances of the underlying parallel environment
        self.par = AssemblyGridParallelEnv(scenario, index, split=split, seed=seed, stage=stage,
                                           realization_steps=realization_steps, render_mode=render_mode,
                                           max_cycles=max_cycles, capacity=capacity, search_paths=search_paths)
        n = len(self.par.possible_agents)
        self.robots = list(self.par.possible_agents)
        self.observation_space = spaces.Dict({
            "observation": spaces.Box(0.0, 1.0, (n, OBS_DIM), np.float32),
            "action_mask": spaces.Box(0, 1, (n, N_ACTIONS), np.int8),
            "state": self.par.state_space,
        })
        self.action_space = spaces.MultiDiscrete(np.full(n, N_ACTIONS, dtype=np.int64))

    @property
    def sim(self):
        return self.par.sim

    def _stack(self) -> dict[str, np.ndarray]:
        # A-PZ-ARRAYS: the parallel env's arrays are every robot's rows in this env's (row-major) order
        return {
            "observation": self.par.observation_array,
            "action_mask": self.par.action_mask_array,
            "state": self.par.state(),
        }

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        if seed is not None:
            self.action_space.seed(seed)
        self.par.reset(seed=seed, options=options)
        obs = self._stack()
        return obs, {"action_mask": obs["action_mask"]}

    def step(self, action: Any):
        joint = np.asarray(action).reshape(-1)
        if joint.shape != (len(self.robots),):
            raise AdapterError(f"action must hold one integer per robot ({len(self.robots)}), got shape {np.shape(action)}")
        result, truncated = self.par.step_joint(joint.tolist())
        if self.reward_name == "sparse-delivery-v1":
            reward = delivered_value(result.events, self.par.sim.state.products)  # A-REWARD-SPARSE
        else:  # the team reward with the agent-mean support credit (the paper's shared form)
            _, _, shared = milestone_rewards(self.par.last_events, self.par.supporting_before, self.par.supporting(), "mean")
            reward = shared[self.robots[0]]
        obs = self._stack()
        return obs, float(reward), bool(result.terminated), truncated, {"action_mask": obs["action_mask"]}

    def render(self):
        return self.par.render()

    def final_metrics(self) -> dict[str, Any]:
        return self.par.final_metrics()


def make_env(scenario: str | Path | Mapping[str, Any] = "coalition-easy", index: int | None = None, **kwargs: Any) -> CentralizedEnv:
    """``agspec.gymnasium.make_env("coalition-medium", index=1000)`` (A-GYM-ENV)."""
    return CentralizedEnv(scenario, index, **kwargs)
