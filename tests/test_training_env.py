"""Split environments and the paper's training realizations (spec/12-adapters.md, A-PZ-SPLIT,
A-TRAINING-REALIZATIONS, RES-SPLIT-CYCLE, RES-TRAINING-SEED-RANGE).

The class of defect: a training loop (a wrapper, a vector env, a library's runner) that resets with
seeds and never passes options stays on one instance.  The generator drives a split environment
with any sequence of seeded and unseeded resets and steps, and checks that the instance each reset
plays is the one the counting rule names, so that every realization is visited.
"""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from agspec.catalogue import SPLITS, load_scenario_bundle
from agspec.ir.fingerprint import fingerprint
from agspec.ir.instance import make_instance
from agspec.marl import curriculum as C

pytest.importorskip("pettingzoo", reason="the MARL extra is not installed: pip install 'agspec[marl]'")
from agspec.pettingzoo import AdapterError, parallel_env  # noqa: E402

FAMILIES = ("coalition", "flow", "concurrency")


# --------------------------------------------------------------------------- the seed formula


@given(family=st.sampled_from(FAMILIES), seed=st.integers(0, C.MAX_SEED), stage=st.integers(0, C.MAX_STAGE),
       r=st.integers(0, C.REALIZATIONS - 1))
@settings(max_examples=200, deadline=None)
def test_training_seeds_follow_the_original_formula(family, seed, stage, r):  # A-TRAINING-REALIZATIONS
    offset = {"coalition": 0, "flow": 300_000, "concurrency": 600_000}[family]
    gen, exe = C.training_seeds(family, seed, stage, r)
    assert gen == 80_000 + offset + 100 * seed + 10 * stage + r
    assert exe == 90_000 + offset + 100 * seed + 10 * stage + r


@given(a=st.tuples(st.sampled_from(FAMILIES), st.integers(0, C.MAX_SEED), st.integers(0, C.MAX_STAGE),
                   st.integers(0, C.REALIZATIONS - 1)),
       b=st.tuples(st.sampled_from(FAMILIES), st.integers(0, C.MAX_SEED), st.integers(0, C.MAX_STAGE),
                   st.integers(0, C.REALIZATIONS - 1)))
@settings(max_examples=300, deadline=None)
def test_two_runs_never_share_a_training_realization(a, b):  # RES-TRAINING-SEED-RANGE
    if a != b:
        assert C.training_seeds(*a)[0] != C.training_seeds(*b)[0]


def test_training_seeds_never_reach_an_evaluation_instance():  # A-TRAINING-REALIZATIONS
    lowest = min(C.training_seeds(f, 0, 0, 0)[0] for f in FAMILIES)
    evaluation = [10_000 + k for split in ("validation", "final-test", "catalogue") for k in SPLITS[split]]
    assert lowest > max(evaluation)


@pytest.mark.parametrize("bad", [dict(seed=C.MAX_SEED + 1), dict(seed=-1), dict(stage=10), dict(r=5),
                                 dict(seed=True), dict(seed=1.0)])
def test_out_of_range_arguments_are_refused(bad):  # RES-TRAINING-SEED-RANGE
    args = {"family": "flow", "seed": 0, "stage": 0, "r": 0, **bad}
    with pytest.raises(C.CurriculumError):
        C.training_seeds(**args)
    with pytest.raises(C.CurriculumError, match="families"):
        C.training_seeds("geometry", 0)


def test_training_instances_are_the_scenario_realized_under_the_run_seeds():
    bundle = load_scenario_bundle("flow-medium")
    runs = C.training_instances(bundle, seed=7)
    assert [i["seeds"]["generation"] for i in runs] == [80_000 + 300_000 + 700 + r for r in range(5)]
    assert [i["seeds"]["execution"] for i in runs] == [90_000 + 300_000 + 700 + r for r in range(5)]
    expected = make_instance(*bundle, generation_seed=380_702, execution_seed=390_702)
    assert fingerprint(runs[2]) == fingerprint(expected)
    assert runs[2]["id"] == "flow-medium-g380702"
    assert len({fingerprint(i) for i in runs}) == 5  # five different realizations


def test_block_sizes_split_the_budget_in_consecutive_blocks():
    assert C.block_sizes(1_536_000) == [307_200] * 5
    assert sum(C.block_sizes(13)) == 13 and C.block_sizes(13) == [2, 2, 3, 3, 3]
    assert [C.realization_at(s, 1_536_000) for s in (0, 307_199, 307_200, 1_535_999)] == [0, 0, 1, 4]


# --------------------------------------------------------------------------- the environment option


def _ids(env, n, seeds=None):
    out = []
    for k in range(n):
        env.reset(seed=None if seeds is None else seeds[k])
        out.append(env.instance["id"])
    return out


def test_a_training_env_cycles_the_run_realizations_whatever_the_reset_seed():  # A-PZ-SPLIT
    env = parallel_env("coalition-medium", split="training", seed=3)
    expected = [f"coalition-medium-g{80_300 + r}" for r in range(5)]
    assert _ids(env, 10, seeds=[0] * 10) == expected * 2  # a loop that re-seeds every reset still cycles
    fresh = parallel_env("coalition-medium", split="train", seed=3)
    assert _ids(fresh, 5) == expected  # and one that never seeds
    assert fresh.sim.execution_seed == 90_304  # the realization's own execution seed (A-PZ-RESET)


