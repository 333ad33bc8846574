"""Every form of a joint action is one joint action (R-ACTION-VALIDATION, A-PZ-STEP, A-PZ-ARRAYS).

The interpreter takes a row-major list of plain ints without converting it, and the PettingZoo step
takes a complete dict without a per-agent loop; the generator below draws joint actions that mix
legal, masked-illegal, out-of-range and negative integers and replays each one in every form the two
entry points accept (list, tuple, NumPy integers, bools, a mapping in any key order, a partial
mapping), so a shortcut that skipped validation, reordered the applied actions or dropped a
coerced-action event for one form shows up as a difference between the forms.
"""

from __future__ import annotations

import copy
import random

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from agspec.catalogue import load_instance
from agspec.interp.observe import N_ACTIONS
from agspec.interp.snapshot import global_state
from agspec.interp.tick import Simulator

SCENARIOS = ("coalition-medium", "concurrency-hard")


def _draw_action(draw, mask) -> int:
    legal = [a for a, ok in enumerate(mask) if ok]
    kind = draw(st.sampled_from(("legal", "legal", "legal", "idle", "masked", "range")))
    if kind == "legal":
        return draw(st.sampled_from(legal))
    if kind == "idle":
        return 0
    if kind == "masked":
        illegal = [a for a, ok in enumerate(mask) if not ok]
        return draw(st.sampled_from(illegal)) if illegal else 0
    return draw(st.sampled_from((-1, N_ACTIONS, N_ACTIONS + 7, -N_ACTIONS)))


def _outcome(sim: Simulator, result) -> tuple:
    # types too: a NumPy integer that slipped through would compare equal and then fail to serialize
    kinds = [type(v).__name__ for v in result.applied.values()] + [
        type(e["action"]).__name__ for e in result.events if e["type"] == "action_coerced"]
    return (result.events, list(result.applied.items()), kinds, result.terminated, result.truncated,
            dict(sim.state.counters), global_state(sim.state))


def _forms(sim: Simulator, joint: list[int], shuffle: random.Random):
    """The same joint action as every input form Simulator.step accepts."""
    ids = list(sim.model.cell_ids)
    yield "list", list(joint)
    yield "tuple", tuple(joint)
    yield "numpy ints", [np.int64(a) for a in joint]
    yield "numpy array", np.asarray(joint, dtype=np.int64)
    yield "bools where 0 or 1", [bool(a) if a in (0, 1) else a for a in joint]
    yield "longer list", list(joint) + [0, 5]
    order = ids[:]
    shuffle.shuffle(order)
    yield "mapping, shuffled keys", {r: joint[ids.index(r)] for r in order}
    yield "mapping without idlers", {r: a for r, a in zip(ids, joint) if a != 0}


@pytest.mark.parametrize("scenario", SCENARIOS)
@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_every_form_of_a_joint_action_steps_alike(scenario, data):
    instance = load_instance(scenario, index=1000)
    reference = Simulator(instance, capacity=False)
    shuffle = random.Random(data.draw(st.integers(0, 2**16)))
    for _ in range(data.draw(st.integers(1, 25))):
        d = reference.decision
        joint = [_draw_action(data.draw, d.masks[c]) for c in reference.model.cells]
        outcomes = {}
        for name, form in _forms(reference, joint, shuffle):
            sim = Simulator(instance, capacity=False)
            sim.state, sim.decision, sim.metrics = _clone(reference)
            outcomes[name] = _outcome(sim, sim.step(form))
        expected = outcomes.pop("list")
        # R-ACTION-VALIDATION, absolutely: a legal action is applied as given, anything else as idle
        legal = [0 <= a < N_ACTIONS and d.masks[c][a] for c, a in zip(reference.model.cells, joint)]
        assert expected[1] == [(r, a if ok else 0) for r, a, ok in zip(reference.model.cell_ids, joint, legal)]
        coerced = [e["robot"] for e in expected[0] if e["type"] == "action_coerced"]
        assert coerced == [r for r, ok in zip(reference.model.cell_ids, legal) if not ok]
        for name, got in outcomes.items():
            assert got == expected, f"the joint action as {name} stepped differently from the plain list"
        reference.step(joint)
        assert all(type(a) is int for a in joint), "the interpreter changed the caller's list"
        if reference.done:
            break


def _clone(sim: Simulator):
    # one deep copy of everything a step reads and writes, so every form starts from the same epoch
    # (the model and its memos are shared: they are pure functions of their keys)
    return copy.deepcopy((sim.state, sim.decision, sim.metrics), memo={id(sim.model): sim.model})


@pytest.mark.parametrize("scenario", SCENARIOS)
@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**16))
def test_every_dict_form_of_a_pettingzoo_step_is_its_joint_step(scenario, seed):
    # the interpreter's test above needs no MARL extra; only this one is skipped without it
    pytest.importorskip("pettingzoo", reason="the MARL extra is not installed: pip install 'agspec[marl]'")
    from agspec.pettingzoo import parallel_env

    envs = [parallel_env(scenario, index=1000) for _ in range(4)]
    for env in envs:
        env.reset(seed=0)
    rng = random.Random(seed)
    agents = envs[0].possible_agents
    for _ in range(30):
        masks = envs[0].action_mask_array
        joint = []
        for row in masks:
            legal = np.flatnonzero(row)
            joint.append(int(rng.choice(legal)) if rng.random() < 0.8 else rng.choice((0, int(np.flatnonzero(row == 0)[0]), N_ACTIONS)))
        order = agents[:]
        rng.shuffle(order)
        shuffled = {a: joint[agents.index(a)] for a in order}
        partial = {a: v for a, v in zip(agents, joint) if v != 0}
        numpy_values = {a: np.int32(v) for a, v in zip(agents, joint)}
        result, _ = envs[0].step_joint(joint)
        outs = [env.step(form) for env, form in zip(envs[1:], (shuffled, partial, numpy_values))]
        for env, out in zip(envs[1:], outs):
            assert env.last_events == envs[0].last_events
            assert env.observation_array.tobytes() == envs[0].observation_array.tobytes()
            assert env.action_mask_array.tobytes() == envs[0].action_mask_array.tobytes()
            obs, _, _, _, infos = out
            assert list(obs) == agents and list(infos) == agents
            for k, a in enumerate(agents):
                assert infos[a]["applied_action"] == result.applied[a] in (joint[k], 0)  # as given, or coerced to idle
                assert obs[a]["action_mask"] is infos[a]["action_mask"]
                assert np.shares_memory(obs[a]["observation"], env.observation_array)
        if not envs[0].agents:
            break
