"""Opt-in reward wrappers (spec/12-adapters.md, A-REWARD-MILESTONE).

Method-level, not benchmark-level: the benchmark reports the measures of chapter 7 whatever reward a
method trained on.
"""

from __future__ import annotations

from dataclasses import asdict
from typing import Any, Mapping

from pettingzoo.utils import BaseParallelWrapper

from agspec.marl.rewards import milestone_rewards

CREDIT_MODES = ("agent", "mean", "none")


class CoalitionMilestoneV1(BaseParallelWrapper):
    """The paper's training reward ``coalition_milestone_v1``.

    Every agent gets ``r_team = 0.10Δp + 2.0Δcoal + 3.0Δop + 11.0Δdeliv − 0.25Δfail − 0.05Δchurn − 0.001``
    plus the support credit: ``0.05·c_sup(u)`` per agent (``support_credit="agent"``, the paper's
    IPPO/MAPPO form), ``0.05·mean_u c_sup(u)`` for all (``"mean"``, the QMIX form) or nothing
    (``"none"``).  The 11.0 per delivery is the paper's sum of the 1.0 sparse environment reward and
    the 10.0 milestone term, so this reward replaces the environment's rather than adding to it.
    """

    def __init__(self, env: Any, support_credit: str = "agent"):
        super().__init__(env)
        if support_credit not in CREDIT_MODES:
            raise ValueError(f"support_credit must be one of {CREDIT_MODES}, got {support_credit!r}")
        self.credit_mode = support_credit

    def step(self, actions: Mapping[str, Any]):
        obs, _env_rewards, terms, truncs, infos = self.env.step(actions)
        base = self.env.unwrapped
        milestone, credit, rewards = milestone_rewards(base.last_events, base.supporting_before, base.supporting(),
                                                       self.credit_mode)
        for agent in obs:
            infos[agent] = {**infos[agent], "milestone": asdict(milestone), "support_credit": credit[agent]}
        return obs, {agent: rewards[agent] for agent in obs}, terms, truncs, infos


def coalition_milestone_v1(env: Any, support_credit: str = "agent") -> CoalitionMilestoneV1:
    """Wrap a parallel env with the paper's team reward (A-REWARD-MILESTONE)."""
    return CoalitionMilestoneV1(env, support_credit)
