"""Whole training runs at tiny budgets (spec/16-training.md): a two-update run of each algorithm,
determinism, resume equals uncut, vector modes, the run directory's schemas, the CLI, and a trained
run evaluated by `agspec evaluate --policy RUN_DIR` (F-POLICY-CHECKPOINT)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

torch = pytest.importorskip("torch", reason="the trainer needs PyTorch: pip install 'agspec[train]'")
torch.set_num_threads(1)  # tiny networks: one thread is fastest, and T-DETERMINISM fixes the thread count

from train_cuts import short_scenario, tiny  # noqa: E402  (the tiny budgets the resume generator uses)

from agspec.cli.main import cli  # noqa: E402
from agspec.formats.schemas import validator  # noqa: E402
from agspec.train.api import is_complete, load_policy, read_summary, train  # noqa: E402
from agspec.train.record import read_record, without_wall_time  # noqa: E402

SCENARIO = "flow-easy"  # 20 robots: the smallest official grid


def policy_sha(out: Path) -> str:
    return read_summary(out)["policy"]["sha256"]


def check_schemas(out: Path) -> list[dict]:
    summary = json.loads((out / "run.json").read_text())
    assert not list(validator("training-run").iter_errors(summary))
    rows = list(read_record(out / "record.jsonl"))
    for row in rows:
        errors = list(validator("training-record").iter_errors(row))
        assert not errors, (row, errors[0].message)
    return rows


@pytest.mark.parametrize("algorithm", ["ippo", "mappo", "qmix"])
def test_a_two_update_run_of_each_algorithm(algorithm, tmp_path):  # T-PPO-UPDATE, T-QMIX-UPDATE, T-RUN-DIR
    config = tiny(algorithm, **{"budget.env_steps": 16, "curriculum.realizations": 1, "curriculum.indices": [0]})
    if algorithm == "qmix":  # TD updates at steps 8, 12 and 16 (T-WARMUP: 8 transitions first)
        config["replay"]["train_every"] = 4
    summary = train(config, tmp_path / "run")
    assert summary["status"] == "complete" and is_complete(tmp_path / "run")
    assert summary["steps"] == 16 and summary["updates"] == (3 if algorithm == "qmix" else 2)
    rows = check_schemas(tmp_path / "run")
    progress = [r for r in rows if r["kind"] == "progress"]
    assert [r["steps"] for r in progress] == [8, 16]
    if algorithm == "qmix":
        assert progress[-1]["replay_size"] == 16 and progress[-1]["epsilon"] < 1.0
    else:
        assert [r["actor_updated"] for r in progress] == [False, True]  # T-WARMUP: 8 steps of critic only
        assert all(r["entropy"] > 0 for r in progress)
    assert {"config.json", "run.json", "record.jsonl", "checkpoint.pt", "policy.pt"} <= {
        p.name for p in (tmp_path / "run").iterdir()}
    real = summary["realizations"][0]
    offset = {"flow": 300_000}["flow"]
    assert real["generation_seed"] == 80_000 + offset and real["instance_id"] == "flow-easy-g380000"


def test_same_seed_same_first_update_bitwise_and_another_seed_differs(tmp_path):  # T-DETERMINISM
    one = {"budget.env_steps": 8, "curriculum.realizations": 1, "curriculum.indices": [0],
           "warmup.critic_steps": 0}
    train(tiny("mappo", **one), tmp_path / "a")
    train(tiny("mappo", **one), tmp_path / "b")
    train(tiny("mappo", seed=1, **one), tmp_path / "c")
    assert policy_sha(tmp_path / "a") == policy_sha(tmp_path / "b") != policy_sha(tmp_path / "c")
    assert (without_wall_time(read_record(tmp_path / "a" / "record.jsonl"))
            == without_wall_time(read_record(tmp_path / "b" / "record.jsonl")))


class Cut(Exception):
    pass


@pytest.mark.parametrize("algorithm,cut_at", [("ippo", 22)])  # every algorithm and cut: test_train_resume.py
def test_resume_equals_uncut(algorithm, cut_at, tmp_path):  # T-RESUME
    # IPPO: 4-tick episodes and 4-step updates, so every update ends at an episode start and the last
    # checkpoint before the cut (step 20) lies inside block 2 (steps 16-24); QMIX checkpoints at block
    # ends only (step 16)
    if algorithm == "ippo":
        config = tiny(algorithm, scenario=short_scenario(tmp_path), **{
            "ppo.steps_per_update": 4, "checkpoint.every_steps": 4, "record.every_steps": 4})
    else:
        config = tiny(algorithm)
    train(config, tmp_path / "uncut")

    def cutter(row):
        if row.get("steps", 0) >= cut_at:
            raise Cut

    with pytest.raises(Cut):
        train(config, tmp_path / "cut", progress=cutter)
    from agspec.checkpoint.files import load_checkpoint

    position = load_checkpoint(tmp_path / "cut" / "checkpoint.pt")["position"]
    assert (position["block"], position["block_step"]) == ((2, 4) if algorithm == "ippo" else (2, 0))
    assert read_summary(tmp_path / "cut")["status"] == "running" and not is_complete(tmp_path / "cut")
    with pytest.raises(Exception, match="add --resume"):
        train(config, tmp_path / "cut")
    resumed = train(config, tmp_path / "cut", resume=True)
    assert resumed["resumed"] == 1 and resumed["steps"] == 40
    assert policy_sha(tmp_path / "cut") == policy_sha(tmp_path / "uncut")
    assert (without_wall_time(read_record(tmp_path / "cut" / "record.jsonl"))
            == without_wall_time(read_record(tmp_path / "uncut" / "record.jsonl")))
    again = train(config, tmp_path / "cut", resume=True)  # a complete run: nothing to do
    assert again["policy"] == resumed["policy"] and again["resumed"] == 1
    other = dict(config, gamma=0.5)
    with pytest.raises(Exception, match="another configuration"):
        train(other, tmp_path / "cut", resume=True)


def test_sync_and_async_copies_give_the_same_run(tmp_path):  # T-COPIES
    base = {"budget.env_steps": 16, "curriculum.realizations": 1, "curriculum.indices": [0], "rollout.envs": 2}
    train(tiny("mappo", **base, **{"runtime.vector": "sync"}), tmp_path / "sync")
    train(tiny("mappo", **base, **{"runtime.vector": "async"}), tmp_path / "async")
    assert policy_sha(tmp_path / "sync") == policy_sha(tmp_path / "async")


def test_validation_rows_and_the_policy_factory(tmp_path):  # T-VALIDATION, T-EVAL-ACTION
    from agspec.pettingzoo import parallel_env

    config = tiny("ippo", **{"budget.env_steps": 16, "curriculum.realizations": 2, "curriculum.indices": [0, 1],
                             "validation.indices": [200], "validation.actions": ["greedy", "sample"]})
    summary = train(config, tmp_path / "run")
    rows = check_schemas(tmp_path / "run")
    phases = [(r["phase"], r["action"]) for r in rows if r["kind"] == "validation"]
    assert phases == [(p, a) for p in ("initial", "block-0", "block-1") for a in ("greedy", "sample")]
    assert summary["validation"]["phase"] == "block-1" and summary["validation"]["action"] == "greedy"
    quiet = tiny("ippo", **{"budget.env_steps": 16, "curriculum.realizations": 2, "curriculum.indices": [0, 1],
                            "validation.indices": [200], "validation.initial": False, "validation.every_block": False})
    train(quiet, tmp_path / "quiet")  # RES-VALIDATION-SCHEDULE: the last block is always validated
    assert [(r["phase"], r["action"]) for r in check_schemas(tmp_path / "quiet") if r["kind"] == "validation"] == [
        ("block-1", "greedy")]
    env = parallel_env(SCENARIO, index=200)
    obs, infos = env.reset(seed=0)
    policy = load_policy(tmp_path / "run")(env)
    for _ in range(5):
        actions = policy(obs, infos)
        assert all(obs[a]["action_mask"][x] == 1 for a, x in actions.items())
        assert actions == policy(obs, infos)  # deterministic
        obs, _r, _t, _tr, infos = env.step(actions)
    obs, infos = env.reset(seed=0)
    sampled = [load_policy(tmp_path / "run", "sample")(env) for _ in range(2)]
    first, second = sampled[0](obs, infos), sampled[1](obs, infos)
    assert first == second and all(obs[a]["action_mask"][x] == 1 for a, x in first.items())  # seeded by the episode


def test_cli_trains_resumes_and_evaluates_a_run(tmp_path):  # T-CLI, F-POLICY-CHECKPOINT
    runner = CliRunner()
    out = tmp_path / "run"
    args = ["train", "--algorithm", "ippo", "--scenario", SCENARIO, "--seed", "0", "-o", str(out), "--steps", "10",
            "--threads", "1", "--set", "ppo.steps_per_update=2", "--set", "ppo.minibatch=32",
            "--set", "validation.indices=[]", "--set", "record.every_steps=2", "--format", "json"]
    res = runner.invoke(cli, args)
    assert res.exit_code == 0, res.output
    assert json.loads(res.output[res.output.index("{"):])["status"] == "complete"
    res = runner.invoke(cli, args[:-2])  # the same run again, without --resume
    assert res.exit_code == 2 and "--resume" in res.output
    res = runner.invoke(cli, [*args, "--resume"])
    assert res.exit_code == 0, res.output
    bundle = tmp_path / "b.json"
    res = runner.invoke(cli, ["evaluate", "--policy", str(out), "--scenario", SCENARIO, "--indices", "1000",
                              "--repeat", "0", "-o", str(bundle), "--format", "json"])
    assert res.exit_code == 0, res.output
    data = json.loads(bundle.read_text())
    (ident,) = [p for p in data["policies"] if p["kind"] == "checkpoint"]
    summary = read_summary(out)
    assert ident["file_sha256"] == summary["policy"]["sha256"]
    assert ident["training"] == {"algorithm": "ippo", "scenario": SCENARIO, "seed": 0, "steps": 10,
                                 "config_sha256": summary["config_sha256"], "action": "greedy"}  # F-POLICY-BUDGET
    assert [e["status"] for e in data["episodes"] if e["controller"] == ident["label"]] == ["ok"]
    res = runner.invoke(cli, ["report", str(bundle)])  # T-CHECKPOINT-ROW: one run, one instance
    assert res.exit_code == 0, res.output
    assert "| IPPO† | flow-easy | 10 | greedy | 1 | 1 |" in res.output and "21.85 ± 0.46" in res.output
    assert "run (IPPO†) — 10 of the paper's 1,536,000 training steps" in res.output  # F-POLICY-BUDGET
    assert "IPPO† on flow-easy — 10 of the paper's 1,536,000 training steps" in res.output
    # a run that is not complete is refused
    (tmp_path / "half").mkdir()
    (tmp_path / "half" / "run.json").write_text(json.dumps({**summary, "status": "running", "policy": None}))
    res = runner.invoke(cli, ["evaluate", "--policy", str(tmp_path / "half"), "--scenario", SCENARIO,
                              "--indices", "1000"])
    assert res.exit_code == 2 and "not complete" in res.output


def test_one_process_at_a_time_trains_into_a_run_directory(tmp_path):  # T-RUN-DIR
    import fcntl

    from agspec.checkpoint.rundir import RunDirError

    out = tmp_path / "run"
    out.mkdir()
    with open(out / ".lock", "a") as fh:  # another process holds the run directory
        fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        import subprocess
        import sys

        code = ("from agspec.train.api import train, resolve_config; import sys\n"
                "c = resolve_config('ippo', 'flow-easy', 0, {'budget.env_steps': 5, 'validation.indices': []})\n"
                f"train(c, {str(out)!r})")
        proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
        assert proc.returncode != 0 and "another process is training into this directory" in proc.stderr
    foreign = tmp_path / "foreign"
    foreign.mkdir()
    (foreign / "notes.txt").write_text("mine")
    with pytest.raises(RunDirError, match="not empty"):
        train(tiny("ippo"), foreign)
    assert sorted(p.name for p in foreign.iterdir()) == ["notes.txt"]  # nothing written into it
