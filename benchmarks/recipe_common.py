"""What the two library recipes share (docs/training.md, "Recipes"): their command line and the
evaluation of the saved model by `agspec evaluate` on the validation instances beside Random masked."""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path
from typing import Any, Callable, Mapping


def parser(description: str, default_out: str, *, copies: bool = False) -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("--scenario", default="flow-easy")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--env-steps", type=int, default=2000, help="training budget in env steps (all robots act)")
    if copies:
        ap.add_argument("--copies", type=int, default=1, help="environment copies stepped together")
    ap.add_argument("--rollout", type=int, default=400, help="env steps per PPO rollout" + (" (over all copies)" if copies else ""))
    ap.add_argument("--max-cycles", type=int, default=None, help="shorter training episodes (smoke runs)")
    ap.add_argument("--jobs", type=int, default=1, help="evaluation workers")
    ap.add_argument("--eval-indices", default="200-204", help="validation indices to evaluate on")
    ap.add_argument("--threads", type=int, default=None,
                    help="torch threads of the learner (default: the budget, CAMP-THREADS)")
    ap.add_argument("-o", "--output", dest="out", type=Path, default=Path(default_out))
    return ap


def evaluate(args: argparse.Namespace, policy_module: Path, name: str, env: Mapping[str, str]) -> dict[str, Any]:
    """`agspec evaluate --policy MODULE:make_policy` beside Random masked; mean delivered per method."""
    cmd = [sys.executable, "-m", "agspec.cli.main", "evaluate", "--policy", f"{policy_module}:make_policy",
           "--name", name, "--controller", "random", "--scenario", args.scenario, "--split", "validation",
           "--indices", args.eval_indices, "--repeat", "0", "--metric", "delivered", "-j", str(args.jobs),
           "-o", str(args.out / "validation.json")]
    proc = subprocess.run(cmd, capture_output=True, text=True, env=dict(os.environ, **env))
    print(proc.stdout, end="")
    if proc.returncode:
        print(proc.stderr, end="", file=sys.stderr)
    bundle = json.loads((args.out / "validation.json").read_text())
    per: dict[str, list[float]] = {}
    for ep in bundle["episodes"]:
        if ep["status"] == "ok":
            per.setdefault(ep["controller"], []).append(ep["metrics"]["delivered"])
    return {"exit": proc.returncode, **{f"delivered_{k}": round(statistics.fmean(v), 2) for k, v in per.items()}}


def main(ap: argparse.ArgumentParser, train: Callable[[argparse.Namespace], dict[str, Any]],
         evaluate_saved: Callable[[argparse.Namespace], dict[str, Any]]) -> None:
    args = ap.parse_args()
    result = {**train(args), **evaluate_saved(args)}
    print(json.dumps(result))
    raise SystemExit(result["exit"])
