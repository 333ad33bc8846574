"""Where the joint actions of a lockstep episode come from (the policies of :mod:`agspec.conform.lockstep.driver`).

A policy answers ``act(t, observations, robots, simulator) -> {robot: action}`` for epoch ``t``;
``observations`` are the driving side's (see the driver), ``simulator`` the reference interpreter
in the driver's state (only a ``global`` policy reads it: the centralized controller).

* :class:`ControllerPolicy` — a seeded reference controller (C-RANDOM, C-GREEDY, C-PARALLEL-AWARE,
  C-CENTRALIZED);
* :class:`ScriptPolicy` — a fixed script of integers or symbolic actions (F-SYMBOLIC-ACTIONS),
  resolved against the driving side's option lists of that tick; ticks past its end are idle;
* :class:`GenePolicy` — hypothesis genes: per tick and robot an integer ``g`` mapped onto the
  robot's legal actions ``legal[g mod |legal|]`` (legal in ascending order, so 0 is idle) — or, for
  the top ``illegal_rate`` of the gene range, onto an illegal action;
* :class:`IllegalActions` — another policy whose actions are replaced, each with probability
  ``rate`` (a seeded stream), by an illegal one: an action the robot's mask forbids or an integer
  outside ``0 … 113`` (F-DIFF-ACTIONS: what R-ACTION-VALIDATION must coerce, with ``action_coerced``).
"""

from __future__ import annotations

import random
from typing import Any, Mapping, Sequence

from agspec.controllers import make_controller
from agspec.formats.actions import IDLE, N_ACTIONS, option_ids, resolve


class ControllerPolicy:
    """A seeded reference controller acting on the driving side's observations."""

    def __init__(self, controller: str, seed: int | None, *, reset_seed: int | None = None):
        self.name = f"{controller}(seed={seed})"
        self.controller, self.seed = controller, seed
        self.reset_seed = seed if reset_seed is None else reset_seed
        self._ctl = make_controller(controller, seed)
        self.information = self._ctl.information
        self.observes = True

    def reset(self, grid: Mapping[str, Any] | None = None) -> None:
        """A new episode on ``grid`` (the scenario's grid, public: C-INFORMATION; the structured
        controllers route on its G_handoff, C-STAGING)."""
        self._ctl = make_controller(self.controller, self.seed, grid=grid)
        self._ctl.reset(self.reset_seed)

    def act(self, t: int, observations, robots, simulator=None) -> dict[str, int]:
        if observations is None:
            raise ValueError("controllers need observations from the driving implementation")
        chosen = self._ctl.act(observations, simulator if self.information == "global" else None)
        return {r: int(a) for r, a in chosen.items()}


class ScriptPolicy:
    """A fixed (integer or symbolic) script; ticks past its end are idle.

    F-SYMBOLIC-ACTIONS: an option the robot is not offered at that tick raises
    :class:`~agspec.formats.actions.IllegalAction` (the driver ends the run as invalid).
    """

    name = "script"
    information = "local"

    def __init__(self, script: Sequence[Mapping[str, Any]]):
        self.script = [dict(j) for j in script]
        # integers need no option lists: a script of integers is driven without observations
        self.observes = any(not isinstance(a, int) or isinstance(a, bool) for j in self.script for a in j.values())

    def reset(self, grid: Mapping[str, Any] | None = None) -> None:
        pass

    def act(self, t: int, observations, robots, simulator=None) -> dict[str, int]:
        joint = self.script[t] if t < len(self.script) else {}
        out = {}
        for robot, action in joint.items():
            if isinstance(action, int) and not isinstance(action, bool):
                a = action
            else:
                a = resolve(action, *option_ids((observations or {}).get(robot)))
            if a != IDLE:
                out[robot] = a
        return out


# F-DIFF-ACTIONS: integers outside the encoding 0 … 113 (O-ACTION-ENCODING) that a driver sends
OUT_OF_RANGE = (-1, N_ACTIONS, 255, 1000)
GENE_RANGE = 2 ** 16  # hypothesis genes are integers 0 … GENE_RANGE - 1


def illegal_action(mask: Sequence[Any] | None, draw: int) -> int:
    """An action the robot may not take, chosen by ``draw`` (a non-negative integer): half the draws an
    action its mask forbids (when there is one), the other half an integer out of range."""
    masked = [a for a, ok in enumerate(mask) if not ok] if isinstance(mask, list) else []
    if masked and draw % 2 == 0:
        return masked[(draw // 2) % len(masked)]
    return OUT_OF_RANGE[(draw // 2) % len(OUT_OF_RANGE)]


class GenePolicy:
    """Hypothesis genes: per tick, per robot (row-major) an integer g -> legal[g mod |legal|], or, for g in
    the top ``illegal_rate`` of the gene range, an illegal action (shrinking towards 0 makes it legal)."""

    name = "hypothesis"
    information = "local"
    observes = True

    def __init__(self, genes: Sequence[Sequence[int]], illegal_rate: float = 0.0):
        self.genes = [list(g) for g in genes]
        self.illegal_from = int(GENE_RANGE * (1.0 - illegal_rate)) if illegal_rate > 0 else GENE_RANGE

    def reset(self, grid: Mapping[str, Any] | None = None) -> None:
        pass

    def act(self, t: int, observations, robots, simulator=None) -> dict[str, int]:
        genes = self.genes[t] if t < len(self.genes) else []
        out = {}
        for k, robot in enumerate(robots):
            if k >= len(genes) or genes[k] == 0:
                continue
            mask = ((observations or {}).get(robot) or {}).get("mask")
            if mask is None:
                continue
            if genes[k] >= self.illegal_from:
                out[robot] = illegal_action(mask, genes[k])
                continue
            legal = [a for a, ok in enumerate(mask) if ok]
            a = legal[genes[k] % len(legal)]
            if a != IDLE:
                out[robot] = a
        return out


class IllegalActions:
    """F-DIFF-ACTIONS: ``inner``'s joint actions, each robot's replaced with probability ``rate`` by an
    illegal action (:func:`illegal_action`), from a stream seeded by ``seed`` and restarted by ``reset``."""

    def __init__(self, inner: Any, rate: float, seed: int):
        self.inner, self.rate, self.seed = inner, rate, seed
        self.name = inner.name  # the rate is stated once, for the whole run (F-DIFF-ACTIONS)
        self.information, self.observes = inner.information, True
        self._rng = random.Random(f"illegal:{seed}")

    def reset(self, grid: Mapping[str, Any] | None = None) -> None:
        self.inner.reset(grid)
        self._rng = random.Random(f"illegal:{self.seed}")

    def act(self, t: int, observations, robots, simulator=None) -> dict[str, int]:
        joint = dict(self.inner.act(t, observations, robots, simulator))
        for robot in robots:
            if self._rng.random() < self.rate:
                mask = ((observations or {}).get(robot) or {}).get("mask")
                joint[robot] = illegal_action(mask, self._rng.randrange(1 << 30))
        return joint


def with_illegal(policy: Any, rate: float, seed: int) -> Any:
    """``policy`` with illegal actions at ``rate`` (itself when the rate is 0)."""
    return IllegalActions(policy, rate, seed) if rate > 0 else policy


__all__ = ["ControllerPolicy", "ScriptPolicy", "GenePolicy", "IllegalActions", "with_illegal", "illegal_action",
           "OUT_OF_RANGE", "GENE_RANGE"]
