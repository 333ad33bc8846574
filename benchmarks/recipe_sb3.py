"""Recipe: train with Stable-Baselines3 + sb3-contrib MaskablePPO through SuperSuit, evaluate with agspec.

    pip install torch==2.13.0 stable-baselines3 sb3-contrib supersuit   # not agspec dependencies
    python benchmarks/recipe_sb3.py --scenario flow-easy --seed 0 --env-steps 2000 -o runs/sb3-flow-easy

The glue is the part of docs/training.md ("Training with other libraries") this script runs:

* the environment is ``parallel_env(scenario, split="training", seed=K)`` (A-PZ-SPLIT): it cycles
  the run's five training realizations on reset, because SuperSuit never passes reset options;
  ``realization_steps`` makes the paper's consecutive blocks of the budget;
* the reward is the paper's ``coalition_milestone_v1`` (A-REWARD-MILESTONE);
* SuperSuit turns the robots into the sub-environments of one vector env (one shared policy, as
  parameter sharing in the paper), and :class:`ActionMasks` hands each robot's O-MASK to
  MaskablePPO, which never samples a masked action;
* the trained model is evaluated by ``agspec evaluate --policy benchmarks/recipe_sb3_policy.py:make_policy``
  on the validation instances 200–204, against the random masked reference.

It prints env steps/s and agent samples/s of training and the validation table; the budget here is
tiny (a smoke run of the recipe), so the numbers say that it runs, not what it learns.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import supersuit as ss
from sb3_contrib import MaskablePPO
from stable_baselines3.common.vec_env import VecEnvWrapper

import recipe_common
from agspec import threads
from agspec.pettingzoo import coalition_milestone_v1, parallel_env

HERE = Path(__file__).resolve().parent


class ActionMasks(VecEnvWrapper):
    """MaskablePPO reads masks through ``env_method("action_masks")``: give it the mask each robot's
    last observation carries (its ``action_mask`` entry, A-PZ-SPACES)."""

    def reset(self):
        self.last = self.venv.reset()
        return self.last

    def step_wait(self):
        self.last, rewards, dones, infos = self.venv.step_wait()
        return self.last, rewards, dones, infos

    def env_method(self, method_name, *args, indices=None, **kwargs):
        if method_name == "action_masks":
            return list(self.last["action_mask"].astype(bool))
        return self.venv.env_method(method_name, *args, indices=indices, **kwargs)

    def has_attr(self, attr_name):
        return attr_name == "action_masks" or self.venv.has_attr(attr_name)

    def seed(self, seed=None):
        # SuperSuit's vector env has no seed(); nothing to seed anyway: v1 dynamics draw no random number,
        # and MaskablePPO seeds its own sampling (torch) from `seed`
        return [seed] * self.num_envs


def make_env(scenario: str, seed: int, env_steps: int, copies: int, max_cycles: int | None):
    """The training env: the run's realizations in blocks of env_steps / 5 per copy, the paper's reward."""
    block = max(1, env_steps // (5 * copies))  # A-PZ-SPLIT: the paper's consecutive blocks
    par = coalition_milestone_v1(parallel_env(scenario, split="training", seed=seed, realization_steps=block,
                                              max_cycles=max_cycles), support_credit="agent")
    agents = len(par.possible_agents)
    vec = ss.pettingzoo_env_to_vec_env_v1(par)
    vec = ss.concat_vec_envs_v1(vec, copies, num_cpus=0, base_class="stable_baselines3")
    return ActionMasks(vec), agents


def train(args: argparse.Namespace) -> dict:
    threads.apply(threads.budget(1, args.threads))  # CAMP-THREADS; the evaluation's hosts inherit it
    venv, agents = make_env(args.scenario, args.seed, args.env_steps, args.copies, args.max_cycles)
    samples = args.env_steps * agents  # SB3 counts one timestep per robot and copy
    n_steps = max(8, args.rollout // args.copies)  # env steps per copy per rollout
    model = MaskablePPO("MultiInputPolicy", venv, n_steps=n_steps, batch_size=min(4096, n_steps * agents * args.copies),
                        n_epochs=4, learning_rate=3e-4, gamma=0.99, gae_lambda=0.95, clip_range=0.1,
                        ent_coef=0.01, seed=args.seed, device="cpu", verbose=0)
    started = time.perf_counter()
    model.learn(total_timesteps=samples)
    seconds = time.perf_counter() - started
    args.out.mkdir(parents=True, exist_ok=True)
    model.save(args.out / "model.zip")
    venv.close()
    return {"env_steps": args.env_steps, "agents": agents, "agent_samples": samples, "train_seconds": round(seconds, 1),
            "env_steps_per_s": round(args.env_steps / seconds, 1), "samples_per_s": round(samples / seconds, 1)}


def evaluate(args: argparse.Namespace) -> dict:
    return recipe_common.evaluate(args, HERE / "recipe_sb3_policy.py", "sb3-maskable-ppo",
                                  {"AGSPEC_SB3_MODEL": str(args.out / "model.zip")})


if __name__ == "__main__":
    recipe_common.main(recipe_common.parser(__doc__.splitlines()[0], "runs/sb3", copies=True), train, evaluate)
