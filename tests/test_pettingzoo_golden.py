"""The PettingZoo adapter's observations and masks, byte for byte (A-OBS-VECTOR, O-MASK).

tests/golden/pettingzoo/digests.json holds per-step digests of every agent's vector and mask on
scripted episodes, recorded with the release whose adapter encoded each structured observation
record separately (tests/golden/pettingzoo/record.py).  The adapter now encodes all agents at once
(agspec.marl.batch) into two arrays that the per-agent dicts view (A-PZ-ARRAYS); it must give the
same bytes, and the same vectors as encode_observation, on the official cells and on generated
scenarios of every topology and variant.
"""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

pytest.importorskip("pettingzoo", reason="the MARL extra is not installed: pip install 'agspec[marl]'")

from agspec.interp.observe import SlotOverflow  # noqa: E402
from agspec.marl.encoding import PublicInfo, encode_observation  # noqa: E402
from agspec.pettingzoo import parallel_env  # noqa: E402
from strategies_scenarios import bundles  # noqa: E402

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


def _same_as_the_records(env, obs, pub, where: str) -> None:
    """Every agent's entries are row views of the env's arrays and equal encode_observation of its
    O-OBSERVATION record, byte for byte, and its O-MASK (A-PZ-ARRAYS, A-OBS-VECTOR)."""
    records = env.sim.observe()
    assert list(obs) == env.possible_agents
    for k, (agent, o) in enumerate(obs.items()):
        assert np.shares_memory(o["observation"], env.observation_array)
        assert np.shares_memory(o["action_mask"], env.action_mask_array)
        assert o["observation"].tobytes() == env.observation_array[k].tobytes()
        expected = encode_observation(records[agent], pub)
        assert o["observation"].tobytes() == expected.tobytes(), f"{agent} {where}"
        assert o["action_mask"].tolist() == [int(b) for b in records[agent]["mask"]], f"{agent} {where}"


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(bundles(), st.integers(0, 2**16))
def test_the_arrays_equal_the_records_on_generated_scenarios(bundle, seed):
    """Generated scenarios (every topology, radius and rule variant): two episodes of masked random
    actions (the second after a reset, so nothing of the first may linger in the arrays), the arrays
    equal to the per-record encoding at every step, and kept arrays never change afterwards."""
    env = parallel_env(bundle.instance, max_cycles=25)
    pub = PublicInfo.of(env.sim.model)
    rng = np.random.default_rng(seed)
    for episode in range(2):
        try:
            obs, _ = env.reset(seed=seed)
            kept = [(env.observation_array, env.observation_array.copy())]
            t = 0
            while env.agents:
                _same_as_the_records(env, obs, pub, f"episode {episode} t={t}\n{bundle.describe()}")
                actions = {a: int(rng.choice(np.flatnonzero(o["action_mask"]))) for a, o in obs.items()}
                obs, *_ = env.step(actions)
                kept.append((env.observation_array, env.observation_array.copy()))
                t += 1
            _same_as_the_records(env, obs, pub, f"episode {episode} end\n{bundle.describe()}")
        except SlotOverflow:  # O-ACTION-ENCODING: the reference refuses such a state; nothing to compare
            continue
        assert all(a.tobytes() == b.tobytes() for a, b in kept)
