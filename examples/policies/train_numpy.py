"""Train numpy_policy.py on the PettingZoo env with the cross-entropy method (NumPy only).

    python examples/policies/train_numpy.py --scenario coalition-easy --iterations 6 --out numpy_policy.json

Fitness is the paper's training reward coalition_milestone_v1 summed over an episode of the training
indices 0-4 (never the final-test instances), with the episode cut at --cycles decisions.
"""

import argparse
import json
from pathlib import Path

import numpy as np

from agspec.pettingzoo import coalition_milestone_v1, parallel_env
from numpy_policy import N_FEATURES, make_policy


def episode_return(scenario: str, index: int, weights: np.ndarray, cycles: int) -> float:
    env = coalition_milestone_v1(parallel_env(scenario, index=index, max_cycles=cycles))
    obs, infos = env.reset(seed=index)
    policy = make_policy(env.unwrapped, weights)
    total = 0.0
    while env.agents:
        obs, rewards, _, _, infos = env.step(policy(obs, infos))
        total += float(np.mean(list(rewards.values()))) if rewards else 0.0
    return total


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="coalition-easy")
    ap.add_argument("--iterations", type=int, default=6)
    ap.add_argument("--population", type=int, default=12)
    ap.add_argument("--elite", type=int, default=3)
    ap.add_argument("--cycles", type=int, default=150)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=Path(__file__).with_name("numpy_policy.json"))
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    mean, std = np.zeros(N_FEATURES), np.ones(N_FEATURES)
    for it in range(args.iterations):
        pop = mean + std * rng.standard_normal((args.population, N_FEATURES))
        index = it % 5  # training split S-SPLITS: suite indices 0-4
        fitness = np.array([episode_return(args.scenario, index, w, args.cycles) for w in pop])
        elite = pop[np.argsort(fitness)[-args.elite:]]
        mean, std = elite.mean(axis=0), elite.std(axis=0) + 0.05
        print(f"iteration {it}: best {fitness.max():.2f}, mean {fitness.mean():.2f}", flush=True)
    args.out.write_text(json.dumps({"scenario": args.scenario, "method": "cross-entropy", "iterations": args.iterations,
                                    "weights": [round(float(x), 6) for x in mean]}, indent=1) + "\n")
    print(f"weights written to {args.out}")


if __name__ == "__main__":
    main()
