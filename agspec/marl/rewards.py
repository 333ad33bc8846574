"""Training rewards (spec/12-adapters.md, A-REWARD-SPARSE, A-REWARD-MILESTONE).

Rewards belong to the method layer: no benchmark measure (chapter 7) depends on them.  Both are
computed from the events of one step (R-TICK-ORDER), so any simulator with the same events gives the
same rewards.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass
from typing import Any, Iterable, Mapping, Sequence

# A-REWARD-MILESTONE: the paper's team reward coefficients (training-reward equation).
MILESTONE_COEFFICIENTS = {
    "progress": 0.10,
    "coalition": 2.0,
    "operation": 3.0,
    "delivery": 11.0,
    "failure": -0.25,
    "churn": -0.05,
}
STEP_COST = -0.001
SUPPORT_CREDIT = 0.05
PROGRESS_EVENTS = ("pick_completed", "handoff_completed", "admitted", "operation_completed", "delivered")


@dataclass(frozen=True)
class MilestoneTerms:
    """The counts Δp, Δcoal, Δop, Δdeliv, Δfail, Δchurn of one step."""

    progress: int
    coalition: int
    operation: int
    delivery: int
    failure: int
    churn: int

    @staticmethod
    def of(events: Iterable[Mapping[str, Any]]) -> "MilestoneTerms":
        n = Counter(e["type"] for e in events)
        return MilestoneTerms(
            progress=sum(n[k] for k in PROGRESS_EVENTS),
            coalition=n["admitted"],
            operation=n["operation_completed"],
            delivery=n["delivered"],
            failure=n["admission_failed"],
            churn=n["support_switched"],
        )

    def team_reward(self) -> float:
        """r_team = 0.10Δp + 2.0Δcoal + 3.0Δop + 11.0Δdeliv − 0.25Δfail − 0.05Δchurn − 0.001."""
        c = MILESTONE_COEFFICIENTS
        return (
            c["progress"] * self.progress
            + c["coalition"] * self.coalition
            + c["operation"] * self.operation
            + c["delivery"] * self.delivery
            + c["failure"] * self.failure
            + c["churn"] * self.churn
            + STEP_COST
        )


def support_credit(before: Mapping[str, bool], after: Mapping[str, bool]) -> dict[str, int]:
    """c_sup(u) = 1 iff u held no pending support before the step and holds one after it.

    A switch between candidates (pending before and after) and a support admitted in the same tick
    (no pending support after) both give 0.
    """
    return {u: int(not before[u] and after[u]) for u in before}


def milestone_rewards(events: Iterable[Mapping[str, Any]], before: Mapping[str, bool], after: Mapping[str, bool],
                      credit_mode: str) -> tuple[MilestoneTerms, dict[str, int], dict[str, float]]:
    """A-REWARD-MILESTONE for one step: the terms, c_sup per agent, and each agent's reward with the
    support credit per agent (``"agent"``), as the agents' mean (``"mean"``) or none (``"none"``)."""
    terms = MilestoneTerms.of(events)
    team = terms.team_reward()
    credit = support_credit(before, after)
    if credit_mode == "agent":
        bonus = {u: float(c) for u, c in credit.items()}
    else:
        shared = sum(credit.values()) / max(len(credit), 1) if credit_mode == "mean" else 0.0
        bonus = dict.fromkeys(credit, shared)
    return terms, credit, {u: team + SUPPORT_CREDIT * bonus[u] for u in credit}


def delivered_value(events: Iterable[Mapping[str, Any]], products: Sequence[Any]) -> float:
    """A-REWARD-SPARSE: the value of the products delivered in this step (1.0 each on the catalogue);
    ``products`` is the state's product list, indexed by product id."""
    return float(sum(products[int(e["product"])].value for e in events if e["type"] == "delivered"))
