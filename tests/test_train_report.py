"""Training curves from run directories and the paper's held-out row from checkpoints (spec/16-training.md,
T-RECORD, T-CHECKPOINT-ROW).  Synthetic run directories: no torch needed."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from click.testing import CliRunner

from agspec.cli.main import cli
from agspec.train import heldout
from agspec.train.curves import band, load_runs


def fake_run(root: Path, name: str, algorithm: str, seed: int, scale: float) -> Path:
    d = root / name
    d.mkdir()
    summary = {"schema": "agspec-training-run/1", "status": "complete", "algorithm": algorithm, "scenario": "coalition-easy",
               "seed": seed}
    (d / "run.json").write_text(json.dumps(summary))
    rows = [{"kind": "header", "schema": "agspec-training-record/1"}]
    for k in range(1, 6):
        rows.append({"kind": "progress", "steps": 16000 * k, "milestone_return": scale * k, "admissions": scale,
                     "delivered": scale * k / 2, "entropy": 1.0 / k, "explained_variance": 0.1 * k})
    (d / "record.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    return d


def test_band_is_the_median_and_interquartile_range_over_seeds(tmp_path):  # T-RECORD
    runs = load_runs([fake_run(tmp_path, f"s{s}", "mappo", s, scale) for s, scale in enumerate((1.0, 2.0, 3.0, 4.0))])
    steps, med, lo, hi = band(runs, "delivered")
    assert steps.tolist() == [16000, 32000, 48000, 64000, 80000]
    # at step 16000 the values are 0.5, 1.0, 1.5, 2.0: median 1.25, quartiles 0.875 and 1.625
    assert (med[0], lo[0], hi[0]) == (1.25, 0.875, 1.625)


def test_report_draws_training_curves_and_refuses_what_is_not_a_run(tmp_path):
    pytest.importorskip("matplotlib", reason="figures need matplotlib: pip install 'agspec[plot]'")
    dirs = [str(fake_run(tmp_path, f"{a}{s}", a, s, s + 1.0)) for a in ("ippo", "mappo", "qmix") for s in range(3)]
    runner = CliRunner()
    out = tmp_path / "curves.svg"
    res = runner.invoke(cli, ["report", *dirs, "--to", "svg", "-o", str(out)])
    assert res.exit_code == 0, res.output
    text = out.read_text()
    assert "IPPO (n=3)" in text and "MAPPO (n=3)" in text and "Policy entropy" in text
    (tmp_path / "empty").mkdir()
    res = runner.invoke(cli, ["report", str(tmp_path / "empty"), "--to", "svg"])
    assert res.exit_code == 2 and "not a training run directory" in res.output
    res = runner.invoke(cli, ["report", dirs[0], "--to", "markdown"])
    assert res.exit_code == 2 and "--to svg" in res.output


def _policies_and_episodes(means_by_seed, algorithm="ippo", scenario="flow-easy", errors=()):
    policies, episodes = [], []
    for seed, values in means_by_seed.items():
        label = f"{algorithm}-s{seed}"
        policies.append({"label": label, "kind": "checkpoint", "training": {
            "algorithm": algorithm, "scenario": scenario, "seed": seed, "steps": 10, "config_sha256": "0" * 64}})
        for i, v in enumerate(values):
            bad = (seed, i) in errors
            episodes.append({"controller": label, "scenario": scenario, "index": 1000 + i,
                             "status": "error" if bad else "ok", "metrics": None if bad else {"delivered": v}})
    return policies, episodes


def test_checkpoint_row_is_the_mean_of_per_policy_means_with_a_t_interval():  # T-CHECKPOINT-ROW
    pytest.importorskip("scipy", reason="the t interval needs SciPy: pip install 'agspec[eval]'")
    policies, episodes = _policies_and_episodes({0: [1, 3], 1: [4, 6], 2: [7, 9], 3: [0, 2]}, errors={(3, 1)})
    (row,) = heldout.rows(policies, episodes)
    assert row["per_policy"] == [2.0, 5.0, 8.0] and row["n"] == 3 and row["incomplete"] == ["ippo-s3"]
    assert row["mean"] == 5.0
    # t_{0.975, 2} = 4.302653; s = 3; half-width = 4.302653 * 3 / sqrt(3)
    assert math.isclose(row["half_width"], 4.302652729911275 * 3 / math.sqrt(3), rel_tol=1e-9)
    assert row["published"] == {"mean": 21.852, "half_width": 0.455}  # IPPO flow-easy, tab:checkpoint-heldout
    text = heldout.markdown([row])
    assert "| IPPO† | flow-easy | 10 | greedy | 3 | 2 | 5.00 ± 7.45 | 21.85 ± 0.46 | ippo-s3 |" in text
    assert "IPPO† on flow-easy — 10 of the paper's 1,536,000 training steps" in text  # F-POLICY-BUDGET
    assert "5.00$\\pm$7.45" in heldout.latex([row])


def test_checkpoint_row_of_one_policy_has_no_interval():
    policies, episodes = _policies_and_episodes({5: [2, 2]}, algorithm="mappo", scenario="coalition-hard")
    (row,) = heldout.rows(policies, episodes)
    assert (row["n"], row["mean"], row["half_width"]) == (1, 2.0, None)
