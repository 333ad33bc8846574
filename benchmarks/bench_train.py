"""Training speed (spec/16-training.md): environment steps per second inside training against the
PettingZoo environment alone, learner samples per second, and where the time goes.

Usage:  python benchmarks/bench_train.py [--scenario coalition-medium] [--algorithm mappo|ippo|qmix]
                                         [--updates 2] [--steps-per-update 1600] [--envs 1,4]
                                         [--threads 1] [--device cpu] [--rollout-device learner|cpu]
                                         [--gpu-update-s 0.77] [--json]

* baseline: ``parallel_env`` reset + step with random masked actions (numpy), the env alone;
* rollout: the trainer's own collection (T-COPIES: the vector env, the actor on every agent of every
  copy, the critic's values), env steps per second of wall time, split into env, actor+critic, rest;
* update: one PPO update of the table's shape (4 epochs, minibatch 4,096), agent samples per second
  (samples × epochs / seconds) — or, for QMIX, TD updates per second at batch 64;
* the ratio rollout / baseline, and the projected wall time of one paper run (1,536,000 steps) and of
  the 270-run campaign from these rates (one process, this machine);
* per update, wall and process CPU seconds of each part: ``env`` (the vector env's step), ``act`` (the
  per-tick forward pass and sampling on the rollout's networks: a copy with ``--rollout-device cpu``,
  RES-ROLLOUT-DEVICE), the rest of the collection (tensors, restarts, stacking and the move to the
  learner's device), ``sync`` (loading the learner's weights into the copy) and the update; with
  ``--gpu-update-s`` also one paper run with these rollout parts and an update of that many seconds
  measured elsewhere (a GPU learner beside this CPU's rollout copy).
The load average before and after is printed: on a shared machine prefer the CPU seconds and ratios.
Nothing is asserted.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from typing import Any

import numpy as np

from _common import machine

BUDGET, RUNS = 1_536_000, 270


def baseline(scenario: str, steps: int) -> float:
    """Env steps/s of the PettingZoo env alone, random masked actions."""
    from agspec.pettingzoo import parallel_env

    env = parallel_env(scenario, index=0)
    obs, _ = env.reset(seed=0)
    rng = np.random.default_rng(0)
    t0 = time.perf_counter()
    for _ in range(steps):
        if not env.agents:
            obs, _ = env.reset(seed=0)
        obs, *_ = env.step({a: int(rng.choice(np.flatnonzero(o["action_mask"]))) for a, o in obs.items()})
    return steps / (time.perf_counter() - t0)


class Timer:
    """Wraps callables and sums their wall time and this process's CPU time (all its threads)."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = {}
        self.cpu: dict[str, float] = {}

    def wrap(self, name: str, fn: Any) -> Any:
        def timed(*a: Any, **kw: Any) -> Any:
            t0, c0 = time.perf_counter(), time.process_time()
            try:
                return fn(*a, **kw)
            finally:
                self.seconds[name] = self.seconds.get(name, 0.0) + time.perf_counter() - t0
                self.cpu[name] = self.cpu.get(name, 0.0) + time.process_time() - c0
        return timed


def per_update(total: dict[str, float], updates: int) -> dict[str, float]:
    return {k: round(v / updates, 3) for k, v in total.items()}


