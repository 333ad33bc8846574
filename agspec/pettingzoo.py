"""PettingZoo adapter (optional extra ``agspec[marl]``; spec/12-adapters.md, A-PZ-*).

    from agspec.pettingzoo import parallel_env, coalition_milestone_v1
    env = coalition_milestone_v1(parallel_env("coalition-medium", index=1000))
"""

from agspec.marl.parallel import AdapterError, AssemblyGridParallelEnv, parallel_env
from agspec.marl.wrappers import CoalitionMilestoneV1, coalition_milestone_v1

__all__ = ["AdapterError", "AssemblyGridParallelEnv", "CoalitionMilestoneV1", "coalition_milestone_v1", "parallel_env"]
