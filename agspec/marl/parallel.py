"""PettingZoo ParallelEnv over the reference interpreter (spec/12-adapters.md, A-PZ-*).

One agent per robot, named by its robot id ``"i,j"`` (R-IDS) in row-major order.  Each agent sees
``{"observation": A-OBS-VECTOR, "action_mask": O-MASK as int8}`` (PettingZoo's action-mask
convention); the mask is also in its info.  Actions are the 114 integers of O-ACTION-ENCODING; an
illegal action is executed as idle and counted, as the interpreter does (R-ACTION-VALIDATION).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv

from agspec.interp.observe import IDLE, N_ACTIONS
from agspec.interp.tick import Simulator, StepResult
from agspec.ir.instance import make_instance
from agspec.marl import curriculum
from agspec.marl.batch import BatchEncoder
from agspec.marl.encoding import OBS_DIM, PublicInfo, StateEncoder, state_dim
from agspec.marl.render import render_text
from agspec.marl.rewards import delivered_value


class AdapterError(ValueError):
    """A bad scenario, instance or option given to an adapter (message names what and where)."""


def _plain_ints(agents: Sequence[str], joint: list[Any]) -> list[int]:
    """A joint action (one value per agent, in order) as plain ints: the common case, plain ints already,
    without NumPy's round trip; an AdapterError names the agent of a value that is not an integer."""
    if set(map(type, joint)) == {int}:
        return joint
    return [value if type(value) is int else _action(agent, value) for agent, value in zip(agents, joint)]


def _action(agent: str, value: Any) -> int:
    """An agent's action as an int (NumPy scalars and 0-d arrays too); AdapterError names the agent.
    Out-of-range integers are the interpreter's to coerce to idle and count (R-ACTION-VALIDATION)."""
    try:
        return int(np.asarray(value).item())
    except (TypeError, ValueError):
        raise AdapterError(f"action of agent {agent!r} must be an integer in 0..{N_ACTIONS - 1}, got {value!r}") from None


def load_instance(scenario: str | Path | Mapping[str, Any], index: int | None = None,
                  search_paths: tuple[str, ...] = ()) -> dict[str, Any]:
    """A-PZ-ENV: an instance IR from a dict, an instance ``.json`` file, or a scenario name/file + index."""
    from agspec.catalogue import CatalogueError, InvalidInstanceError, read_instance_file
    from agspec.catalogue import load_instance as load

    if isinstance(scenario, Mapping):
        if scenario.get("kind") != "instance":
            raise AdapterError("an instance given as a mapping must be an instance IR (kind: instance)")
        return dict(scenario)
    try:
        if index is not None and read_instance_file(scenario) is not None:
            raise AdapterError(f"{scenario} is an instance; it takes no index")
        return load(scenario, index, None, search_paths)
    except (CatalogueError, InvalidInstanceError) as exc:
        raise AdapterError(str(exc)) from None


class Curriculum:
    """A-PZ-SPLIT: the instances a split environment plays, realized when first played.

    ``items`` are the split's instance keys (training realization r, or a suite index); the n-th
    instance a reset plays is ``items[(n or steps // block) mod len(items)]`` (RES-SPLIT-CYCLE).
    """

    def __init__(self, bundle: tuple[Any, Any, Any], split: str, seed: int | None, stage: int, block: int | None):
        self.bundle, self.split, self.seed, self.stage, self.block = bundle, split, seed, stage, block
        if split == "training":
            self.items: list[int] = list(range(curriculum.REALIZATIONS))
        else:
            self.items = list(curriculum.split_indices(split))
        self._instances: dict[int, dict[str, Any]] = {}
        self.resets = 0  # resets that played the curriculum (not an options["instance"])

    def position(self, steps: int) -> int:
        """Which item the next curriculum reset plays, ``steps`` env steps into the environment's life."""
        n = self.resets if self.block is None else steps // self.block
        return n % len(self.items)

    def instance(self, position: int) -> dict[str, Any]:
        key = self.items[position]
        if key not in self._instances:
            if self.split == "training":  # A-TRAINING-REALIZATIONS
                self._instances[key] = curriculum.training_instance(self.bundle, self.seed, self.stage, key)
            else:
                self._instances[key] = make_instance(*self.bundle, index=key)
        return self._instances[key]


