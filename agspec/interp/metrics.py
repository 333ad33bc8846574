"""Outcome measures and mechanism diagnostics (spec chapter 07, IDs M-*).

Sampling convention (M-SAMPLING): one pre-action sample and one post-start sample per decision
epoch t = 0..T-1, and one WIP sample after each clock advance (t = 1..T).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from itertools import combinations
from typing import Any

from agspec.interp import capacity as cap
from agspec.interp.candidates import Candidate
from agspec.interp.model import Model
from agspec.interp.rules import blocking_cause, geometric_conflict, shares_exclusive
from agspec.interp.state import State


@dataclass
class CapacitySnapshot:
    """M-CAPACITY: K*(s_t) and what it was computed from."""

    k_star: int
    running: int
    exact: bool
    compatible: list[Candidate] = field(default_factory=list)
    selected: tuple[str, ...] = ()


@dataclass(frozen=True)
class Compatibility:
    """The weight-free part of one state's M-CAPACITY problem: the running operations, the
    candidates compatible with every reservation, their pairwise conflicts (by position in
    ``compatible``) and the finite-capacity resources with their committed use."""

    running: int
    compatible: list[Candidate]
    conflicts: set[frozenset[int]]
    resource_capacity: dict[str, int]
    resource_external_use: dict[str, int]


def compatibility(state: State, model: Model, candidates: list[Candidate]) -> Compatibility:
    """M-CAPACITY: running operations plus candidates compatible with every reservation, and what
    excludes them from each other."""
    running = sum(1 for a in state.activities if a.is_operation)
    compatible = [
        c for c in candidates if blocking_cause(state, model, c.members, c.resources, c.plan, c.target) is None
    ]
    conflicts = set()
    for a, b in combinations(range(len(compatible)), 2):
        ca, cb = compatible[a], compatible[b]
        if (
            not set(ca.members).isdisjoint(cb.members)
            or shares_exclusive(model, ca.resources, cb.resources)
            or geometric_conflict(model, ca.plan, ca.target, ca.members, cb.plan, cb.target, cb.members)
        ):
            conflicts.add(frozenset((a, b)))
    finite = {r: model.resource_cap(r) for c in compatible for r in c.resources if model.resource_cap(r) > 1}
    external = {r: sum(1 for act in state.activities if r in act.resources and not act.is_operation) for r in finite}
    # running operations are members of every feasible set: their use of finite resources counts too
    for r in finite:
        external[r] += sum(1 for act in state.activities if r in act.resources and act.is_operation)
    return Compatibility(running, compatible, conflicts, finite, external)


def capacity_problem(state: State, model: Model, candidates: list[Candidate], weights: dict[str, float] | None = None,
                     compat: Compatibility | None = None):
    """Build the M-CAPACITY problem: running operations plus candidates compatible with every reservation.
    ``compat`` is :func:`compatibility` of this state and these candidates when the caller already has it."""
    if compat is None:
        compat = compatibility(state, model, candidates)
    cands = []
    for k, c in enumerate(compat.compatible):
        xor_key = (c.pid, c.op.xor_group) if c.op.xor_group else None
        cands.append(
            cap.Cand(
                index=k,
                group=(c.pid, c.op.id),
                xor_key=xor_key,
                resources=tuple(sorted(c.resources)),
                weight=(weights or {}).get(c.cid, 1.0),
                size=c.size,
                duration=c.plan.duration,
                margin=c.plan.min_reach_margin,
                id=c.cid,
            )
        )
    problem = cap.CapacityProblem(
        running=compat.running,
        candidates=cands,
        conflicts=compat.conflicts,
        resource_capacity=compat.resource_capacity,
        resource_external_use=compat.resource_external_use,
    )
    return problem, compat.compatible


def capacity_snapshot(state: State, model: Model, candidates: list[Candidate],
                      compat: Compatibility | None = None) -> CapacitySnapshot:
    problem, compatible = capacity_problem(state, model, candidates, compat=compat)
    result = cap.solve_count(problem)
    return CapacitySnapshot(
        k_star=result.k_star, running=problem.running, exact=result.exact, compatible=compatible,
        selected=tuple(result.selected),
    )


# A-PZ-CAPACITY: the measures computed from step 1's M-CAPACITY and M-RF-BR samples
CAPACITY_MEASURES = ("ready_feasible_fraction", "blocked_ready_rate", "blocked_ready_rate_material", "capacity_mean",
                     "utilization", "utilization_approx", "utilization_samples", "capacity_exact_fraction")


def percentile(values: list[float], q: float) -> float:
    """Element at index round(q (n-1)) of the sorted values (half-to-even), 0.0 when empty."""
    if not values:
        return 0.0
    ordered = sorted(values)
    k = min(len(ordered) - 1, max(0, round(q * (len(ordered) - 1))))
    return float(ordered[k])


class MetricsAccumulator:
    """Collects per-epoch samples; :meth:`final` turns them into the metrics of chapter 07."""

    def __init__(self, model: Model, capacity: bool = True):
        self.model = model
        self.capacity = capacity  # A-PZ-CAPACITY: whether step 1's M-CAPACITY / M-RF-BR samples are taken
        self.samples = 0
        self.k_star_sum = 0
        self.k_realized_sum = 0
        self.coop_sum = 0
        self.busy_sum = 0.0
        self.exact_samples = 0
        self.util_exact: list[float] = []
        self.util_approx: list[float] = []
        self.ready_sum = 0
        self.ready_material_sum = 0
        self.feasible_sum = 0
        self.wip_sum = 0
        self.wip_samples = 0
        self.no_progress = 0
        self._k_star = 0
        self._exact = True

    def pre_action(self, capacity: CapacitySnapshot, n_ready: int, n_ready_material: int, n_feasible: int) -> None:
        self._k_star, self._exact = capacity.k_star, capacity.exact
        self.k_star_sum += capacity.k_star
        self.exact_samples += 1 if capacity.exact else 0
        self.ready_sum += n_ready
        self.ready_material_sum += n_ready_material
        self.feasible_sum += n_feasible

    def sample(self, state: State) -> None:
        """M-REALIZED-CONCURRENCY, M-OCCUPANCY, M-UTILIZATION at epoch t after this epoch's starts."""
        t = state.t
        teams = [a for a in state.activities if a.is_operation and a.end > t]
        k_t = len(teams)
        self.samples += 1
        self.k_realized_sum += k_t
        self.coop_sum += sum(1 for a in teams if len(a.members) >= 2)
        busy = [r.busy_until > t or r.incoming is not None for r in state.robots.values()].count(True)  # not free (R-EXECUTION)
        self.busy_sum += busy / len(state.robots)
        if self._k_star > 0:
            (self.util_exact if self._exact else self.util_approx).append(k_t / self._k_star)

    def post_advance(self, state: State, progress: int) -> None:
        """M-MEAN-WIP sample and the R-NO-PROGRESS indicator (counted by M-NO-PROGRESS) after the clock advance."""
        self.wip_sum += state.wip
        self.wip_samples += 1
        team_active = any(a.is_operation for a in state.activities)
        if state.wip > 0 and progress == 0 and not team_active:
            self.no_progress += 1

    def final(self, state: State) -> dict[str, Any]:
        model = self.model
        c = state.counters
        t_end = max(1, state.t)
        delivered = state.delivered
        released = state.released
        opportunities = state.release_opportunities
        flow = [p.complete_time - p.spawn_time for p in state.products if p.delivered]
        rmft_terms = [(p.complete_time if p.delivered else state.t) - p.spawn_time for p in state.products]
        admissions = int(c.get("team_formation_count", 0))
        failures = int(c.get("team_formation_failures", 0))
        co_adm = int(c.get("coalition_formation_count", 0))
        co_fail = int(c.get("coalition_formation_failures", 0))
        parts = [r.team_participations for r in state.robots.values()]
        mean_part = sum(parts) / len(parts)
        cv = (math.sqrt(sum((p - mean_part) ** 2 for p in parts) / len(parts)) / mean_part) if mean_part > 0 else 0.0
        batch_done = model.mode == "batch" and delivered >= (model.batch_size or 0) and released >= (model.batch_size or 0)
        out = {
            # outcome measures
            "delivered": delivered,
            "released": released,
            "release_opportunities": opportunities,
            "lost_releases": state.lost_releases,
            "throughput": delivered / t_end,
            "completion_rate": delivered / released if released else None,
            "release_acceptance": released / opportunities if opportunities else None,
            "demand_fulfillment": delivered / opportunities if opportunities else None,
            "mean_wip": self.wip_sum / max(1, self.wip_samples),
            "restricted_mean_flow_time": sum(rmft_terms) / len(rmft_terms) if rmft_terms else None,
            "mean_flow_time": sum(flow) / len(flow) if flow else None,  # M-FLOW-TIME
            "flow_time_p50": percentile(flow, 0.5),
            "flow_time_p90": percentile(flow, 0.9),
            "unfinished_count": released - delivered,
            "makespan": (max(p.complete_time for p in state.products) - min(p.spawn_time for p in state.products))
            if batch_done
            else None,
            "timed_out": (model.mode == "batch" and not batch_done),
            # admission and coalition diagnostics
            "admissions": admissions,
            "admission_failures": failures,
            "admission_success": admissions / (admissions + failures) if admissions + failures else None,
            "admission_latency": c.get("team_formation_latency_sum", 0) / admissions if admissions else None,
            "coalition_admissions": co_adm,
            "coalition_failures": co_fail,
            "coalition_success": co_adm / (co_adm + co_fail) if co_adm + co_fail else None,
            "coalition_latency": c.get("coalition_formation_latency_sum", 0) / co_adm if co_adm else None,
            "candidate_switches": int(c.get("team_proposal_churn", 0)),
            "mean_team_size": c.get("team_size_sum", 0) / admissions if admissions else 0.0,
            "team_load_cv": cv,
            # blocking
            "blocked_activities": int(c.get("trajectory_conflict_count", 0)),
            "geometry_blocked": int(c.get("geometry_block_count", 0)),
            "resource_blocked": int(c.get("resource_block_count", 0)),
            "robot_blocked": int(c.get("robot_block_count", 0)),
            "geometry_rejections": int(c.get("reject_motion_infeasible", 0)),
            "geometry_delay_ticks": int(c.get("geometry_delay_ticks", 0)),
            "motion_duration_total": int(c.get("motion_duration_total", 0)),
            "motion_path_length": float(c.get("motion_path_length", 0.0)),
            "minimum_reach_margin": float(c.get("minimum_reach_margin", 0.0)),
            # occupancy, readiness, progress
            "robot_occupancy": self.busy_sum / max(1, self.samples),
            "ready_feasible_fraction": self.feasible_sum / self.ready_sum if self.ready_sum else None,
            "blocked_ready_rate": 1 - self.feasible_sum / self.ready_sum if self.ready_sum else None,
            # DIV-BR-READY-SET: the original release's variant counts only occurrences whose inputs exist;
            # M-RATIO-FORMS: (ready - feasible) / ready, the original's arithmetic, not 1 - feasible / ready
            "blocked_ready_rate_material": (self.ready_material_sum - self.feasible_sum) / self.ready_material_sum
            if self.ready_material_sum else None,
            "no_progress_ticks": self.no_progress,
            "handoffs": int(c.get("handoff_count", 0)),
            "handoffs_per_delivered": c.get("handoff_count", 0) / max(1, delivered),  # M-HANDOFFS
            # productive concurrency
            "capacity_mean": self.k_star_sum / max(1, self.samples),
            "realized_concurrency_mean": self.k_realized_sum / max(1, self.samples),
            "cooperative_concurrency_mean": self.coop_sum / max(1, self.samples),
            "utilization": sum(self.util_exact) / len(self.util_exact) if self.util_exact else None,
            "utilization_approx": sum(self.util_approx) / len(self.util_approx) if self.util_approx else None,
            "utilization_samples": len(self.util_exact),
            "capacity_exact_fraction": self.exact_samples / max(1, self.samples),
            "invalid_actions": int(c.get("invalid_attempts", 0)),
            "lost_releases_raw_material": int(c.get("lost_releases_raw_material", 0)),
            "ticks": state.t,
        }
        if not self.capacity:  # A-PZ-CAPACITY: measures of samples never taken are null, never zero
            out.update(dict.fromkeys(CAPACITY_MEASURES))
        return out