def measure(scenario: str, algorithm: str, envs: int, spu: int, updates: int, device: str,
            rollout_device: str = "learner", gpu_update_s: float | None = None) -> dict[str, Any]:
    import torch

    from agspec.train import acting, curriculum
    from agspec.train.api import resolve_config
    from agspec.train.rollout import EpisodeStats, make_vector, start_block
    from agspec.train.run import _dims, _learner, _rollout_device

    config = resolve_config(algorithm, scenario, 0, {"rollout.envs": envs, "runtime.device": device,
                                                     "runtime.rollout_device": rollout_device,
                                                     **({"ppo.steps_per_update": spu} if algorithm != "qmix" else {})})
    blocks = curriculum.plan(config)
    instance = curriculum.training_instances(config, blocks[:1])[0]
    n_agents, state_dim = _dims(instance)
    rollout = _rollout_device(config)
    learner = _learner(config, n_agents, state_dim, torch.device(device), rollout)
    vec = make_vector(instance, envs, config["reward"]["support_credit"], algorithm != "ippo",
                      "async" if envs > 1 else "sync")
    timer = Timer()
    vec.step = timer.wrap("env", vec.step)
    learner.sync_rollout = timer.wrap("sync", learner.sync_rollout)  # RES-ROLLOUT-DEVICE
    try:
        obs = start_block(vec, instance)
        episodes = EpisodeStats(envs)
        out: dict[str, Any] = {"scenario": scenario, "algorithm": algorithm, "envs": envs, "agents": n_agents,
                               "device": device, "rollout_device": acting.describe(torch.device(device), rollout),
                               "threads": torch.get_num_threads()}
        if algorithm == "qmix":
            learner.config = {**config, "warmup": {"replay_transitions": 64}}
            learner.act = timer.wrap("act", learner.act)
            learner.train_step = timer.wrap("td_update", learner.train_step)
            steps = spu * updates
            t0 = time.perf_counter()
            learner.run_ticks(vec, obs, steps // envs, episodes)
            wall = time.perf_counter() - t0
            out.update(env_steps_per_s=steps / wall, td_updates=learner.updates,
                       td_updates_per_s=learner.updates / max(timer.seconds.get("td_update", 1e-9), 1e-9),
                       split_s={k: round(v, 3) for k, v in timer.seconds.items()}, wall_s=round(wall, 3))
            per_run = BUDGET / out["env_steps_per_s"]
        else:
            learner.act = timer.wrap("act", learner.act)
            collect = timer.wrap("collect", learner.collect)
            update = timer.wrap("update", learner.update)
            samples = 0
            for k in range(updates):
                batch, obs = collect(vec, obs, spu // envs, episodes)
                stats = update(batch, 10_000 + spu * k)  # past the warm-up: the actor learns too
                samples += stats["samples"]
            steps = spu * updates
            wall, cpu = timer.seconds, timer.cpu
            collect_s, update_s = wall["collect"], wall["update"] - wall.get("sync", 0.0)
            wall["collect_rest"] = collect_s - wall["env"] - wall["act"]
            cpu["collect_rest"] = cpu["collect"] - cpu["env"] - cpu["act"]
            out.update(env_steps_per_s=steps / collect_s, learner_samples_per_s=samples / update_s,
                       collect_s=round(collect_s, 3), update_s=round(update_s, 3),
                       split_s={k: round(v, 3) for k, v in wall.items()},
                       per_update_wall_s=per_update(wall, updates), per_update_cpu_s=per_update(cpu, updates),
                       update_share=round(update_s / (collect_s + wall["update"]), 3))
            per_run = BUDGET / steps * (collect_s + wall["update"])
            if gpu_update_s is not None:
                # the rollout's parts as measured here, the update as measured on a GPU (RES-ROLLOUT-DEVICE)
                rollout_part = (collect_s + wall.get("sync", 0.0)) / updates
                out["projected_run_with_gpu_update_h"] = round(BUDGET / spu * (rollout_part + gpu_update_s) / 3600, 2)
        out["projected_run_h"] = round(per_run / 3600, 2)
        out["projected_campaign_h_one_process"] = round(per_run * RUNS / 3600, 1)
        return out
    finally:
        vec.close()


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--scenario", default="coalition-medium")
    ap.add_argument("--algorithm", default="mappo", choices=("ippo", "mappo", "qmix"))
    ap.add_argument("--updates", type=int, default=2)
    ap.add_argument("--steps-per-update", type=int, default=1600)
    ap.add_argument("--envs", default="1")
    ap.add_argument("--threads", type=int, default=None)
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--rollout-device", default="learner", help="runtime.rollout_device (RES-ROLLOUT-DEVICE)")
    ap.add_argument("--gpu-update-s", type=float, default=None,
                    help="project one paper run with this many seconds per update of --steps-per-update steps "
                         "(measured on a GPU)")
    ap.add_argument("--baseline-steps", type=int, default=800)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    import torch

    if args.threads:
        torch.set_num_threads(args.threads)
    load_before = os.getloadavg()
    base = baseline(args.scenario, args.baseline_steps)
    rows = [measure(args.scenario, args.algorithm, int(e), args.steps_per_update, args.updates, args.device,
                    args.rollout_device, args.gpu_update_s) for e in args.envs.split(",")]
    for row in rows:
        row["rollout_vs_env_alone"] = round(row["env_steps_per_s"] / base, 3)
    result = {"machine": machine(), "load_average": {"before": [round(x, 2) for x in load_before],
                                                     "after": [round(x, 2) for x in os.getloadavg()]},
              "baseline_env_steps_per_s": round(base, 1), "rows": rows}
    if args.json:
        print(json.dumps(result, indent=2))
        return
    print(f"load average (1, 5, 15 min) before {result['load_average']['before']}, "
          f"after {result['load_average']['after']}")
    print(f"PettingZoo env alone ({args.scenario}, random masked): {base:,.0f} env steps/s")
    for r in rows:
        print(f"{r['algorithm']} envs={r['envs']} device={r['device']} rollout on {r['rollout_device']} "
              f"threads={r['threads']}: "
              f"rollout {r['env_steps_per_s']:,.0f} env steps/s ({r['rollout_vs_env_alone']:.2f}x the env alone)")
        if "learner_samples_per_s" in r:
            print(f"  learner {r['learner_samples_per_s']:,.0f} agent samples/s; update share of the wall time "
                  f"{r['update_share']:.0%}; collect {r['collect_s']} s, update {r['update_s']} s, split {r['split_s']}")
            print(f"  per update, wall s {r['per_update_wall_s']}; process CPU s {r['per_update_cpu_s']}")
            if "projected_run_with_gpu_update_h" in r:
                print(f"  projected: one paper run with these rollout parts and a {args.gpu_update_s} s GPU update "
                      f"{r['projected_run_with_gpu_update_h']} h")
        else:
            print(f"  {r['td_updates_per_s']:,.1f} TD updates/s; split {r['split_s']}")
        print(f"  projected: one 1,536,000-step run {r['projected_run_h']} h; 270 runs in one process "
              f"{r['projected_campaign_h_one_process']} h")


if __name__ == "__main__":
    main()
