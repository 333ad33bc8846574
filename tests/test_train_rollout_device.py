"""The rollout acting on a copy of the networks (spec/16-training.md, RES-ROLLOUT-DEVICE): a copy on the
learner's device changes no byte, a copy that misses a synchronization is caught, a rollout stream of
its own is deterministic and resumes, and the thread budget governs the copy's forward passes.

Without a GPU the copy lives on the CPU beside a CPU learner; the stream a GPU learner would force
(the rollout's own, T-DETERMINISM) is forced here by declaring the two devices different."""

from __future__ import annotations

import json
from unittest import mock

import pytest

torch = pytest.importorskip("torch", reason="the trainer needs PyTorch: pip install 'agspec[train]'")
torch.set_num_threads(1)  # T-DETERMINISM fixes the thread count

from train_cuts import cut_and_resume, cut_config, differences, outcome, tiny  # noqa: E402

from agspec.formats.schemas import validator  # noqa: E402
from agspec.train import acting, ppo, qmix  # noqa: E402
from agspec.train.api import train  # noqa: E402
from agspec.train.config import ConfigError  # noqa: E402
from agspec.train.run import _rollout_device  # noqa: E402

LEARNER = {"runtime.rollout_device": "learner"}  # the learner's own networks act: the plain loop
COPY = {"runtime.rollout_device": "cpu"}  # a copy on the CPU, beside the CPU learner


def trained(config, out):
    train(config, out)
    return outcome(out)


@pytest.fixture(scope="module")
def plain(tmp_path_factory):
    """The plain run of each algorithm (no copy), computed once."""
    root = tmp_path_factory.mktemp("plain")
    cache = {}

    def get(algorithm):
        if algorithm not in cache:
            cache[algorithm] = trained(tiny(algorithm, **LEARNER), root / algorithm)
        return cache[algorithm]
    return get


@pytest.fixture
def own_stream():
    """The rollout draws from its own stream, as it does beside a GPU learner (RES-ROLLOUT-DEVICE)."""
    with mock.patch.object(acting, "same_device", lambda a, b: False):
        yield


@pytest.mark.parametrize("algorithm", ["ippo", "mappo", "qmix"])
def test_a_copy_on_the_learners_device_gives_the_plain_run(algorithm, plain, tmp_path):  # RES-ROLLOUT-DEVICE
    got = trained(tiny(algorithm, **COPY), tmp_path / "run")
    assert differences(plain(algorithm), got) == []
    summary = json.loads((tmp_path / "run" / "run.json").read_text())
    assert not list(validator("training-run").iter_errors(summary))
    assert (summary["device"], summary["rollout_device"], summary["runtime"]["rollout_device"]) == ("cpu", "cpu", "cpu")


@pytest.mark.parametrize("algorithm", ["ippo", "mappo", "qmix"])
def test_a_copy_that_is_not_synchronized_is_caught(algorithm, plain, tmp_path):  # RES-ROLLOUT-DEVICE
    # the seeded bug: the copy keeps its initial weights; PPO's first update changes the critic (the
    # actor is frozen, T-WARMUP) and the stale values change the second update's advantages; QMIX's
    # first TD update at step 8 changes the greedy actions that follow
    learner = qmix.QMIXLearner if algorithm == "qmix" else ppo.PPOLearner
    with mock.patch.object(learner, "sync_rollout", lambda self: None):
        got = trained(tiny(algorithm, **COPY), tmp_path / "run")
    assert differences(plain(algorithm), got) != []


def test_an_own_rollout_stream_is_deterministic_and_used(plain, own_stream, tmp_path):  # T-DETERMINISM
    first = trained(tiny("ippo", **COPY), tmp_path / "a")
    assert differences(first, trained(tiny("ippo", **COPY), tmp_path / "b")) == []
    assert differences(plain("ippo"), first) != []  # the actions come from another stream
    summary = json.loads((tmp_path / "a" / "run.json").read_text())
    assert summary["rollout_device"] == "cpu"


def test_an_own_rollout_stream_resumes_to_the_uncut_run(own_stream, tmp_path):  # T-RESUME
    config = cut_config("ippo", tmp_path)
    config["runtime"]["rollout_device"] = "cpu"
    expected = trained(config, tmp_path / "uncut")
    assert differences(expected, cut_and_resume(config, tmp_path / "cut", cut_row=3)) == []
    original = ppo.PPOLearner.load_state_dict

    def forgets_the_stream(self, data):  # the seeded bug: the rollout stream is not restored
        keep = self.rollout_gen.get_state()
        original(self, data)
        self.rollout_gen.set_state(keep)

    with mock.patch.object(ppo.PPOLearner, "load_state_dict", forgets_the_stream):
        assert differences(expected, cut_and_resume(config, tmp_path / "mutant", cut_row=3)) != []


def test_the_thread_budget_governs_the_copys_forward_passes(tmp_path):  # CAMP-THREADS, RES-ROLLOUT-DEVICE
    seen = set()
    original = ppo.PPOLearner.act

    def act(self, *args):
        assert self.acting_actor is not self.actor
        seen.add(torch.get_num_threads())
        return original(self, *args)

    torch.set_num_threads(2)
    try:
        with mock.patch.object(ppo.PPOLearner, "act", act):
            train(tiny("ippo", **COPY, **{"budget.env_steps": 10, "curriculum.realizations": 1,
                                          "curriculum.indices": [0], "ppo.steps_per_update": 5,
                                          "record.every_steps": 5, "checkpoint.every_steps": 5}), tmp_path / "run")
    finally:
        torch.set_num_threads(1)
    assert seen == {1}  # runtime.threads = 1 (the tiny configuration), not the process's 2


def test_where_the_rollout_acts():  # RES-ROLLOUT-DEVICE
    def config(name):
        return {"runtime": {"rollout_device": name}}

    cpu, cuda = torch.device("cpu"), torch.device("cuda")
    assert tiny("ippo")["runtime"]["rollout_device"] == "learner"  # the default: no copy
    assert acting.rollout_device(config("learner")) is None and acting.rollout_device(config("cpu")) == cpu
    assert acting.describe(cuda, None) == "cuda" and acting.describe(cuda, cpu) == "cpu"
    assert acting.same_device(torch.device("cuda"), torch.device("cuda:0"))
    assert not acting.same_device(torch.device("cuda:1"), torch.device("cuda:0"))
    gen = torch.Generator()
    assert acting.rollout_stream(0, gen, cpu, None) is gen and acting.rollout_stream(0, gen, cpu, cpu) is gen
    own = acting.rollout_stream(0, gen, cuda, cpu)
    assert own is not gen and torch.equal(own.get_state(), acting.rollout_stream(0, gen, cuda, cpu).get_state())
    assert not torch.equal(own.get_state(), acting.rollout_stream(1, gen, cuda, cpu).get_state())
    with pytest.raises(ConfigError, match="runtime.rollout_device"):
        _rollout_device(config("no-such-device"))
    if not torch.cuda.is_available():
        with pytest.raises(ConfigError, match="no CUDA device"):
            _rollout_device(config("cuda"))
    with pytest.raises(ConfigError, match="rollout_device"):
        tiny("ippo", **{"runtime.rollout_device": 0})
