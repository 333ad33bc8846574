"""The PettingZoo adapter's observations and masks, byte for byte (A-OBS-VECTOR, O-MASK).

tests/golden/pettingzoo/digests.json holds per-step digests of every agent's vector and mask on
scripted episodes, recorded with the release whose adapter encoded each structured observation
record separately (tests/golden/pettingzoo/record.py).  The adapter now encodes all agents at once
(agspec.marl.batch); it must give the same bytes, and the same vectors as encode_observation.
"""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pettingzoo", reason="the MARL extra is not installed: pip install 'agspec[marl]'")

from agspec.marl.encoding import PublicInfo, encode_observation  # noqa: E402
from agspec.pettingzoo import parallel_env  # noqa: E402

GOLDEN = Path(__file__).parent / "golden" / "pettingzoo"
_spec = importlib.util.spec_from_file_location("pz_golden_record", GOLDEN / "record.py")
record = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(record)
EPISODES = json.loads((GOLDEN / "digests.json").read_text())


@pytest.mark.parametrize("episode", EPISODES, ids=lambda e: f"{e['scenario']}-{e['index']}")
def test_observations_match_the_recorded_digests(episode):
    got = record.episode_digests(episode["scenario"], episode["index"], episode["steps"])
    first_bad = next((t for t, (a, b) in enumerate(zip(got, episode["digests"])) if a != b), None)
    assert first_bad is None, f"observation bytes differ from the recording at step {first_bad}"
    assert len(got) == len(episode["digests"])


@pytest.mark.parametrize("scenario", ["coalition-medium", "concurrency-hard"])
def test_the_all_agents_encoder_equals_encode_observation_of_every_record(scenario):
    env = parallel_env(scenario, index=1000, max_cycles=60)
    pub = PublicInfo.of(env.sim.model)
    obs, _ = env.reset(seed=0)
    t = 0
    while env.agents:
        records = env.sim.observe()
        for agent, o in obs.items():
            expected = encode_observation(records[agent], pub)
            assert o["observation"].dtype == np.float32 and o["action_mask"].dtype == np.int8
            assert o["observation"].tobytes() == expected.tobytes(), f"{agent} at t={t}"
            assert o["action_mask"].tolist() == [int(b) for b in records[agent]["mask"]]
        obs, *_ = env.step(record.scripted_actions(obs, t))
        t += 1
