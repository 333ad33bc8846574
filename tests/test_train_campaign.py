"""Training campaigns (T-CAMPAIGN): a plan of algorithms × scenarios × seeds on the campaign executor,
resumable, each run evaluated, and the same campaign record on every executor (CAMP-IDENTICAL)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner

torch = pytest.importorskip("torch", reason="the trainer needs PyTorch: pip install 'agspec[train]'")

from agspec.campaign.executor import ExecutorSpec  # noqa: E402
from agspec.cli.main import cli  # noqa: E402
from agspec.train.api import is_complete, read_summary  # noqa: E402
from agspec.train.campaign import PlanError, check_plan, items, paper_plan, run_campaign  # noqa: E402

# a few ticks per run (as tests/test_train_runs.py's tiny runs), evaluated on one validation instance
TINY = {"budget.env_steps": 40, "record.every_steps": 8, "validation.indices": []}
PER_ALGORITHM = {"ippo": {"ppo.steps_per_update": 8, "ppo.minibatch": 64, "warmup.critic_steps": 8,
                          "checkpoint.every_steps": 8},
                 "qmix": {"replay.capacity": 64, "warmup.replay_transitions": 8, "replay.target_sync_every": 8}}
PLAN = {"schema": "agspec-training-plan/1", "algorithms": ["ippo", "qmix"], "scenarios": ["flow-easy"],
        "seeds": [0], "settings": TINY, "algorithm_settings": PER_ALGORITHM,
        "evaluation": {"split": "validation", "indices": [200]}}


def campaign(out: Path, executor: ExecutorSpec) -> list[dict]:
    return list(run_campaign(check_plan(PLAN), out, executor))


def test_the_paper_plan_is_the_paper_campaign():
    plan = check_plan(paper_plan())
    runs = items(plan, Path("c"))
    assert len(runs) == 270 and len({r.run_dir for r in runs}) == 270
    assert plan["evaluation"]["indices"] == list(range(1000, 1050))
    assert dict(runs[0].settings) == {"runtime.threads": 1}  # RES-CAMPAIGN-THREADS: one thread per run


@pytest.mark.parametrize("plan, match", [
    ({"schema": "agspec-training-plan/1", "algorithms": ["ppo"]}, "algorithms"),
    ({"schema": "agspec-training-plan/1", "seeds": [3000]}, "seeds"),
    ({"schema": "agspec-training-plan/1", "settings": {"seed": 1}}, "settings"),
    ({"schema": "agspec-training-plan/1", "evaluation": {"split": "validation", "indices": [1000]}}, "not a validation"),
    ({"algorithms": ["ippo"]}, "schema"),
])
def test_bad_plans_are_refused_before_anything_runs(plan, match):
    with pytest.raises(PlanError, match=match):
        check_plan(plan)


@pytest.mark.ray
def test_local_and_ray_campaigns_write_the_same_bytes_and_resume(tmp_path):  # CAMP-IDENTICAL, T-CAMPAIGN
    records = campaign(tmp_path / "local", ExecutorSpec("local", 2))
    assert [r["run"] for r in records] == ["ippo-flow-easy-s0", "qmix-flow-easy-s0"]
    for r in records:
        assert r["status"] == "complete" and r["steps"] == 40
        ev = r["evaluation"]
        assert (ev["split"], ev["indices"], ev["episodes"], ev["ok"], ev["errors"]) == ("validation", [200], 1, 1, 0)
        run_dir = tmp_path / "local" / "runs" / r["run"]
        assert is_complete(run_dir) and read_summary(run_dir)["policy"]["sha256"] == r["policy_sha256"]
    local = (tmp_path / "local" / "campaign.jsonl").read_bytes()
    pytest.importorskip("ray")
    campaign(tmp_path / "ray", ExecutorSpec("ray", 2))
    assert (tmp_path / "ray" / "campaign.jsonl").read_bytes() == local

    # resumable: a complete campaign runs nothing again; a run cut short (here: its evaluation lost,
    # its run directory reset to a mid-training checkpoint is covered by T-RESUME) is completed
    (tmp_path / "local" / "runs" / "qmix-flow-easy-s0" / "evaluation.json").unlink()
    shutil.rmtree(tmp_path / "local" / "runs" / "ippo-flow-easy-s0")
    again = campaign(tmp_path / "local", ExecutorSpec("local", 1))
    assert (tmp_path / "local" / "campaign.jsonl").read_bytes() == local
    assert again == records


def test_cli_campaign_from_a_plan_file(tmp_path):
    plan = tmp_path / "plan.json"
    plan.write_text(json.dumps({**PLAN, "algorithms": ["ippo"], "seeds": [0]}))
    res = CliRunner().invoke(cli, ["train", "--campaign", str(plan), "-o", str(tmp_path / "c"), "--format", "json"])
    assert res.exit_code == 0, res.output
    out = json.loads(res.stdout)
    assert [r["run"] for r in out["runs"]] == ["ippo-flow-easy-s0"] and out["runs"][0]["status"] == "complete"
    bad = CliRunner().invoke(cli, ["train", "--campaign", "paper", "--seed", "1", "-o", str(tmp_path / "d")])
    assert bad.exit_code == 2 and "--campaign takes the runs from its plan" in bad.stderr
    gpus = CliRunner().invoke(cli, ["train", "--campaign", str(plan), "--gpus-per-run", "1", "-o", str(tmp_path / "e")])
    assert gpus.exit_code == 2 and "--executor ray" in gpus.stderr
