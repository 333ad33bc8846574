"""The training configuration against the paper's tab:marlconfig, overrides, the curriculum seeds and
the `agspec train` usage errors (spec/16-training.md).  No torch needed."""

from __future__ import annotations

import json
from functools import lru_cache

import pytest
from click.testing import CliRunner

from agspec.cli.main import cli
from agspec.train import curriculum
from agspec.train.api import resolve_config
from agspec.train.config import ConfigError, digest, flatten_settings, paper_defaults, parse_override

# tab:marlconfig, transcribed row by row from the paper (the appendix "Reference MARL configurations");
# (row, algorithm, dotted key, value)
TABLE = [
    ("execution network", "ippo", "actor.width", 256),
    ("execution network", "ippo", "actor.blocks", 2),
    ("execution network", "ippo", "actor.activation", "tanh"),
    ("execution network", "ippo", "actor.input_layer_norm", True),
    ("execution network", "ippo", "actor.heads", ["family", "slot"]),
    ("execution network", "ippo", "actor.init", "orthogonal"),
    ("execution network", "mappo", "actor.width", 256),
    ("execution network", "mappo", "actor.blocks", 2),
    ("execution network", "qmix", "qnet.hidden", [256, 256]),
    ("execution network", "qmix", "qnet.activation", "tanh"),
    ("training value model", "ippo", "critic.input", "observation"),
    ("training value model", "ippo", "critic.width", 256),
    ("training value model", "mappo", "critic.input", "state+observation"),
    ("training value model", "mappo", "critic.width", 256),
    ("training value model", "qmix", "mixer.width", 64),
    ("training value model", "qmix", "mixer.hyper_hidden", 128),
    ("training value model", "qmix", "mixer.non_negative", "softplus"),
    *[("optimizer", a, "optimizer.name", "AdamW") for a in ("ippo", "mappo", "qmix")],
    *[("optimizer", a, "optimizer.eps", 1e-5) for a in ("ippo", "mappo", "qmix")],
    *[("learning rate", a, "lr.actor", 1e-4) for a in ("ippo", "mappo")],
    *[("learning rate", a, "lr.critic", 3e-4) for a in ("ippo", "mappo")],
    ("learning rate", "qmix", "lr.q", 5e-4),
    *[("discount", a, "gamma", 0.99) for a in ("ippo", "mappo", "qmix")],
    *[(("on-policy update", a, f"ppo.{k}", v)) for a in ("ippo", "mappo") for k, v in (
        ("gae_lambda", 0.95), ("clip", 0.10), ("value_clip", 0.20), ("steps_per_update", 1600), ("epochs", 4),
        ("minibatch", 4096), ("max_grad_norm", 0.5), ("target_kl", 0.02))],
    *[("exploration", a, "entropy.start", 0.015) for a in ("ippo", "mappo")],
    *[("exploration", a, "entropy.end", 0.001) for a in ("ippo", "mappo")],
    ("exploration", "qmix", "epsilon.start", 1.0),
    ("exploration", "qmix", "epsilon.end", 0.05),
    ("exploration", "qmix", "epsilon.decay_fraction", 0.75),
    ("replay / target", "qmix", "replay.capacity", 50_000),
    ("replay / target", "qmix", "replay.batch", 64),
    ("replay / target", "qmix", "replay.train_every", 4),
    ("replay / target", "qmix", "replay.target_sync_every", 1600),
    ("replay / target", "qmix", "replay.td_target", "single-network"),
    ("replay / target", "qmix", "replay.loss", "mse"),
    *[("warm-up", a, "warmup.critic_steps", 3200) for a in ("ippo", "mappo")],
    ("warm-up", "qmix", "warmup.replay_transitions", 3200),
    *[("training curriculum", a, "curriculum.realizations", 5) for a in ("ippo", "mappo", "qmix")],
    *[("training curriculum", a, "curriculum.indices", [0, 1, 2, 3, 4]) for a in ("ippo", "mappo", "qmix")],
    *[("initialization", a, "initialization", "random") for a in ("ippo", "mappo", "qmix")],
    *[("training budget", a, "budget.env_steps", 1_536_000) for a in ("ippo", "mappo", "qmix")],
    # the paper's training-reward section: the support credit per agent (IPPO/MAPPO) or the team mean (QMIX)
    *[("training reward", a, "reward.support_credit", "agent") for a in ("ippo", "mappo")],
    ("training reward", "qmix", "reward.support_credit", "mean"),
    *[("training reward", a, "reward.name", "coalition_milestone_v1") for a in ("ippo", "mappo", "qmix")],
]


