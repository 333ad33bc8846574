"""A hand-written policy for `agspec evaluate --policy examples/policies/heuristic.py:make_policy`.

Written only against the policy contract (spec/13-policy.md, F-POLICY-PYTHON): the factory gets the
episode's PettingZoo ParallelEnv and returns a callable (observations, infos) -> actions, where each
observation is {"observation": float32[1566], "action_mask": int8[114]} and an action is an int.
"""

import numpy as np

# O-ACTION-ENCODING: 0 idle, 1 deliver, 2..33 pick, 34..41 hand off toward d, 42..49 receive from d,
# 50..113 support an operation option. Directions d: 0 N, 1 NE, 2 E, 3 SE, 4 S, 5 SW, 6 W, 7 NW.
DELIVER, PICK, HANDOFF, RECEIVE, OPERATION = 1, range(2, 34), range(34, 42), range(42, 50), range(50, 114)
EASTWARD = (2, 1, 3)  # material flows from the shelves (west) to the output column (east)
FROM_WEST = (6, 7, 5)
PREFERENCE = [DELIVER, *OPERATION, *PICK, *(HANDOFF[d] for d in EASTWARD), *(RECEIVE[d] for d in FROM_WEST)]


def make_policy(env):
    def act(observations, infos):
        actions = {}
        for agent, obs in observations.items():
            legal = np.flatnonzero(obs["action_mask"])
            actions[agent] = next((a for a in PREFERENCE if obs["action_mask"][a]), int(legal[0]))
        return actions

    return act
