"""The training recipes of docs/training.md ("Training with other libraries") run end to end at a tiny
budget: train through the library on a split environment (A-PZ-SPLIT), save, evaluate with
``agspec evaluate`` (F-POLICY-HOST loads the model once per worker), exit 0 with no masked action.
The libraries are not agspec dependencies: each test is skipped where its library is missing."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow
@pytest.mark.parametrize("recipe, needs", [("recipe_sb3.py", ("sb3_contrib", "supersuit")),
                                           ("recipe_torchrl.py", ("torchrl", "tensordict"))])
def test_recipe_trains_saves_and_evaluates(tmp_path, recipe, needs):
    for module in ("torch", "pettingzoo", *needs):
        pytest.importorskip(module)
    r = subprocess.run([sys.executable, str(ROOT / "benchmarks" / recipe), "--env-steps", "200", "--rollout", "100",
                        "--max-cycles", "50", "--eval-indices", "200", "-o", str(tmp_path)],
                       capture_output=True, text=True, timeout=900, cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-3000:]
    result = json.loads(r.stdout.strip().splitlines()[-1])
    assert result["env_steps"] == 200 and result["agent_samples"] == 200 * result["agents"]
    bundle = json.loads((tmp_path / "validation.json").read_text())
    mine = [ep for ep in bundle["episodes"] if ep["controller"] != "random"]
    assert len(mine) == 1 and mine[0]["status"] == "ok" and mine[0]["illegal_actions"] == 0
