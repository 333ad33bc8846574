"""Training throughput and where the time goes (docs/training.md, "The campaign"; T-CAMPAIGN).

Usage:  python benchmarks/bench_training_throughput.py [--scenario coalition-medium] [--steps 8000] [--profile] [--json]

Measures, on this machine, one torch thread per run (RES-CAMPAIGN-THREADS):

* the PettingZoo environment alone, masked random actions (the baseline of the same run);
* each algorithm's training at the paper's configuration for ``--steps`` env steps (no validation):
  env steps/s and agent samples/s (env steps × robots) over the whole run;
* a profile of each run split into the environment (``agspec`` code: the interpreter, the encoders,
  the reward), the learner (``torch``) and the rest;

then projects one paper run (1,536,000 env steps) and the 270-run campaign.  Nothing is asserted.
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import tempfile
import time
from pathlib import Path

import numpy as np
import torch

from _common import emit

from agspec.pettingzoo import parallel_env
from agspec.train.api import resolve_config, train

PAPER_STEPS, RUNS = 1_536_000, 270


def env_alone(scenario: str, steps: int) -> float:
    env = parallel_env(scenario, split="training", seed=0)
    rng = np.random.default_rng(0)
    obs, _ = env.reset()
    started = time.perf_counter()
    for _ in range(steps):
        actions = {a: int(rng.choice(np.flatnonzero(obs[a]["action_mask"]))) for a in env.agents}
        obs, *_ = env.step(actions)
        if not env.agents:
            obs, _ = env.reset()
    return steps / (time.perf_counter() - started)


def split_profile(stats: pstats.Stats) -> dict[str, float]:
    """Seconds spent inside agspec (environment) and inside torch (learner), by self time."""
    out = {"environment": 0.0, "learner": 0.0, "other": 0.0}
    for (filename, _, _), (_, _, tottime, _, _) in stats.stats.items():  # type: ignore[attr-defined]
        if "/agspec/" in filename and "/agspec/train/" not in filename:
            out["environment"] += tottime
        elif "/torch/" in filename or filename == "~":
            out["learner"] += tottime
        else:
            out["other"] += tottime
    return out


def one(algorithm: str, scenario: str, steps: int, work: Path, profiled: bool, device: str = "cpu") -> dict:
    config = resolve_config(algorithm, scenario, 0, {"budget.env_steps": steps, "validation.indices": [],
                                                      "runtime.threads": 1, "runtime.device": device})
    profile = cProfile.Profile() if profiled else None
    started = time.perf_counter()
    if profile is not None:
        profile.enable()
    summary = train(config, work / algorithm)
    if profile is not None:
        profile.disable()
    seconds = time.perf_counter() - started
    robots = len(parallel_env(scenario, index=0).possible_agents)
    # cProfile slows Python-heavy code (the environment) more than torch's kernels: with --profile the
    # throughput is lower and the environment's share an upper bound
    parts = split_profile(pstats.Stats(profile)) if profile is not None else {}
    total = sum(parts.values()) or 1.0
    return {"algorithm": algorithm, "env_steps": summary["steps"], "seconds": round(seconds, 1),
            "env_steps_per_s": round(summary["steps"] / seconds, 1),
            "agent_samples_per_s": round(summary["steps"] * robots / seconds, 1),
            **{f"{k}_share": round(v / total, 3) for k, v in parts.items()},
            "projected_run_hours": round(PAPER_STEPS / (summary["steps"] / seconds) / 3600, 1)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="coalition-medium")
    ap.add_argument("--steps", type=int, default=8000, help="past the 3,200-step warm-ups of the table")
    ap.add_argument("--algorithms", default="ippo,mappo,qmix")
    ap.add_argument("--profile", action="store_true", help="also split the time (cProfile; slower)")
    ap.add_argument("--device", default="cpu", help="the learner's torch device (cpu, cuda)")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    torch.set_num_threads(1)
    work = Path(tempfile.mkdtemp(prefix="agspec-throughput-"))
    baseline = env_alone(args.scenario, 400)
    rows = [one(a, args.scenario, args.steps, work, args.profile, args.device) for a in args.algorithms.split(",")]
    hours = [r["projected_run_hours"] for r in rows]
    result = {"scenario": args.scenario, "device": args.device, "env_alone_steps_per_s": round(baseline, 1), "runs": rows,
              "projected_campaign_core_hours": round(sum(hours) / len(hours) * RUNS, 1)}
    emit(result, rows, ["algorithm", "env_steps", "seconds", "env_steps_per_s", "agent_samples_per_s",
                        "environment_share", "learner_share", "other_share", "projected_run_hours"],
         f"training throughput on {args.scenario} (env alone: {baseline:.0f} steps/s)", args.json)


if __name__ == "__main__":
    main()