@pytest.mark.parametrize("split", ["validation", "final-test"])
def test_evaluation_splits_cycle_the_canonical_suite_instances(split):
    env = parallel_env("flow-easy", split=split)
    n = len(SPLITS[split])
    ids = _ids(env, n + 1)
    assert ids == [f"ag32-flow-easy-s{k}" for k in [*SPLITS[split], SPLITS[split][0]]]


def test_realization_steps_make_blocks_of_env_steps():  # A-PZ-SPLIT, RES-SPLIT-CYCLE
    env = parallel_env("flow-easy", split="training", seed=0, realization_steps=5, max_cycles=2)
    played = []
    for _ in range(12):  # 12 episodes of 2 steps: blocks of 5 steps switch at the next reset
        env.reset(seed=1)
        played.append(env.position)
        while env.agents:
            env.step({})
    assert played == [0, 0, 0, 1, 1, 2, 2, 2, 3, 3, 4, 4]


def test_an_instance_option_plays_once_and_keeps_the_cycle():
    env = parallel_env("flow-easy", split="training", seed=0)
    env.reset()
    env.reset(options={"instance": 1000})
    assert env.instance["id"] == "ag32-flow-easy-s1000" and env.position is None
    env.reset()
    assert env.position == 1 and env.instance["id"] == "flow-easy-g380001"


@given(ops=st.lists(st.tuples(st.one_of(st.none(), st.integers(0, 2**31)), st.integers(0, 3)), min_size=1,
                    max_size=14),
       block=st.one_of(st.none(), st.integers(1, 6)))
@settings(max_examples=25, deadline=None)
def test_any_reset_sequence_plays_the_counted_instance(ops, block):  # RES-SPLIT-CYCLE: the generator
    """Seeded or not, with any steps between: reset n plays the item the counting rule names."""
    env = parallel_env("flow-easy", split="training", seed=1, realization_steps=block)
    steps, visited = 0, set()
    for n, (seed, k) in enumerate(ops):
        env.reset(seed=seed)
        want = (n if block is None else steps // block) % 5
        assert env.position == want and env.instance["seeds"]["generation"] == 380_100 + want
        visited.add(env.instance["id"])
        for _ in range(k):
            env.step({})
            steps += 1
    if block is None:  # counted resets visit min(n, 5) distinct realizations, never stay on one
        assert len(visited) == min(len(ops), 5)


@pytest.mark.parametrize("kwargs, match", [
    (dict(split="training"), "needs seed"),
    (dict(split="nope"), "split must be one of"),
    (dict(seed=1), "option of split"),
    (dict(realization_steps=4), "option of split"),
    (dict(stage=1), "option of split"),
    (dict(split="validation", seed=2), "belong to split='training'"),
    (dict(split="training", seed=3000), "0..2999"),
    (dict(split="training", seed=1, index=3), "takes no index"),
    (dict(split="training", seed=1, realization_steps=0), "positive integer"),
])
def test_bad_split_options_are_refused_with_a_message(kwargs, match):
    with pytest.raises(AdapterError, match=match):
        parallel_env("flow-easy", **kwargs)


def test_a_split_needs_a_scenario_not_an_instance(tmp_path):
    inst = parallel_env("flow-easy", index=1000).instance
    with pytest.raises(AdapterError, match="needs a scenario"):
        parallel_env(inst, split="validation")


def test_the_gymnasium_env_takes_the_split_options():  # A-GYM-ENV
    pytest.importorskip("gymnasium")
    from agspec.gymnasium import make_env

    env = make_env("flow-easy", split="training", seed=2)
    seen = []
    for _ in range(6):
        env.reset(seed=0)
        seen.append(env.par.instance["seeds"]["generation"])
    assert seen == [380_200, 380_201, 380_202, 380_203, 380_204, 380_200]


def test_supersuit_vector_env_cycles_without_options():
    """The wrappers researchers train through never pass options; the split env still cycles."""
    ss = pytest.importorskip("supersuit")
    made = []

    def make():
        env = parallel_env("flow-easy", split="training", seed=0, max_cycles=2)
        made.append(env)
        return env

    vec = ss.pettingzoo_env_to_vec_env_v1(make())
    base = made[-1]
    vec.reset(seed=5)
    seen = [base.position]
    for _ in range(9):  # episodes of 2 steps: the vector env resets on its own when one ends
        _, _, _, _, _ = vec.step([0] * vec.num_envs)
        _, _, _, _, _ = vec.step([0] * vec.num_envs)
        seen.append(base.position)
    assert seen == [0, 1, 2, 3, 4, 0, 1, 2, 3, 4]


def test_the_cycle_check_catches_an_env_stuck_on_one_instance(monkeypatch):
    """The generator above proves itself: an environment whose resets never move (the defect of a
    seed-only reset) fails it."""
    from agspec.marl.parallel import Curriculum

    monkeypatch.setattr(Curriculum, "position", lambda self, steps: 0)
    with pytest.raises(AssertionError):
        test_any_reset_sequence_plays_the_counted_instance()
