"""Centralized privileged reference (spec C-CENTRALIZED).

Each epoch it selects, from the globally admissible candidates (those compatible with every
committed activity), a compatible set of maximum productive weight with the original release's
group search (exact within its limits, greedy first-fit otherwise: C-CENTRALIZED-SEARCH).  Robots
keep supporting a pending candidate that is still enabled, otherwise support their first option
in the selected set, otherwise follow the Parallel-aware rule.  Admissions still go through the
normal support/admission path: the controller chooses actions, never outcomes.
"""

from __future__ import annotations

from typing import Any, Mapping

from agspec.controllers.base import IDLE, OP0, Obs
from agspec.controllers.greedy import GreedyController
from agspec.interp.candidates import Candidate
from agspec.interp.metrics import capacity_problem

# C-CENTRALIZED-SEARCH limits of the original release's exact search
EXACT_CANDIDATES, EXACT_GROUPS, EXACT_COMBINATIONS = 64, 6, 100_000


def productive_weight(sim, cand: Candidate) -> float:
    """M-WEIGHTED: op weight x (1 + downstream critical / critical path) x urgency x value, floored."""
    state, model = sim.state, sim.model
    product = state.products[cand.pid]
    recipe = model.recipes[product.recipe]
    # RES-CENTRALIZED-WEIGHT: the downstream critical path includes the operation itself and the
    # remaining work is the summed duration of the product's uncompleted operations.
    downstream = cand.op.duration + recipe.downstream[cand.op.id]
    remaining = sum(op.duration for op in recipe.operations if op.id not in product.completed)
    slack = product.due_time - state.t
    urgency = min(3.0, max(1.0, 2.0 - slack / max(1, remaining + 2)))
    crit = max(1, recipe.critical_path)
    return max(1e-6, cand.op.weight * (1.0 + downstream / crit) * urgency * product.value)


def _compatible(a, chosen, conflicts) -> bool:
    return all(a.group != b.group and frozenset((a.index, b.index)) not in conflicts
               and (a.xor_key is None or a.xor_key != b.xor_key) for b in chosen)


def _resources_ok(problem, chosen) -> bool:
    for r, cap in problem.resource_capacity.items():
        used = problem.resource_external_use.get(r, 0) + sum(1 for c in chosen if r in c.resources)
        if used > cap:
            return False
    return True


def weighted_selection(problem) -> list:
    """C-CENTRALIZED-SEARCH: greedy first-fit seed, then exact include-one-or-skip DFS within limits."""
    cands = list(problem.candidates)
    greedy: list = []
    for c in sorted(cands, key=lambda c: (-c.weight, c.size, -c.margin, c.id)):
        if _compatible(c, greedy, problem.conflicts) and _resources_ok(problem, greedy + [c]):
            greedy.append(c)
    groups: dict[Any, list] = {}
    for c in cands:
        groups.setdefault(c.group, []).append(c)
    combos = 1
    for g in groups.values():
        combos *= len(g) + 1
        if combos > EXACT_COMBINATIONS:
            break
    if len(cands) > EXACT_CANDIDATES or len(groups) > EXACT_GROUPS or combos > EXACT_COMBINATIONS:
        return greedy
    ordered = sorted(groups.items(), key=lambda kv: (len(kv[1]), kv[0][0], kv[0][1]))
    options = [sorted(g, key=lambda c: -c.weight) for _, g in ordered]
    best_max = [max(c.weight for c in g) for g in options]
    best = {"score": sum(c.weight for c in greedy), "set": list(greedy)}

    def dfs(k: int, chosen: list, score: float) -> None:
        if score > best["score"] + 1e-12:
            best["score"], best["set"] = score, list(chosen)
        if k == len(options):
            return
        if score + sum(best_max[k:]) <= best["score"] + 1e-12:  # admissible bound
            return
        for c in options[k]:
            if _compatible(c, chosen, problem.conflicts) and _resources_ok(problem, chosen + [c]):
                chosen.append(c)
                dfs(k + 1, chosen, score + c.weight)
                chosen.pop()
        dfs(k + 1, chosen, score)

    dfs(0, [], 0.0)
    return best["set"]


class CentralizedController:
    """C-CENTRALIZED: privileged weighted selection, Parallel-aware logistics."""

    name = "centralized"
    information = "global"

    def __init__(self, grid: Mapping[str, Any] | None = None) -> None:
        self._pa = GreedyController(parallel_aware=True, grid=grid)

    def reset(self, seed: int | None = None) -> None:
        pass

    def select(self, sim) -> set[str]:
        cands = sim.decision.candidates
        weights = {c.cid: productive_weight(sim, c) for c in cands}
        problem, _ = capacity_problem(sim.state, sim.model, cands, weights, sim.compatibility())
        return {c.id for c in weighted_selection(problem)}

    def act(self, observations: Mapping[str, Obs], privileged: Any = None) -> dict[str, int]:
        if privileged is None:
            raise ValueError("the centralized reference needs the privileged simulator view")
        selected = self.select(privileged)
        out = {}
        for robot, obs in observations.items():
            out[robot] = self.act_one(obs, selected)
        return out

    def act_one(self, obs: Obs, selected: set[str]) -> int:
        mask = obs["mask"]
        if obs["busy"] or not any(mask[1:]):
            return IDLE
        options = obs["operation_options"]
        pending = obs.get("supports")
        for k, opt in enumerate(options):
            if opt["id"] == pending and mask[OP0 + k]:
                return OP0 + k
        for k, opt in enumerate(options):
            if opt["id"] in selected and mask[OP0 + k]:
                return OP0 + k
        return self._pa.choose(obs)  # robots outside the selection follow Parallel-aware