def make_curriculum(scenario: Any, index: int | None, split: str | None, seed: int | None, stage: int,
                    realization_steps: int | None, search_paths: tuple[str, ...]) -> Curriculum | None:
    """A-PZ-SPLIT: check the split options and load the scenario they cycle over (None: no split)."""
    from agspec.catalogue import CatalogueError, load_scenario_bundle, read_instance_file

    if split is None:
        for name, value in (("seed", seed), ("realization_steps", realization_steps)):
            if value is not None:
                raise AdapterError(f"{name}= is an option of split environments; give split='training' "
                                   "(or 'validation', 'final-test')")
        if stage:
            raise AdapterError("stage= is an option of split='training'")
        return None
    try:
        name = curriculum.split_name(split)
    except curriculum.CurriculumError as exc:
        raise AdapterError(str(exc)) from None
    if index is not None:
        raise AdapterError(f"split={split!r} plays the split's instances; it takes no index")
    if realization_steps is not None and (isinstance(realization_steps, bool) or not isinstance(realization_steps, int)
                                          or realization_steps < 1):
        raise AdapterError(f"realization_steps must be a positive integer, got {realization_steps!r}")
    if name == "training" and seed is None:
        raise AdapterError("split='training' needs seed=K, the run's algorithm seed: the training realizations "
                           "are derived from it (A-TRAINING-REALIZATIONS)")
    if name != "training" and (seed is not None or stage):
        raise AdapterError(f"split={split!r} plays the canonical suite instances, the same for every run; "
                           "seed= and stage= belong to split='training'")
    if isinstance(scenario, Mapping):
        raise AdapterError("a split environment needs a scenario (a name or a scenario file), not an instance")
    try:
        if read_instance_file(scenario) is not None:
            raise AdapterError(f"{scenario} is an instance; a split environment needs a scenario")
        bundle = load_scenario_bundle(scenario, search_paths)
        out = Curriculum(bundle, name, seed, stage, realization_steps)
        out.instance(0)  # the seed formula's checks and the first realization, before any reset
    except (CatalogueError, curriculum.CurriculumError, ValueError) as exc:
        if isinstance(exc, AdapterError):
            raise
        raise AdapterError(str(exc)) from None
    return out


