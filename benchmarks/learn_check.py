"""Evidence that the trainer learns (spec/16-training.md): IPPO and MAPPO (and QMIX, reported whatever
its figures) trained on flow-easy and one coalition scenario for a small budget, several seeds, then
delivered on the validation instances 200-204 against Random masked and Greedy.

Usage:  python benchmarks/learn_check.py [--budget 8000 | --budget flow-easy=8000,coalition-easy=20000]
                                         [--qmix-budget 1000] [--seeds 0,1,2] [--paper]
                                         [--scenarios flow-easy,coalition-easy] [--algorithms ippo,mappo,qmix]
                                         [-j 2] [--device cpu] [--envs 1] [--set KEY=VALUE …]
                                         [--deadline-s 840] [--out DIR] [--json]

A --set of a setting the algorithm lacks (ppo.* for QMIX, replay.* for PPO) is skipped for it.
By default the runs use FAST settings (shorter PPO updates, learning rates 1e-3, target KL 0.05, shorter
warm-ups) so that learning shows within minutes on a CPU; --paper keeps the table's settings and changes
only the budget (the paper's runs need 1,536,000 steps).  Each run is a fresh `agspec train` process (`--threads 1`, -j of them at a time) with the paper's
configuration but the budget (and any --set); validation runs once, after the last block, through the
evaluation's own runner (T-VALIDATION, greedy action T-EVAL-ACTION).  The table shows, per scenario
and method, each seed's mean delivered on 200-204, the mean over seeds, the training episodes'
delivered in the last record row (sampled actions), and the references' means on the same
instances.  "learns" means the mean over seeds of the greedy validation beats Random masked by more
than its own spread (max(1, 2 × Random's half-width)) with the policy's own sampled actions (both are
stochastic policies); the paper's greedy evaluation action (argmax) is shown beside it, since early in
training an argmax policy is often degenerate (the paper's held-out values also lie below its training
curves).  Runs past --deadline-s are stopped and
reported from their record.  Nothing is asserted.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

from _common import machine

PPO_DEFAULTS = ("validation.initial=false", "validation.every_block=false", "checkpoint.every_steps=null",
                "validation.actions=[greedy, sample]")
# --fast (the default): settings that learn within minutes on a CPU, against the table's (--paper):
# shorter updates with bigger steps; everything else is tab:marlconfig
FAST = ("ppo.steps_per_update=200", "ppo.minibatch=1000", "warmup.critic_steps=400", "lr.actor=0.001",
        "lr.critic=0.001", "ppo.target_kl=0.05", "warmup.replay_transitions=400", "replay.target_sync_every=400")


def run_one(out: Path, algorithm: str, scenario: str, seed: int, budget: int, device: str, envs: int,
            sets: list[str], deadline: float) -> dict[str, Any]:
    cmd = [sys.executable, "-c", "from agspec.cli.main import main; main()", "train", "--algorithm", algorithm,
           "--scenario", scenario, "--seed", str(seed), "--steps", str(budget), "--threads", "1", "--device", device,
           "--envs", str(envs), "-o", str(out), "--format", "json"]
    from agspec.train.config import paper_defaults

    defaults = paper_defaults(algorithm)
    for s in (*PPO_DEFAULTS, f"record.every_steps={max(envs, budget // 20 // envs * envs)}", *sets):
        node: Any = defaults
        for part in s.split("=", 1)[0].split("."):
            node = node.get(part) if isinstance(node, dict) else None
        if node is not None or s.split("=", 1)[0] == "checkpoint.every_steps":  # a setting this algorithm has
            cmd += ["--set", s]
    t0 = time.perf_counter()
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=max(1.0, deadline - time.time()))
        status = "complete" if proc.returncode == 0 else f"exit {proc.returncode}: {proc.stderr.strip()[-300:]}"
    except subprocess.TimeoutExpired:
        status = "stopped at the deadline"
    result: dict[str, Any] = {"algorithm": algorithm, "scenario": scenario, "seed": seed, "status": status,
                              "wall_s": round(time.perf_counter() - t0, 1), "validation": None, "sampled": None,
                              "train_delivered": None, "steps": 0}
    record = out / "record.jsonl"
    if record.exists():
        rows = [json.loads(line) for line in record.read_text().splitlines() if line.strip()]
        progress = [r for r in rows if r["kind"] == "progress" and r.get("delivered") is not None]
        vals = [r for r in rows if r["kind"] == "validation" and r["phase"] != "initial" and r["action"] == "greedy"]
        sampled = [r for r in rows if r["kind"] == "validation" and r["phase"] != "initial" and r["action"] == "sample"]
        if sampled:
            result["sampled"] = sampled[-1]["delivered_mean"]
        if progress:
            result["train_delivered"] = progress[-1]["delivered"]
            result["steps"] = progress[-1]["steps"]
            result["train_curve"] = [(r["steps"], r["delivered"]) for r in progress]
        if vals:
            result["validation"] = vals[-1]["delivered_mean"]
            result["validation_per_index"] = vals[-1]["delivered"]
    return result


def budget_of(text: str, scenario: str) -> int:
    """--budget N, or S=N,... per scenario (a scenario not named takes the first number)."""
    if "=" not in text:
        return int(text)
    pairs = dict(item.split("=", 1) for item in text.split(","))
    return int(pairs.get(scenario, next(iter(pairs.values()))))


def references(scenarios: list[str], indices: list[int]) -> dict[tuple[str, str], dict[str, float]]:
    from agspec.catalogue import load_instance
    from agspec.evaluate import mean_ci, run_episode

    out = {}
    for scenario in scenarios:
        for ctl in ("random", "greedy"):
            values = [run_episode(load_instance(scenario, i), ctl).metrics["delivered"] for i in indices]
            mean, half = mean_ci([float(v) for v in values])
            out[(scenario, ctl)] = {"mean": mean, "half_width": half, "values": values}
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--budget", default="8000",
                    help="environment steps per run: N, or per scenario, e.g. flow-easy=5000,coalition-easy=20000")
    ap.add_argument("--qmix-budget", type=int, default=1_000, help="QMIX's budget (its TD updates are slow on a CPU)")
    ap.add_argument("--seeds", default="0,1,2")
    ap.add_argument("--scenarios", default="flow-easy,coalition-easy")
    ap.add_argument("--algorithms", default="ippo,mappo,qmix")
    ap.add_argument("-j", "--jobs", type=int, default=2)
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--envs", type=int, default=1)
    ap.add_argument("--set", dest="sets", action="append", default=[])
    ap.add_argument("--paper", action="store_true", help="the table's settings (only the budget changed)")
    ap.add_argument("--deadline-s", type=float, default=840.0)
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    scenarios, algorithms = args.scenarios.split(","), args.algorithms.split(",")
    seeds = [int(s) for s in args.seeds.split(",")]
    deadline = time.time() + args.deadline_s
    root = args.out or Path(tempfile.mkdtemp(prefix="learn-check-"))
    root.mkdir(parents=True, exist_ok=True)
    jobs = [(a, s, k) for a in algorithms for s in scenarios for k in seeds]
    t0 = time.perf_counter()
    with ThreadPoolExecutor(max_workers=args.jobs) as pool:
        futures = [pool.submit(run_one, root / f"{a}-{s}-s{k}", a, s, k,
                               args.qmix_budget if a == "qmix" else budget_of(args.budget, s),
                               args.device, args.envs, [*(() if args.paper else FAST), *args.sets], deadline)
                   for a, s, k in jobs]
        results = [f.result() for f in futures]
    refs = references(scenarios, [200, 201, 202, 203, 204])
    verdicts = []
    for scenario in scenarios:
        rnd = refs[(scenario, "random")]
        for algorithm in algorithms:
            mine = [r for r in results if r["scenario"] == scenario and r["algorithm"] == algorithm]
            vals = [r["validation"] for r in mine if r["validation"] is not None]
            mean = statistics.fmean(vals) if vals else None
            sampled = [r["sampled"] for r in mine if r["sampled"] is not None]
            sampled_mean = statistics.fmean(sampled) if sampled else None
            margin = max(1.0, 2 * rnd["half_width"])
            learns = sampled_mean is not None and sampled_mean > rnd["mean"] + margin
            verdicts.append({"scenario": scenario, "algorithm": algorithm, "validation_per_seed": vals,
                             "validation_mean": mean, "sampled_per_seed": sampled, "sampled_mean": sampled_mean,
                             "greedy_beats_random": mean is not None and mean > rnd["mean"] + margin,
                             "random": rnd["mean"], "greedy": refs[(scenario, "greedy")]["mean"],
                             "train_delivered_per_seed": [r["train_delivered"] for r in mine],
                             "steps_per_seed": [r["steps"] for r in mine], "learns": learns})
    report = {"machine": machine(), "budget": args.budget, "qmix_budget": args.qmix_budget,
              "settings": "paper" if args.paper else list(FAST),
              "device": args.device, "envs": args.envs, "sets": args.sets, "wall_s": round(time.perf_counter() - t0, 1),
              "out": str(root), "verdicts": verdicts, "runs": results,
              "references": {f"{s}/{c}": v for (s, c), v in refs.items()}}
    (root / "learn_check.json").write_text(json.dumps(report, indent=2))
    if args.json:
        print(json.dumps(report, indent=2))
        return
    print(f"learn check: budget {args.budget} steps (QMIX {report['qmix_budget']}), seeds {seeds}, device {args.device}, "
          f"{args.jobs} at a time, {report['wall_s']} s; runs in {root}")
    print("delivered on validation 200-204 (mean of 5 episodes per seed); 'sampled': the policy's own sampled "
          "actions,\n'argmax': the paper's evaluation action; 'train': training episodes in the last record row")
    print(f"{'scenario':15} {'method':6} {'sampled per seed':18} {'mean':>5}  {'argmax per seed':18} {'mean':>5} "
          f"{'Random':>6} {'Greedy':>6} {'train':>16}  verdict (sampled vs Random masked)")

    def fmt(xs: list) -> str:
        return ", ".join("—" if x is None else f"{x:.1f}" for x in xs) or "—"

    for v in verdicts:
        sm = f"{v['sampled_mean']:.2f}" if v["sampled_mean"] is not None else "—"
        gm = f"{v['validation_mean']:.2f}" if v["validation_mean"] is not None else "—"
        verdict = "learns" if v["learns"] else ("reported" if v["algorithm"] == "qmix" else "does NOT beat random")
        print(f"{v['scenario']:15} {v['algorithm']:6} {fmt(v['sampled_per_seed']):18} {sm:>5}  "
              f"{fmt(v['validation_per_seed']):18} {gm:>5} {v['random']:>6.2f} {v['greedy']:>6.2f} "
              f"{fmt(v['train_delivered_per_seed']):>16}  {verdict}")
    for r in results:
        if r["status"] != "complete":
            print(f"  {r['algorithm']} {r['scenario']} seed {r['seed']}: {r['status']} (at {r['steps']} steps)")


if __name__ == "__main__":
    main()
