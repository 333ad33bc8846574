"""Gymnasium adapter: one agent controls every robot (optional extra ``agspec[marl]``; A-GYM-ENV).

    import gymnasium, agspec.gymnasium
    env = gymnasium.make("agspec/AssemblyGrid-v1", scenario="coalition-easy", index=1000)
"""

import gymnasium

from agspec.marl.centralized import CentralizedEnv, make_env

ENV_ID = "agspec/AssemblyGrid-v1"
if ENV_ID not in gymnasium.registry:
    gymnasium.register(ENV_ID, entry_point="agspec.marl.centralized:CentralizedEnv")

__all__ = ["CentralizedEnv", "ENV_ID", "make_env"]