class AssemblyGridParallelEnv(ParallelEnv):
    """AssemblyGrid v1 as a PettingZoo ParallelEnv (A-PZ-ENV).

    With ``split`` (A-PZ-SPLIT) it cycles over a split's instances on reset: ``split="training"``
    with ``seed=K`` plays the run's five training realizations (A-TRAINING-REALIZATIONS),
    ``"validation"`` and ``"final-test"`` the canonical suite instances.
    """

    metadata = {"name": "assemblygrid_v1", "render_modes": ["ansi", "human"], "is_parallelizable": True, "render_fps": 4}

    def __init__(self, scenario: str | Path | Mapping[str, Any], index: int | None = None, *,
                 split: str | None = None, seed: int | None = None, stage: int = 0,
                 realization_steps: int | None = None, render_mode: str | None = None,
                 max_cycles: int | None = None, capacity: bool = False, search_paths: tuple[str, ...] = ()):
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise AdapterError(f"render_mode must be one of {self.metadata['render_modes']}, got {render_mode!r}")
        self._scenario, self._search_paths = scenario, search_paths
        self.render_mode = render_mode
        self.max_cycles = max_cycles
        self.capacity = bool(capacity)  # A-PZ-CAPACITY: M-CAPACITY sampled only when asked for
        self.curriculum = make_curriculum(scenario, index, split, seed, stage, realization_steps, search_paths)
        self.position: int | None = None  # the curriculum item now played (None: not a split env, or an option)
        self.total_steps = 0  # env steps over the environment's life (the clock of realization_steps)
        if self.curriculum is not None:
            self._set_instance(self.curriculum.instance(0))
        else:
            self._set_instance(load_instance(scenario, index, search_paths))

    # ------------------------------------------------------------------ instance and spaces

    def _set_instance(self, instance: dict[str, Any]) -> None:
        self.instance = instance
        self.sim = Simulator(instance, capacity=self.capacity)
        self.public = PublicInfo.of(self.sim.model)
        self._encoder = BatchEncoder(self.sim.model, self.public)
        self._state_encoder = StateEncoder(self.sim.model)
        agents = self.sim.agents()
        if getattr(self, "possible_agents", None) not in (None, agents):
            # spaces are per agent and must stay the same objects (A-PZ-SPACES)
            raise AdapterError("a new instance must keep the grid size of the environment's scenario")
        self.possible_agents = agents
        self._agent_set = frozenset(agents)
        self.agents = []
        self._all_false = dict.fromkeys(agents, False)  # what terminations and truncations are until the end
        if not hasattr(self, "_action_spaces"):  # one space object per agent for the env's lifetime (A-PZ-SPACES)
            self._observation_spaces = {a: spaces.Dict({
                "observation": spaces.Box(0.0, 1.0, (OBS_DIM,), np.float32),
                "action_mask": spaces.Box(0, 1, (N_ACTIONS,), np.int8),
            }) for a in agents}
            self._action_spaces = {a: spaces.Discrete(N_ACTIONS) for a in agents}
        self.state_space = spaces.Box(0.0, 1.0, (state_dim(self.sim.model),), np.float32)
        self.last_events: list[dict[str, Any]] = []

    def observation_space(self, agent: str) -> spaces.Space:
        return self._observation_spaces[agent]

    def action_space(self, agent: str) -> spaces.Space:
        return self._action_spaces[agent]

    # ------------------------------------------------------------------ episode

    def reset(self, seed: int | None = None, options: dict[str, Any] | None = None):
        """A-PZ-RESET: ``options={"instance": index | instance IR | path}`` changes the instance.

        ``seed`` is the execution seed (S-SEEDS; v1 draws nothing from it, so it only enters the
        record) and seeds the agents' action spaces, as PettingZoo's seeding convention expects.
        """
        options = options or {}
        if "instance" in options:
            choice = options["instance"]
            if isinstance(choice, (int, np.integer)) and not isinstance(choice, bool):
                self._set_instance(load_instance(self._scenario, int(choice), self._search_paths))
            elif isinstance(choice, (str, Path, Mapping)):
                self._set_instance(load_instance(choice, None, self._search_paths))
            else:
                raise AdapterError(f"options['instance'] must be an index, an instance IR or a path, got {choice!r}")
            self.position = None
        elif self.curriculum is not None:  # A-PZ-SPLIT: the seed never picks the instance, the cycle does
            self.position = self.curriculum.position(self.total_steps)
            self.curriculum.resets += 1
            instance = self.curriculum.instance(self.position)
            if instance is not self.instance:
                self._set_instance(instance)
        if seed is not None:
            for k, agent in enumerate(self.possible_agents):
                self.action_space(agent).seed(int(seed) + k)
        self.sim.reset(seed)
        self._encoder.reset()
        self._state_encoder.reset()
        self.agents = list(self.possible_agents)
        self.last_events = list(self.sim.reset_events)
        self._cycles = 0
        self._encode()
        obs, masks = self._agent_views()
        return obs, {agent: {"action_mask": mask} for agent, mask in zip(self.possible_agents, masks)}

    def _encode(self) -> None:
        # A-OBS-VECTOR and O-MASK of every agent into two new arrays (the same bytes as encode_observation
        # of sim.observe()), A-PZ-ARRAYS
        decision = self.sim.decision
        self.observation_array, self.action_mask_array = self._encoder.encode(
            self.sim.state, decision.options, decision.masks)

    def _agent_views(self) -> tuple[dict[str, dict[str, np.ndarray]], list[np.ndarray]]:
        # each agent's entries are row views of the arrays (A-PZ-ARRAYS); the mask rows serve the infos too
        masks = list(self.action_mask_array)
        return {agent: {"observation": vector, "action_mask": mask}
                for agent, vector, mask in zip(self.possible_agents, self.observation_array, masks)}, masks

    @property
    def supporting_before(self) -> dict[str, bool]:
        """Which robots held a pending support before the last step (the c_sup input of A-REWARD-MILESTONE)."""
        return {agent: s is not None for agent, s in zip(self.possible_agents, self._supports_before)}

    def supporting(self) -> dict[str, bool]:
        """Which robots hold a pending support now (the c_sup input of A-REWARD-MILESTONE)."""
        robots = self.sim.state.robots
        return {agent: robots[c].supports is not None for agent, c in zip(self.possible_agents, self.sim.model.cells)}

    def step(self, actions: Mapping[str, Any]):
        """A-PZ-STEP: one decision epoch; agents missing from ``actions`` idle."""
        if not self.agents:
            raise AdapterError("step() after the episode ended; call reset()")
        known = self._agent_set
        if not known.issuperset(actions):
            unknown = [a for a in actions if a not in known]
            raise AdapterError(f"unknown agent(s) {unknown}; agents are robot ids such as {self.possible_agents[0]!r}")
        agents = self.possible_agents
        if len(actions) == len(agents):  # every agent named (the superset test above): in agent order
            joint = list(map(actions.__getitem__, agents))
        else:
            joint = [actions.get(agent, IDLE) for agent in agents]  # row-major, as the interpreter takes a list
        result, truncated = self._advance(_plain_ints(agents, joint))
        team = delivered_value(result.events, self.sim.state.products)  # A-REWARD-SPARSE
        obs, masks = self._agent_views()
        rewards = dict.fromkeys(agents, team)
        # a copy of a kept dict skips hashing every agent name again; the caller owns what it gets
        terms = dict.fromkeys(agents, True) if result.terminated else self._all_false.copy()
        truncs = dict.fromkeys(agents, True) if truncated else self._all_false.copy()
        infos = {agent: {"action_mask": mask, "applied_action": applied}
                 for agent, mask, applied in zip(agents, masks, map(result.applied.__getitem__, agents))}
        return obs, rewards, terms, truncs, infos

    def step_joint(self, joint: Sequence[Any]) -> tuple[StepResult, bool]:
        """A-PZ-ARRAYS: one decision epoch of the joint action ``joint`` (one integer per robot, in
        ``possible_agents`` order) without the per-agent dicts; the arrays hold the new epoch.  Returns the
        interpreter's step result and whether the episode was truncated (by the horizon or ``max_cycles``).
        :meth:`step` is the same epoch plus its dicts; batch consumers (A-GYM-ENV, training copies) call
        this directly.  NumPy integers are taken; anything else that is not an integer is an AdapterError."""
        if not self.agents:
            raise AdapterError("step() after the episode ended; call reset()")
        if len(joint) != len(self.possible_agents):
            raise AdapterError(f"step_joint() takes one action per robot ({len(self.possible_agents)}, in "
                               f"possible_agents order), got {len(joint)}")
        return self._advance(_plain_ints(self.possible_agents, list(joint)))

    def _advance(self, joint: list[int]) -> tuple[StepResult, bool]:
        """The epoch of a checked joint action (plain ints, row-major): what step and step_joint share."""
        # the encoder read every robot's pending support at the last epoch: the state this step starts from
        self._supports_before = self._encoder.supports
        result = self.sim.step(joint)
        self.last_events = result.events
        self._cycles += 1
        self.total_steps += 1
        truncated = result.truncated or (self.max_cycles is not None and self._cycles >= self.max_cycles
                                         and not result.terminated)
        self._encode()
        if result.terminated or truncated:
            self.agents = []
        return result, bool(truncated)

    def state(self) -> np.ndarray:
        """A-STATE-VECTOR: the privileged global state (centralized training only)."""
        return self._state_encoder.encode(self.sim.state)

    def render(self) -> str | None:
        if self.render_mode is None:
            return None
        text = render_text(self.sim.state, self.sim.model)
        if self.render_mode == "human":
            print(text)
            return None
        return text

    def close(self) -> None:
        pass

    def final_metrics(self) -> dict[str, Any]:
        """The benchmark measures of the episode so far (chapter 7): what evaluation reports when the
        environment was made with ``capacity=True``; without it the M-CAPACITY and M-RF-BR measures
        are null (A-PZ-CAPACITY)."""
        return self.sim.final_metrics()


def parallel_env(scenario: str | Path | Mapping[str, Any], index: int | None = None, **kwargs: Any) -> AssemblyGridParallelEnv:
    """``parallel_env("coalition-medium", index=1000)`` (A-PZ-ENV), or a split environment cycling its
    instances on reset: ``parallel_env("coalition-medium", split="training", seed=0)`` (A-PZ-SPLIT)."""
    return AssemblyGridParallelEnv(scenario, index, **kwargs)
