"""Environment copies for training (spec/16-training.md, T-COPIES, T-REWARD, T-EPISODES).

:class:`TeamEnv` presents all agents of one PettingZoo environment (A-PZ-ENV) as one Gymnasium
environment whose observation is the batch of every agent's A-OBS-VECTOR and O-MASK (and, for the
centralized critic and mixer, the A-STATE-VECTOR), whose action is the joint action, and whose
info carries each agent's training reward ``coalition_milestone_v1`` (A-REWARD-MILESTONE) and the
counts the training record needs.  Copies run through Gymnasium's vector machinery, in this
process (``SyncVectorEnv``) or one process each (``AsyncVectorEnv``); the trainer resets copies
itself (autoreset disabled) so that every episode replays its block's realization from its start.
"""

from __future__ import annotations

from typing import Any, Mapping

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.vector import AsyncVectorEnv, AutoresetMode, SyncVectorEnv, VectorEnv

from agspec.interp.observe import N_ACTIONS
from agspec.marl.encoding import OBS_DIM
from agspec.marl.parallel import AssemblyGridParallelEnv
from agspec.marl.rewards import SUPPORT_CREDIT, milestone_rewards

# the info keys every step carries (the vector env stacks them per copy)
STEP_INFO = ("rewards", "milestone", "admitted", "delivered")


class TeamEnv(gym.Env):
    """All agents of one AssemblyGrid instance as one batch (T-COPIES).

    ``instance`` is the instance IR the copy plays until ``reset(options={"instance": ir})`` gives
    another one; every reset starts that instance afresh with its own execution seed (S-SEEDS).
    """

    metadata: dict[str, Any] = {"render_modes": []}

    def __init__(self, instance: Mapping[str, Any], support_credit: str, with_state: bool):
        self.par = AssemblyGridParallelEnv(dict(instance))
        self.instance = dict(instance)
        self.credit_mode = support_credit
        self.with_state = with_state
        self.agents = list(self.par.possible_agents)
        n = len(self.agents)
        space = {"obs": spaces.Box(0.0, 1.0, (n, OBS_DIM), np.float32),
                 "mask": spaces.Box(0, 1, (n, N_ACTIONS), np.int8)}
        if with_state:
            space["state"] = self.par.state_space
        self.observation_space = spaces.Dict(space)
        self.action_space = spaces.MultiDiscrete([N_ACTIONS] * n)

    def _observe(self) -> dict[str, np.ndarray]:
        # A-PZ-ARRAYS: the env's arrays hold every agent's rows in possible_agents order (self.agents)
        out = {"obs": self.par.observation_array, "mask": self.par.action_mask_array}
        if self.with_state:
            out["state"] = self.par.state()
        return out

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        """T-EPISODES: a new episode of this copy's realization (or of ``options["instance"]``)."""
        super().reset(seed=seed)
        if options and "instance" in options:
            self.instance = dict(options["instance"])
        self.par.reset(seed=self.instance["seeds"]["execution"], options={"instance": self.instance})
        return self._observe(), {}

    def step(self, action: np.ndarray):
        result, truncated = self.par.step_joint(np.asarray(action).tolist())
        # T-REWARD: the paper's reward from this step's events (A-REWARD-MILESTONE)
        terms_, credit, rewards = milestone_rewards(self.par.last_events, self.par.supporting_before,
                                                    self.par.supporting(), self.credit_mode)
        per_agent = np.array([rewards[a] for a in self.agents], dtype=np.float32)
        # T-RECORD: the milestone return term excludes the sparse unit of every delivery and takes
        # the agents' mean support credit, whatever the method's own credit
        milestone = terms_.team_reward() - terms_.delivery + SUPPORT_CREDIT * (sum(credit.values()) / len(credit))
        info = {"rewards": per_agent, "milestone": milestone, "admitted": terms_.coalition,
                "delivered": terms_.delivery}
        team = float(per_agent.mean())
        return self._observe(), team, result.terminated, truncated and not result.terminated, info


def make_vector(instance: Mapping[str, Any], copies: int, support_credit: str, with_state: bool,
                mode: str) -> VectorEnv:
    """``copies`` TeamEnvs of ``instance``, in this process (``sync``) or one process each (``async``).

    Autoreset is disabled: :func:`restart` resets the copies whose episode ended (T-EPISODES).
    """
    fns = [lambda: TeamEnv(instance, support_credit, with_state) for _ in range(copies)]
    if mode == "async":
        return AsyncVectorEnv(fns, autoreset_mode=AutoresetMode.DISABLED, context="spawn")
    return SyncVectorEnv(fns, autoreset_mode=AutoresetMode.DISABLED)


def vector_mode(config: Mapping[str, Any]) -> str:
    """T-COPIES: ``auto`` is one process per copy when there are several copies, else this process."""
    mode = config["runtime"]["vector"]
    if mode == "auto":
        return "async" if config["rollout"]["envs"] > 1 else "sync"
    return mode


def start_block(vec: VectorEnv, instance: Mapping[str, Any]) -> dict[str, np.ndarray]:
    """Every copy starts an episode of ``instance`` (T-CURRICULUM: a block's first tick)."""
    obs, _ = vec.reset(options={"instance": dict(instance)})
    return obs


def restart(vec: VectorEnv, obs: dict[str, np.ndarray], ended: np.ndarray) -> dict[str, np.ndarray]:
    """T-EPISODES: reset the copies whose episode ended; the others keep their observation."""
    if not ended.any():
        return obs
    fresh, _ = vec.reset(options={"reset_mask": ended.astype(np.bool_)})
    return {key: np.where(ended.reshape((-1,) + (1,) * (value.ndim - 1)), fresh[key], value)
            for key, value in obs.items()}


def step_info(infos: Mapping[str, Any], key: str) -> np.ndarray:
    """The per-copy array of one STEP_INFO key from the vector env's stacked infos."""
    return np.asarray(infos[key])


class EpisodeStats:
    """Per copy: the running sums of the episode in progress, and the episodes finished (T-RECORD)."""

    def __init__(self, copies: int):
        self.copies = copies
        self.open = [self._zero() for _ in range(copies)]
        self.finished: list[dict[str, float]] = []

    @staticmethod
    def _zero() -> dict[str, float]:
        return {"milestone_return": 0.0, "admissions": 0, "delivered": 0, "length": 0}

    def add(self, infos: Mapping[str, Any], ended: np.ndarray) -> None:
        milestone, admitted, delivered = (step_info(infos, k) for k in ("milestone", "admitted", "delivered"))
        for e in range(self.copies):
            ep = self.open[e]
            ep["milestone_return"] += float(milestone[e])
            ep["admissions"] += int(admitted[e])
            ep["delivered"] += int(delivered[e])
            ep["length"] += 1
            if ended[e]:
                self.finished.append(ep)
                self.open[e] = self._zero()

    def drain(self) -> list[dict[str, float]]:
        out, self.finished = self.finished, []
        return out

    def reset_open(self) -> None:
        """A new block starts every copy afresh (its unfinished episodes are not counted)."""
        self.open = [self._zero() for _ in range(self.copies)]
