"""Greedy and Parallel-aware reference controllers (spec C-GREEDY, C-PARALLEL-AWARE).

Both decide per robot from its own execution information only.  They share the operation logic
(keep the pending candidate unless another enabled one has strictly higher visible support) and
move material only towards its staging or output target; Parallel-aware additionally prefers
destinations with lower locally observed congestion.
"""

from __future__ import annotations

from typing import Any, Mapping

from agspec.controllers.base import DELIVER, HANDOFF0, IDLE, OP0, PICK0, RECEIVE0, Obs, Routes, grid_key, parse_cell
from agspec.controllers.base import routes
from agspec.interp.model import DIRECTION_NAMES, DIRECTIONS

_DIR_INDEX = {name: d for d, name in enumerate(DIRECTION_NAMES)}


def operation_choice(obs: Obs) -> int | None:
    """C-GREEDY operation rule; None when the robot has no operation decision to make."""
    options = obs["operation_options"]
    pending = obs.get("supports")
    if not options and pending is None:
        return None  # nothing offered, nothing pending
    mask = obs["mask"]
    enabled = [k for k in range(len(options)) if mask[OP0 + k]]
    if pending is not None:
        pending_slot = next((k for k in enabled if options[k]["id"] == pending), None)
        if len(enabled) > 1:
            best = max(enabled, key=lambda k: (options[k]["support"], -options[k]["duration"], options[k]["id"]))
            if pending_slot is None or options[best]["support"] > options[pending_slot]["support"] + 1e-12:
                return OP0 + best
        return OP0 + pending_slot if pending_slot is not None else IDLE
    if enabled:
        return OP0 + enabled[0]  # slot order: highest support, then smallest id
    return None


def congestion(routes: Routes, dest: tuple[int, int], neighbours: dict[tuple[int, int], Mapping[str, Any]]) -> int:
    """C-PARALLEL-AWARE: busy or holding robots among the G_obs neighbours of ``dest`` that this robot
    observes (cells it does not observe count 0)."""
    score = 0
    for cell in routes.observed_around(dest):
        nb = neighbours.get(cell)
        if nb is None:
            continue
        score += (1 if nb["busy"] else 0) + (1 if nb["holding"] is not None else 0)
    return score


def logistics_choice(obs: Obs, parallel_aware: bool, grid: Mapping[str, Any] | None = None) -> int:
    """C-GREEDY logistics: pick, receive, deliver or hand off along a strictly shortening route
    (route distances in G_handoff of ``grid``, C-STAGING)."""
    mask = obs["mask"]
    rows, cols = obs["grid"]
    r = routes(grid_key(grid, rows, cols))
    me = parse_cell(obs["robot"])
    held = obs["holding"]
    if held is None:
        if obs["pick_options"] and mask[PICK0]:
            return PICK0
        best = None
        for nb in obs["neighbours"]:
            item = nb["holding"]
            if item is None or nb["busy"]:
                continue
            d = _DIR_INDEX[nb["dir"]]
            if not mask[RECEIVE0 + d]:
                continue
            at = parse_cell(nb["robot"])
            target = r.item_target(item["product"], item["token"], item["final"], at)
            there, here = r.distance(at, target), r.distance(me, target)
            if there is None or here is None:
                continue
            gain = there - here
            if gain <= 0:
                continue
            key = (-gain, here, d)
            if best is None or key < best[0]:
                best = (key, RECEIVE0 + d)
        return best[1] if best else IDLE
    if mask[DELIVER]:
        return DELIVER
    target = r.item_target(held["product"], held["token"], held["final"], me)
    here = r.distance(me, target)
    if not here:  # at the target (0) or, defensively, cut off from it (None)
        return IDLE
    by_cell = {parse_cell(n["robot"]): n for n in obs["neighbours"]}
    best = None
    for d, (di, dj) in enumerate(DIRECTIONS):
        if not mask[HANDOFF0 + d]:
            continue
        dest = (me[0] + di, me[1] + dj)
        nb = by_cell.get(dest)
        if nb is None or nb["holding"] is not None or nb["busy"]:
            continue
        dist = r.distance(dest, target)
        if dist is None or dist >= here:
            continue
        cong = congestion(r, dest, by_cell) if parallel_aware else 0
        key = (dist, cong, -dj, abs(di), d)  # greedy: congestion is always 0
        if best is None or key < best[0]:
            best = (key, HANDOFF0 + d)
    return best[1] if best else IDLE


class GreedyController:
    """C-GREEDY (parallel_aware=False) and C-PARALLEL-AWARE (parallel_aware=True)."""

    information = "local"

    def __init__(self, parallel_aware: bool = False, grid: Mapping[str, Any] | None = None):
        self.parallel_aware = parallel_aware
        self.grid = grid  # the scenario grid (C-INFORMATION: public); None = the v1 default topology
        self.name = "parallel-aware" if parallel_aware else "greedy"

    def reset(self, seed: int | None = None) -> None:
        pass

    def act_one(self, obs: Obs) -> int:
        mask = obs["mask"]
        if obs["busy"] or not any(mask[1:]):
            return IDLE
        return self.choose(obs)

    def choose(self, obs: Obs) -> int:
        """The choice of a robot that is free and has a legal action besides idle."""
        op = operation_choice(obs)
        if op is not None:
            return op
        if obs.get("supports") is not None:
            return IDLE
        return logistics_choice(obs, self.parallel_aware, self.grid)

    def act(self, observations: Mapping[str, Obs], privileged: Any = None) -> dict[str, int]:
        return {robot: self.act_one(obs) for robot, obs in observations.items()}