def _get(config, dotted):
    node = config
    for part in dotted.split("."):
        node = node[part]
    return node


@lru_cache(maxsize=None)
def _resolved(algorithm):
    return json.dumps(resolve_config(algorithm, "coalition-medium", 0))


@pytest.mark.parametrize("row,algorithm,key,value", TABLE, ids=[f"{a}:{k}" for _r, a, k, _v in TABLE])
def test_every_setting_is_the_tables(row, algorithm, key, value):  # T-CONFIG
    assert _get(json.loads(_resolved(algorithm)), key) == value, row


def test_the_transcription_covers_every_row_of_the_table():
    rows = {r for r, _a, _k, _v in TABLE}
    assert rows >= {"execution network", "training value model", "optimizer", "learning rate", "discount",
                    "on-policy update", "exploration", "replay / target", "warm-up", "training curriculum",
                    "initialization", "training budget"}


def test_a_changed_default_is_caught():
    """The table test is not vacuous: a drifted default fails it."""
    config = resolve_config("ippo", "flow-easy", 0, {"ppo.clip": 0.2})
    assert _get(config, "ppo.clip") != dict((k, v) for _r, a, k, v in TABLE if a == "ippo")["ppo.clip"]


def test_overrides_set_existing_keys_and_refuse_unknown_ones():
    config = resolve_config("mappo", "flow-easy", 2, {"ppo.clip": 0.2, "budget.env_steps": 16000})
    assert config["ppo"]["clip"] == 0.2 and config["budget"]["env_steps"] == 16000 and config["seed"] == 2
    with pytest.raises(ConfigError, match="ppo has no 'clipp'"):
        resolve_config("mappo", "flow-easy", 2, {"ppo.clipp": 0.2})
    with pytest.raises(ConfigError, match="is a section"):
        resolve_config("mappo", "flow-easy", 2, {"ppo": 3})
    with pytest.raises(ConfigError, match="identity"):
        resolve_config("mappo", "flow-easy", 2, {"seed": 3})
    with pytest.raises(ConfigError, match="split evenly over 5 realizations"):
        resolve_config("qmix", "flow-easy", 2, {"budget.env_steps": 1601})
    with pytest.raises(ConfigError, match="rollout.envs"):
        resolve_config("ippo", "flow-easy", 2, {"rollout.envs": 3})  # 1,600 does not split over 3 copies
    with pytest.raises(ConfigError, match="unknown algorithm"):
        resolve_config("vdn", "flow-easy", 2)
    with pytest.raises(ConfigError, match="unknown scenario"):
        resolve_config("ippo", "no-such-scenario", 2)


def test_override_values_are_read_as_yaml():
    assert parse_override("ppo.clip=0.2") == ("ppo.clip", 0.2)
    assert parse_override("validation.indices=[200, 201]") == ("validation.indices", [200, 201])
    assert parse_override("checkpoint.every_steps=null") == ("checkpoint.every_steps", None)
    with pytest.raises(ConfigError, match="KEY=VALUE"):
        parse_override("ppo.clip")


def test_a_settings_file_is_checked_key_by_key():
    flat = flatten_settings({"ppo": {"clip": 0.3}, "budget.env_steps": 8000}, paper_defaults("ippo"))
    assert flat == {"ppo.clip": 0.3, "budget.env_steps": 8000}
    with pytest.raises(ConfigError, match="ppo has no 'nope'"):
        resolve_config("ippo", "flow-easy", 0, flatten_settings({"ppo": {"nope": 1}}, paper_defaults("ippo")))


def test_the_configuration_digest_leaves_out_how_it_runs():  # T-CONFIG
    a = resolve_config("ippo", "flow-easy", 0)
    b = resolve_config("ippo", "flow-easy", 0, {"runtime.vector": "async", "runtime.threads": 3})
    c = resolve_config("ippo", "flow-easy", 0, {"ppo.epochs": 3})
    assert digest(a) == digest(b) != digest(c)


@pytest.mark.parametrize("scenario,family_offset", [("coalition-medium", 0), ("flow-easy", 300_000),
                                                    ("concurrency-hard", 600_000)])
