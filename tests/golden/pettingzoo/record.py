"""Record the golden digests of the PettingZoo adapter's observations (A-OBS-VECTOR) and masks (O-MASK).

The digests were recorded with the release whose encoder built every vector from the structured
observation record (encode_observation); tests/test_pettingzoo_golden.py replays the same episodes
and requires the same bytes from whatever encoder the adapter uses now.

    python tests/golden/pettingzoo/record.py > tests/golden/pettingzoo/digests.json
"""

from __future__ import annotations

import hashlib
import json

import numpy as np

from agspec.pettingzoo import parallel_env

# (scenario, instance index, steps): the adapter's heaviest official cells plus two others
EPISODES = (("coalition-medium", 1000, 400), ("concurrency-hard", 1000, 400), ("flow-hard", 1000, 150),
            ("coalition-hard", 1001, 150))


def scripted_actions(obs: dict, t: int) -> dict[str, int]:
    """A deterministic action rule over the legal actions (no RNG, so any release replays it)."""
    actions = {}
    for k, (agent, o) in enumerate(obs.items()):
        legal = np.flatnonzero(o["action_mask"])
        actions[agent] = int(legal[(t * 7 + k * 13) % len(legal)])
    return actions


def step_digest(obs: dict) -> str:
    h = hashlib.sha256()
    for agent, o in obs.items():
        h.update(agent.encode())
        h.update(np.ascontiguousarray(o["observation"], dtype=np.float32).tobytes())
        h.update(np.ascontiguousarray(o["action_mask"], dtype=np.int8).tobytes())
    return h.hexdigest()[:20]


def episode_digests(scenario: str, index: int, steps: int) -> list[str]:
    env = parallel_env(scenario, index=index, max_cycles=steps)
    obs, _ = env.reset(seed=0)
    out = [step_digest(obs)]
    t = 0
    while env.agents:
        obs, *_ = env.step(scripted_actions(obs, t))
        t += 1
        out.append(step_digest(obs))
    return out


if __name__ == "__main__":
    print(json.dumps([{"scenario": s, "index": i, "steps": n, "digests": episode_digests(s, i, n)}
                      for s, i, n in EPISODES], indent=0))
