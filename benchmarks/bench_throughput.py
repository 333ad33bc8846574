"""Throughput where users wait: the PettingZoo loop's env steps/s and plain episodes' ticks/s, against
one or more baseline builds measured in the same run.

Usage:  python benchmarks/bench_throughput.py --baseline NAME=PY [--baseline NAME=PY ...]
                                              [--reps 5] [--steps 400] [--index 1000]
                                              [--scenario S ...] [--controller C ...] [--only pz|train|run]
                                              [--json]

Three figures per scenario, each in fresh processes of every build, interleaved (the order rotates
every repetition, so load from other processes hits every side alike), ``--reps`` times; the
tables show the medians and each build's ratio to every baseline:

* **PettingZoo loop** — ``parallel_env(S, index=N)``: ``reset`` + ``step`` until the episode ends
  (``--steps`` env steps), every agent taking a uniformly random legal action of its
  ``action_mask`` (a NumPy generator seeded 0, drawn outside the timer, so a policy's cost is not
  counted).  CPU seconds of the process (``time.process_time``), plus the median and 99th
  percentile of one step.  Target: ``PZ_TARGET`` × the first baseline on ``PZ_CELLS``.
* **Training copy** — the trainer's environment copy (``agspec.train.rollout.make_vector``, one copy in
  this process, the state vector of MAPPO's critic and the milestone reward, T-COPIES, T-REWARD) under
  the same random legal actions, restarted when its episode ends: what ``agspec train`` waits for per
  env step besides the networks.  No target of its own (it rides on the PettingZoo loop's).
* **Plain episodes** — ``run_episode(instance, controller, horizon=--steps)``, what ``agspec run``
  does (interpreter, its M-CAPACITY samples and the controller).  Target: at least the ticks/s of
  the baseline named ``RUN_FLOOR`` (the first release of the interpreter) on every cell.

``NAME=PY``: a label (the commit, say) and the Python of a virtual environment with that build
installed (see docs/performance.md).  Without a baseline the script prints this build's figures
only.  Figures depend on the machine and its load; nothing is asserted.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time

from _common import baseline_python, ratio_table, run_json, self_peak_mib

PZ_TARGET = 2.5  # the PettingZoo loop: >= 2.5x the first baseline's env steps/s
PZ_CELLS = ("coalition-medium", "concurrency-hard")
RUN_FLOOR = "abdc822"  # plain episodes: ticks/s at least the first interpreter release's


# --------------------------------------------------------------------------- one measurement (worker)


def pz_loop(scenario: str, index: int, steps: int) -> dict:
    import numpy as np

    from agspec.pettingzoo import parallel_env

    env = parallel_env(scenario, index=index, max_cycles=steps)
    rng = np.random.default_rng(0)
    t0 = time.process_time()
    obs, _ = env.reset(seed=0)
    elapsed = time.process_time() - t0
    per_step = []
    while env.agents:
        actions = {a: int(rng.choice(np.flatnonzero(o["action_mask"]))) for a, o in obs.items()}
        t0 = time.process_time()
        obs, *_ = env.step(actions)
        dt = time.process_time() - t0
        per_step.append(dt)
        elapsed += dt
    per_step.sort()
    n = len(per_step)
    return {"scenario": scenario, "robots": len(env.possible_agents), "steps": n, "seconds": round(elapsed, 4),
            "value": round(n / elapsed, 1), "p50_ms": round(per_step[n // 2] * 1e3, 3),
            "p99_ms": round(per_step[min(n - 1, round(0.99 * (n - 1)))] * 1e3, 3)}


def train_copy(scenario: str, index: int, steps: int) -> dict:
    import numpy as np

    from agspec.catalogue import load_instance
    from agspec.train.rollout import make_vector, restart, start_block

    instance = load_instance(scenario, index=index)
    vec = make_vector(instance, 1, "agent", True, "sync")
    rng = np.random.default_rng(0)
    t0 = time.process_time()
    obs = start_block(vec, instance)
    elapsed = time.process_time() - t0
    for _ in range(steps):
        action = np.array([[rng.choice(np.flatnonzero(row)) for row in obs["mask"][0]]])
        t0 = time.process_time()
        nxt, _, term, trunc, _ = vec.step(action)
        obs = restart(vec, nxt, np.logical_or(term, trunc))
        elapsed += time.process_time() - t0
    vec.close()
    return {"scenario": scenario, "steps": steps, "seconds": round(elapsed, 4), "value": round(steps / elapsed, 1)}


def plain_run(scenario: str, controller: str, index: int, ticks: int) -> dict:
    from agspec.catalogue import load_scenario_bundle
    from agspec.evaluate import run_episode
    from agspec.ir.instance import make_instance

    sc, recipes, profile = load_scenario_bundle(scenario)
    inst = make_instance(sc, recipes, profile, index=index)
    t0 = time.process_time()
    result = run_episode(inst, controller, horizon=ticks)
    elapsed = time.process_time() - t0
    n = result.metrics["ticks"]
    return {"scenario": scenario, "controller": controller, "ticks": n, "seconds": round(elapsed, 4),
            "value": round(n / elapsed, 1), "delivered": result.metrics["delivered"]}


# --------------------------------------------------------------------------- driver


def interleaved(args: list[str], reps: int, sides: dict[str, str]) -> dict:
    """Median of the workers' ``value`` per side; the order of the sides rotates every repetition."""
    names = list(sides)
    samples: dict[str, list[float]] = {k: [] for k in names}
    last: dict[str, dict] = {}
    for rep in range(reps):
        order = names[rep % len(names):] + names[:rep % len(names)]
        if rep % 2:
            order.reverse()
        for side in order:
            last[side] = run_json(sides[side], __file__, args)
            samples[side].append(last[side]["value"])
    return {"median": {k: statistics.median(v) for k, v in samples.items()}, "samples": samples, "last": last}