def test_curriculum_seeds_follow_the_formula(scenario, family_offset):  # T-CURRICULUM, RES-TRAINING-SEEDS
    for seed in (0, 7):
        config = resolve_config("mappo", scenario, seed)
        blocks = curriculum.plan(config)
        assert [b.index for b in blocks] == [0, 1, 2, 3, 4]
        for r, b in enumerate(blocks):
            assert b.generation_seed == 80_000 + family_offset + 100 * seed + 10 * 0 + r
            assert b.execution_seed == 90_000 + family_offset + 100 * seed + 10 * 0 + r
            assert (b.first_step, b.steps) == (r * 307_200, 307_200)


def test_training_realizations_are_never_evaluation_instances():  # T-CURRICULUM
    config = resolve_config("ippo", "flow-easy", 3)
    blocks = curriculum.plan(config)
    training = curriculum.training_instances(config, blocks)
    evaluation = curriculum.suite_instances(config, [200, 1000])
    assert len({json.dumps(i["realization"] if "realization" in i else i, sort_keys=True) for i in training}) == 5
    train_seeds = {i["seeds"]["generation"] for i in training}
    assert train_seeds == {b.generation_seed for b in blocks}
    assert not train_seeds & {i["seeds"]["generation"] for i in evaluation}


def test_train_usage_errors_exit_2_with_a_message(tmp_path):  # T-CLI
    runner = CliRunner()
    base = ["train", "--algorithm", "ippo", "--scenario", "flow-easy", "--seed", "0", "-o", str(tmp_path / "r")]
    for extra, message in ((["--set", "ppo.nope=1"], "ppo has no 'nope'"), (["--steps", "7"], "split evenly"),
                           (["--set", "oops"], "KEY=VALUE")):
        res = runner.invoke(cli, [*base, *extra])
        assert res.exit_code == 2 and message in res.output, res.output
    res = runner.invoke(cli, ["train", "--algorithm", "ippo", "--scenario", "nope", "--seed", "0", "-o", str(tmp_path)])
    assert res.exit_code == 2 and "unknown scenario" in res.output
    (tmp_path / "occupied").mkdir()
    (tmp_path / "occupied" / "x.txt").write_text("x")
    res = runner.invoke(cli, [*base[:-1], str(tmp_path / "occupied"), "--steps", "5"])
    assert res.exit_code == 2 and "not empty" in res.output


def test_train_print_config_and_settings_file(tmp_path):  # T-CLI
    settings = tmp_path / "s.yaml"
    settings.write_text("ppo:\n  clip: 0.3\nalgorithm: ippo\n")
    res = CliRunner().invoke(cli, ["train", "--algorithm", "ippo", "--scenario", "flow-easy", "--seed", "1",
                                   "-o", str(tmp_path / "r"), "--config", str(settings), "--set", "ppo.epochs=2",
                                   "--print-config"])
    assert res.exit_code == 0, res.output
    config = json.loads(res.output)
    assert config["ppo"]["clip"] == 0.3 and config["ppo"]["epochs"] == 2 and config["seed"] == 1
    settings.write_text("algorithm: mappo\n")
    res = CliRunner().invoke(cli, ["train", "--algorithm", "ippo", "--scenario", "flow-easy", "--seed", "1",
                                   "-o", str(tmp_path / "r"), "--config", str(settings), "--print-config"])
    assert res.exit_code == 1 and "command line says" in res.output  # the file's content is invalid
    settings.write_text("ppo:\n  nope: 1\n")
    res = CliRunner().invoke(cli, ["train", "--algorithm", "ippo", "--scenario", "flow-easy", "--seed", "1",
                                   "-o", str(tmp_path / "r"), "--config", str(settings), "--print-config"])
    assert res.exit_code == 1 and "s.yaml" in res.output and "ppo has no 'nope'" in res.output


@pytest.mark.parametrize("scenario,family", [("coalition-easy", "coalition"), ("flow-medium", "flow"),
                                             ("concurrency-hard", "concurrency")])
def test_the_trainer_and_the_training_split_share_one_seed_formula(scenario, family):  # A-TRAINING-REALIZATIONS
    from agspec.marl.curriculum import training_seeds
    from agspec.train.config import resolve
    from agspec.train.curriculum import plan

    for seed in (0, 7, 2999):
        blocks = plan(resolve("ippo", scenario, seed, family, {}))
        assert [(b.generation_seed, b.execution_seed) for b in blocks] == \
            [training_seeds(family, seed, 0, r) for r in range(5)]
