"""The actor trained by benchmarks/recipe_torchrl.py, as an agspec policy (F-POLICY-PYTHON).

    AGSPEC_TORCHRL_ACTOR=runs/torchrl/actor.pt agspec evaluate --policy benchmarks/recipe_torchrl_policy.py:make_policy

The weights are loaded at import (once per worker, F-POLICY-HOST); each robot plays the masked
argmax of the shared actor's logits, first index on ties, as the paper evaluates learned policies.
"""

import os

import numpy as np
import torch
from torch import nn

from agspec import threads

OBS_DIM, N_ACTIONS = 1566, 114


def actor_network() -> nn.Module:
    """The shared actor: the robot's A-OBS-VECTOR -> 114 logits (the recipe's, not the paper's network)."""
    return nn.Sequential(nn.LayerNorm(OBS_DIM), nn.Linear(OBS_DIM, 256), nn.Tanh(), nn.Linear(256, 256), nn.Tanh(),
                         nn.Linear(256, N_ACTIONS))


if __name__ != "__main__" and os.environ.get("AGSPEC_TORCHRL_ACTOR"):
    threads.apply_inherited()  # CAMP-THREADS: the host's budget (agspec's -j N runs N workers)
    ACTOR = actor_network()
    ACTOR.load_state_dict(torch.load(os.environ["AGSPEC_TORCHRL_ACTOR"], map_location="cpu"))
    ACTOR.eval()


def make_policy(env):
    agents = list(env.possible_agents)

    def act(observations, infos):
        obs = torch.from_numpy(np.stack([observations[a]["observation"] for a in agents]))
        mask = torch.from_numpy(np.stack([observations[a]["action_mask"] for a in agents]).astype(bool))
        with torch.no_grad():
            logits = ACTOR(obs).masked_fill(~mask, float("-inf"))
        return {a: int(x) for a, x in zip(agents, logits.argmax(dim=-1))}

    return act
