"""Recipe: train IPPO with TorchRL (one shared agent group), evaluate with agspec.

    pip install torch==2.13.0 torchrl tensordict   # not agspec dependencies
    python benchmarks/recipe_torchrl.py --scenario flow-easy --seed 0 --env-steps 2000 -o runs/torchrl-flow-easy

The glue is the part of docs/training.md ("Training with other libraries") this script runs:

* ``parallel_env(scenario, split="training", seed=K, realization_steps=…)`` (A-PZ-SPLIT) cycles the
  run's training realizations on reset; ``coalition_milestone_v1`` is the paper's reward;
* TorchRL's ``PettingZooWrapper`` with ``group_map={"robots": every robot}`` makes one agent group,
  so one actor and one critic are shared by every robot (parameter sharing); the observation's
  ``action_mask`` entry becomes the group's mask, and the actor samples from a
  ``MaskedCategorical`` (a masked action has probability 0);
* PPO from TorchRL's pieces: ``SyncDataCollector``, ``GAE``, ``ClipPPOLoss``, the clip and GAE
  values of the paper's table (0.10, γ 0.99, λ 0.95); the critic sees the robot's own
  observation (IPPO);
* the actor is saved as a state dict and evaluated by ``agspec evaluate --policy
  benchmarks/recipe_torchrl_policy.py:make_policy`` on the validation instances, with the masked
  argmax of its logits.

It prints env steps/s and agent samples/s of training and the validation table; the budget here is
tiny (a smoke run of the recipe), so the numbers say that it runs, not what it learns.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import torch
from tensordict.nn import TensorDictModule
from torch import nn
try:  # TorchRL 0.14 renamed the single-process collector
    from torchrl.collectors import Collector as SyncDataCollector
except ImportError:
    from torchrl.collectors import SyncDataCollector
from torchrl.data import LazyTensorStorage, ReplayBuffer, SamplerWithoutReplacement
from torchrl.envs.libs.pettingzoo import PettingZooWrapper
from torchrl.modules import MaskedCategorical, ProbabilisticActor, ValueOperator
from torchrl.objectives import ClipPPOLoss, ValueEstimators

from agspec import threads
from agspec.pettingzoo import coalition_milestone_v1, parallel_env

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import recipe_common  # noqa: E402
from recipe_torchrl_policy import actor_network  # noqa: E402  (the one definition of the actor)

GROUP = "robots"
OBS = (GROUP, "observation", "observation")  # the Dict space's "observation" entry, per robot


def make_env(scenario: str, seed: int, env_steps: int, max_cycles: int | None) -> PettingZooWrapper:
    par = coalition_milestone_v1(parallel_env(scenario, split="training", seed=seed,
                                              realization_steps=max(1, env_steps // 5), max_cycles=max_cycles),
                                 support_credit="agent")
    return PettingZooWrapper(par, group_map={GROUP: list(par.possible_agents)}, categorical_actions=True,
                             use_mask=False, return_state=False, seed=seed)


def train(args: argparse.Namespace) -> dict:
    torch.manual_seed(args.seed)
    threads.apply(threads.budget(1, args.threads))  # CAMP-THREADS; the evaluation's hosts inherit it
    env = make_env(args.scenario, args.seed, args.env_steps, args.max_cycles)
    agents = len(env.group_map[GROUP])
    actor_net = TensorDictModule(actor_network(), in_keys=[OBS], out_keys=[(GROUP, "logits")])
    actor = ProbabilisticActor(actor_net, in_keys={"logits": (GROUP, "logits"), "mask": (GROUP, "action_mask")},
                               out_keys=[env.action_key], distribution_class=MaskedCategorical, return_log_prob=True,
                               log_prob_key=(GROUP, "sample_log_prob"))
    critic = ValueOperator(nn.Sequential(nn.LayerNorm(1566), nn.Linear(1566, 256), nn.Tanh(), nn.Linear(256, 1)),
                           in_keys=[OBS], out_keys=[(GROUP, "state_value")])
    collector = SyncDataCollector(env, actor, frames_per_batch=args.rollout, total_frames=args.env_steps,
                                  device="cpu")
    loss = ClipPPOLoss(actor, critic, clip_epsilon=0.10, entropy_coeff=0.01, normalize_advantage=True)
    loss.set_keys(reward=env.reward_key, action=env.action_key, sample_log_prob=(GROUP, "sample_log_prob"),
                  value=(GROUP, "state_value"), done=(GROUP, "done"), terminated=(GROUP, "terminated"))
    loss.make_value_estimator(ValueEstimators.GAE, gamma=0.99, lmbda=0.95)
    optim = torch.optim.AdamW(loss.parameters(), lr=3e-4, eps=1e-5)
    buffer = ReplayBuffer(storage=LazyTensorStorage(args.rollout), sampler=SamplerWithoutReplacement(),
                          batch_size=max(1, args.rollout // 4))
    started = time.perf_counter()
    steps = 0
    for batch in collector:
        with torch.no_grad():
            loss.value_estimator(batch, params=loss.critic_network_params, target_params=loss.target_critic_network_params)
        buffer.extend(batch.reshape(-1))
        for _ in range(4):  # epochs
            for _ in range(4):  # minibatches
                out = loss(buffer.sample())
                total = out["loss_objective"] + out["loss_critic"] + out["loss_entropy"]
                optim.zero_grad()
                total.backward()
                nn.utils.clip_grad_norm_(loss.parameters(), 0.5)
                optim.step()
        steps += batch.numel()
    seconds = time.perf_counter() - started
    collector.shutdown()
    args.out.mkdir(parents=True, exist_ok=True)
    torch.save(actor_net.module.state_dict(), args.out / "actor.pt")
    return {"env_steps": steps, "agents": agents, "agent_samples": steps * agents, "train_seconds": round(seconds, 1),
            "env_steps_per_s": round(steps / seconds, 1), "samples_per_s": round(steps * agents / seconds, 1)}


def evaluate(args: argparse.Namespace) -> dict:
    return recipe_common.evaluate(args, HERE / "recipe_torchrl_policy.py", "torchrl-ippo",
                                  {"AGSPEC_TORCHRL_ACTOR": str(args.out / "actor.pt")})


if __name__ == "__main__":
    recipe_common.main(recipe_common.parser(__doc__.splitlines()[0], "runs/torchrl"), train, evaluate)