def _rows(kind: str, cells: list[tuple[list[str], dict]], reps: int, sides: dict[str, str]) -> list[dict]:
    baselines = [s for s in sides if s != "new"]
    rows = []
    for args, row in cells:
        r = interleaved(["--worker", kind, *args], reps, sides)
        med = r["median"]
        row = {**row, **{f"{s} /s": med[s] for s in sides}}
        for b in baselines:
            row[f"x {b}"] = med["new"] / med[b] if med[b] else None
        if kind == "pz":
            row["p50 ms"] = r["last"]["new"]["p50_ms"]
            row["p99 ms"] = r["last"]["new"]["p99_ms"]
            if baselines:
                row[f"{baselines[0]} p99 ms"] = r["last"][baselines[0]]["p99_ms"]
                row["ok"] = row[f"x {baselines[0]}"] >= PZ_TARGET if row["scenario"] in PZ_CELLS else None
        elif RUN_FLOOR in sides:
            row["ok"] = row[f"x {RUN_FLOOR}"] >= 1.0
        row["samples"] = r["samples"]
        rows.append(row)
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--baseline", action="append", default=[], metavar="NAME=PY",
                    help="a baseline build: label and the Python of its virtual environment (repeatable)")
    ap.add_argument("--reps", type=int, default=5, help="interleaved runs per side and cell (median)")
    ap.add_argument("--steps", type=int, default=400)
    ap.add_argument("--index", type=int, default=1000)
    ap.add_argument("--scenario", action="append", default=None)
    ap.add_argument("--controller", action="append", default=None, help="plain episodes' controllers")
    ap.add_argument("--only", choices=("pz", "train", "run"), default=None, help="one of the three figures")
    ap.add_argument("--worker", choices=("pz", "train", "run"), default=None, help=argparse.SUPPRESS)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    scenarios = args.scenario or list(PZ_CELLS)
    controllers = args.controller or ["greedy", "random"]
    if args.worker:  # one measurement in this Python: the driver's subprocess
        c = controllers[0]
        if args.worker == "pz":
            result = pz_loop(scenarios[0], args.index, args.steps)
        elif args.worker == "train":
            result = train_copy(scenarios[0], args.index, args.steps)
        else:
            result = plain_run(scenarios[0], c, args.index, args.steps)
        print(json.dumps({**result, "peak_rss_mib": round(self_peak_mib(), 1)}))
        return
    sides = {"new": sys.executable}
    for spec in args.baseline:
        name, sep, python = spec.partition("=")
        if not sep or not name or name == "new":
            raise SystemExit(f"--baseline takes NAME=PY, got {spec!r}")
        sides[name] = baseline_python(python)
    common = ["--index", str(args.index), "--steps", str(args.steps)]
    out: dict = {"benchmark": "throughput", "reps": args.reps, "steps": args.steps, "index": args.index,
                 "pz_target": PZ_TARGET, "pz_cells": PZ_CELLS, "run_floor": RUN_FLOOR}
    if args.only in (None, "pz"):
        out["pz"] = _rows("pz", [(["--scenario", s, *common], {"scenario": s}) for s in scenarios],
                          args.reps, sides)
    if args.only in (None, "train"):
        out["train"] = _rows("train", [(["--scenario", s, *common], {"scenario": s}) for s in scenarios],
                             args.reps, sides)
    if args.only in (None, "run"):
        out["run"] = _rows("run", [(["--scenario", s, "--controller", c, *common], {"scenario": s, "controller": c})
                                   for s in scenarios for c in controllers], args.reps, sides)
    if args.json:
        print(json.dumps(out, indent=2))
        return
    for kind, title in (("pz", f"PettingZoo loop, env steps/s (masked random actions; target >= {PZ_TARGET} x "
                                f"the first baseline on {', '.join(PZ_CELLS)})"),
                        ("train", "training copy (make_vector, MAPPO's state vector and milestone reward), env steps/s"),
                        ("run", f"plain episodes (run_episode), ticks/s (target >= 1.0 x {RUN_FLOOR})")):
        if kind in out:
            keys = [k for k in out[kind][0] if k != "samples"]
            ratio_table(f"{title}; medians of {args.reps} interleaved runs, index {args.index}, {args.steps} steps",
                        out[kind], [(k, k) for k in keys])
    print(json.dumps(out))


if __name__ == "__main__":
    main()
