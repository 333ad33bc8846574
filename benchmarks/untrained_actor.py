"""Is the untrained IPPO actor a uniform masked policy? (spec/16-training.md, RES-UNTRAINED-ACTOR)

For each algorithm seed k the actor is built exactly as ``agspec train --algorithm ippo --seed k``
builds it (the run's weight-initialization stream, T-DETERMINISM), and plays episodes of the run's
first training realization (block 0, RES-TRAINING-SEEDS; every episode of a block replays it,
T-EPISODES) through the trainer's own sampling (``PPOLearner.act``: masked softmax, T-MASK).  Beside
it, on the same realization, a uniform masked policy draws each agent's action uniformly among its
legal actions.  Two measurements:

* the action distribution: at every agent-tick of the actor's episodes, the actor's probabilities
  against uniform over the legal actions — total-variation distance, the largest probability ratio,
  and each family's mass (the family + slot logit sum of T-ACTOR could make it uniform over families
  rather than over actions);
* delivered per episode, actor vs uniform, per seed (its realization) and paired over seeds: the
  standard error is over seeds (realizations differ much more than episodes of one realization).

Usage:  OMP_NUM_THREADS=1 python benchmarks/untrained_actor.py [--scenario flow-easy] [--seeds 0-29]
                                                                [--episodes 4] [--json]
Nothing is asserted; the figures are recorded in spec/16-training.md (RES-UNTRAINED-ACTOR).
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
import time
from typing import Any

import numpy as np
import torch

from agspec.train.api import resolve_config
from agspec.checkpoint import nets
from agspec.train import curriculum
from agspec.train.rollout import TeamEnv
from agspec.train.run import _learner


def seeds_arg(text: str) -> list[int]:
    out: list[int] = []
    for part in text.split(","):
        lo, _, hi = part.partition("-")
        out += list(range(int(lo), int(hi or lo) + 1))
    return out


def episode(env: TeamEnv, choose) -> tuple[int, list[tuple[np.ndarray, np.ndarray]]]:
    """One episode of the realization; returns delivered and the (obs, mask) batches it saw."""
    obs, _ = env.reset()
    delivered, seen, done = 0, [], False
    while not done:
        seen.append((obs["obs"], obs["mask"]))
        obs, _team, term, trunc, info = env.step(choose(obs))
        delivered += int(info["delivered"])
        done = term or trunc
    return delivered, seen


class Distribution:
    """Actor probabilities against uniform masked, summed over agent-ticks."""

    def __init__(self) -> None:
        self.n = 0
        self.tv = 0.0
        self.max_ratio = 1.0
        self.min_ratio = 1.0
        self.family_actor = np.zeros(len(nets.FAMILIES))
        self.family_uniform = np.zeros(len(nets.FAMILIES))
        self.multi_family = 0  # agent-ticks with legal actions in two or more families

    def add(self, actor: torch.nn.Module, obs: np.ndarray, mask: np.ndarray) -> None:
        with torch.no_grad():
            probs = torch.softmax(nets.masked_logits(actor(torch.from_numpy(obs)), torch.from_numpy(mask)), -1).numpy()
        legal = mask.astype(bool)
        uniform = legal / legal.sum(-1, keepdims=True)
        fam = nets.action_families().numpy()
        for a in range(obs.shape[0]):
            p, u, m = probs[a], uniform[a], legal[a]
            self.n += 1
            self.tv += 0.5 * float(np.abs(p - u).sum())
            ratio = p[m] / u[m]
            self.max_ratio = max(self.max_ratio, float(ratio.max()))
            self.min_ratio = min(self.min_ratio, float(ratio.min()))
            fa, fu = np.bincount(fam, p, len(nets.FAMILIES)), np.bincount(fam, u, len(nets.FAMILIES))
            self.family_actor += fa
            self.family_uniform += fu
            self.multi_family += int((np.bincount(fam[m], minlength=len(nets.FAMILIES)) > 0).sum() >= 2)

    def summary(self) -> dict[str, Any]:
        return {"agent_ticks": self.n, "mean_total_variation": self.tv / max(1, self.n),
                "max_probability_ratio": self.max_ratio, "min_probability_ratio": self.min_ratio,
                "agent_ticks_with_two_or_more_legal_families": self.multi_family,
                "family_mass_actor": dict(zip(nets.FAMILIES, (self.family_actor / max(1, self.n)).round(6).tolist())),
                "family_mass_uniform": dict(zip(nets.FAMILIES,
                                                (self.family_uniform / max(1, self.n)).round(6).tolist()))}


def mean_se(values: list[float]) -> tuple[float, float]:
    if len(values) < 2:
        return (values[0] if values else math.nan), math.nan
    return statistics.fmean(values), statistics.stdev(values) / math.sqrt(len(values))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenario", default="flow-easy")
    ap.add_argument("--algorithm", default="ippo", choices=("ippo", "mappo"))
    ap.add_argument("--seeds", default="0-29", type=seeds_arg)
    ap.add_argument("--episodes", type=int, default=4, help="episodes per policy and seed")
    ap.add_argument("--distribution-seeds", type=int, default=5,
                    help="measure the action distribution on the first N seeds' actor episodes")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    torch.set_num_threads(1)
    started = time.perf_counter()
    dist = Distribution()
    per_seed = []
    for n, seed in enumerate(args.seeds):
        config = resolve_config(args.algorithm, args.scenario, seed)
        blocks = curriculum.plan(config)
        inst = curriculum.training_instances(config, blocks[:1])[0]
        env = TeamEnv(inst, config["reward"]["support_credit"], config["critic"]["input"] == "state+observation")
        learner = _learner(config, len(env.agents), int(env.par.state_space.shape[0]), torch.device("cpu"))

        def actor_choice(obs: dict[str, np.ndarray]) -> np.ndarray:
            state = torch.from_numpy(obs["state"]) if "state" in obs else None
            actions, _logp, _v = learner.act(torch.from_numpy(obs["obs"]), torch.from_numpy(obs["mask"]), state)
            return actions.numpy()

        rng = np.random.default_rng(10_000 + seed)

        def uniform_choice(obs: dict[str, np.ndarray]) -> np.ndarray:
            return np.array([rng.choice(np.flatnonzero(m)) for m in obs["mask"]])

        actor, uniform = [], []
        for _ in range(args.episodes):
            d, seen = episode(env, actor_choice)
            actor.append(d)
            if n < args.distribution_seeds:
                for o, m in seen:
                    dist.add(learner.actor, o, m)
            uniform.append(episode(env, uniform_choice)[0])
        per_seed.append({"seed": seed, "instance": inst["id"], "actor": actor, "uniform": uniform,
                         "actor_mean": statistics.fmean(actor), "uniform_mean": statistics.fmean(uniform)})
        if not args.json:
            print(f"seed {seed:3d}: actor {statistics.fmean(actor):5.2f} {actor}  uniform "
                  f"{statistics.fmean(uniform):5.2f} {uniform}", file=sys.stderr, flush=True)
    a_mean, a_se = mean_se([s["actor_mean"] for s in per_seed])
    u_mean, u_se = mean_se([s["uniform_mean"] for s in per_seed])
    d_mean, d_se = mean_se([s["actor_mean"] - s["uniform_mean"] for s in per_seed])
    first3 = per_seed[:3]
    out = {"scenario": args.scenario, "algorithm": args.algorithm, "seeds": args.seeds,
           "episodes_per_policy_and_seed": args.episodes,
           "delivered": {"actor": {"mean": a_mean, "se_over_seeds": a_se},
                         "uniform": {"mean": u_mean, "se_over_seeds": u_se},
                         "paired_difference": {"mean": d_mean, "se_over_seeds": d_se}},
           "first_three_seeds": {"actor": statistics.fmean(s["actor_mean"] for s in first3),
                                 "uniform": statistics.fmean(s["uniform_mean"] for s in first3)} if first3 else None,
           "seed_to_seed_sd_of_uniform_mean": statistics.stdev(s["uniform_mean"] for s in per_seed)
           if len(per_seed) > 1 else None,
           # episode-to-episode spread within a realization (pooled over seeds): the noise of one episode
           "within_seed_episode_sd": {p: math.sqrt(statistics.fmean(statistics.variance(s[p]) for s in per_seed))
                                      for p in ("actor", "uniform")} if args.episodes > 1 else None,
           "distribution": dist.summary(), "per_seed": per_seed,
           "wall_time_s": round(time.perf_counter() - started, 1)}
    if args.json:
        print(json.dumps(out, indent=1))
    else:
        print(json.dumps({k: v for k, v in out.items() if k != "per_seed"}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
