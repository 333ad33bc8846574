"""A MaskablePPO model trained by benchmarks/recipe_sb3.py, as an agspec policy (F-POLICY-PYTHON).

    AGSPEC_SB3_MODEL=runs/sb3/model.zip agspec evaluate --policy benchmarks/recipe_sb3_policy.py:make_policy

The model is loaded at import, which agspec does once per worker (F-POLICY-HOST); the factory only
binds it to the episode.  Every robot's action is the masked argmax of the shared policy
(``deterministic=True``), as the paper evaluates learned policies.
"""

import os

import numpy as np
from sb3_contrib import MaskablePPO

from agspec import threads

threads.apply_inherited()  # CAMP-THREADS: the host's budget (agspec's -j N runs N workers)
MODEL = MaskablePPO.load(os.environ.get("AGSPEC_SB3_MODEL", "runs/sb3/model.zip"), device="cpu")


def make_policy(env):
    agents = list(env.possible_agents)

    def act(observations, infos):
        batch = {key: np.stack([observations[a][key] for a in agents]) for key in ("observation", "action_mask")}
        actions, _ = MODEL.predict(batch, action_masks=batch["action_mask"].astype(bool), deterministic=True)
        return {a: int(x) for a, x in zip(agents, actions)}

    return act
