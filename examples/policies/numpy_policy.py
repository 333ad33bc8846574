"""A small NumPy policy trained on the PettingZoo env (see train_numpy.py); no deep-learning framework.

    agspec evaluate --policy examples/policies/numpy_policy.py:make_policy --name numpy-cem

Each legal action gets a linear score w · φ(a, o) of hand-made action features (its kind, its
direction, the support fraction of an operation slot read from the observation vector); the policy
plays the highest-scoring legal action, deterministically, as the paper evaluates learned policies.
Weights come from numpy_policy.json next to this file (or the file named by AGSPEC_POLICY_WEIGHTS).
"""

import json
import os
from pathlib import Path

import numpy as np

N_ACTIONS, OP0, OP_SLOTS, OP_OFFSET, OP_DIM = 114, 50, 64, 286, 20
N_FEATURES = 6 + 8 + 8 + 1  # kind one-hot, handoff direction, receive direction, operation support


def kind_features() -> np.ndarray:
    """The observation-independent part of φ(a): one row per action."""
    phi = np.zeros((N_ACTIONS, N_FEATURES - 1), dtype=np.float32)
    for a in range(N_ACTIONS):
        kind = 0 if a == 0 else 1 if a == 1 else 2 if a < 34 else 3 if a < 42 else 4 if a < 50 else 5
        phi[a, kind] = 1.0
        if 34 <= a < 42:
            phi[a, 6 + a - 34] = 1.0
        if 42 <= a < 50:
            phi[a, 14 + a - 42] = 1.0
    return phi


PHI = kind_features()
SLOT_TIEBREAK = -1e-4 * np.arange(N_ACTIONS)  # lower slots first among equal scores


def scores(weights: np.ndarray, observation: np.ndarray) -> np.ndarray:
    support = observation[OP_OFFSET + 8:OP_OFFSET + OP_SLOTS * OP_DIM:OP_DIM]  # support fraction per op slot
    s = PHI @ weights[:-1] + SLOT_TIEBREAK
    s[OP0:] += weights[-1] * support
    return s


def choose(weights: np.ndarray, obs: dict) -> int:
    s = scores(weights, obs["observation"])
    s[obs["action_mask"] == 0] = -np.inf
    return int(np.argmax(s))


def load_weights() -> np.ndarray:
    path = Path(os.environ.get("AGSPEC_POLICY_WEIGHTS", Path(__file__).with_name("numpy_policy.json")))
    return np.asarray(json.loads(path.read_text())["weights"], dtype=np.float32)


def make_policy(env, weights=None):
    w = load_weights() if weights is None else np.asarray(weights, dtype=np.float32)

    def act(observations, infos):
        return {agent: choose(w, obs) for agent, obs in observations.items()}

    return act
