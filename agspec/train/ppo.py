"""IPPO and MAPPO as tab:marlconfig gives them (spec/16-training.md, T-PPO-*).

Both share the actor (T-ACTOR) and the update; they differ only in what the critic reads: the
agent's observation (IPPO) or the global state concatenated with it (MAPPO) (T-CRITIC).  A rollout
is ``ppo.steps_per_update`` environment steps spread over the copies (T-ENV-STEP, T-COPIES); every
agent of every copy is one trajectory for GAE (T-GAE).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np
import torch
from torch.nn import functional as F

from agspec.checkpoint import nets
from agspec.train import acting
from agspec.train.rollout import EpisodeStats, restart, step_info


@dataclass
class Rollout:
    """One update's samples, [T ticks, E copies, R agents] (state: [T, E, S])."""

    obs: torch.Tensor
    mask: torch.Tensor
    state: torch.Tensor | None
    actions: torch.Tensor
    logp: torch.Tensor
    values: torch.Tensor
    rewards: torch.Tensor
    dones: torch.Tensor  # [T, E]: the episode of that copy ended at this tick (terminated or truncated)
    last_values: torch.Tensor  # [E, R]: V of the state after the last tick (T-GAE bootstrap)


def entropy_coefficient(config: Mapping[str, Any], steps_done: int) -> float:
    """T-ENTROPY-SCHEDULE: linear from start to end over the budget, at the steps done after this rollout."""
    e = config["entropy"]
    fraction = steps_done / max(1, config["budget"]["env_steps"])
    return e["start"] + fraction * (e["end"] - e["start"])


def actor_frozen(config: Mapping[str, Any], steps_done: int) -> bool:
    """T-WARMUP: the actor learns only once more than ``warmup.critic_steps`` steps have been collected."""
    return steps_done <= config["warmup"]["critic_steps"]


def gae(rewards: torch.Tensor, values: torch.Tensor, dones: torch.Tensor, last_values: torch.Tensor,
        gamma: float, lam: float) -> tuple[torch.Tensor, torch.Tensor]:
    """T-GAE: advantages and returns over [T, …] trajectories; a done tick neither bootstraps nor
    carries the advantage across (RES-TRUNCATION-TERMINAL)."""
    steps = rewards.shape[0]
    adv = torch.zeros_like(rewards)
    running = torch.zeros_like(last_values)
    next_value = last_values
    for t in range(steps - 1, -1, -1):
        live = 1.0 - dones[t].to(rewards.dtype)
        while live.dim() < rewards[t].dim():
            live = live.unsqueeze(-1)
        delta = rewards[t] + gamma * next_value * live - values[t]
        running = delta + gamma * lam * live * running
        adv[t] = running
        next_value = values[t]
    return adv, adv + values


def clipped_surrogate(ratio: torch.Tensor, adv: torch.Tensor, clip: float) -> torch.Tensor:
    """T-PPO-UPDATE: mean(min(ρA, clip(ρ, 1 − ε, 1 + ε)A)), to be maximized."""
    return torch.minimum(ratio * adv, ratio.clamp(1 - clip, 1 + clip) * adv).mean()


def clipped_value_loss(value: torch.Tensor, old: torch.Tensor, returns: torch.Tensor, clip: float,
                       kind: str) -> torch.Tensor:
    """T-PPO-UPDATE: mean(max(ℓ(V, R), ℓ(V_old + clip(V − V_old, ±c), R))), ℓ Huber or squared (RES-VALUE-LOSS)."""
    loss = F.smooth_l1_loss if kind == "huber" else F.mse_loss
    clipped = old + (value - old).clamp(-clip, clip)
    return torch.maximum(loss(value, returns, reduction="none"), loss(clipped, returns, reduction="none")).mean()


def explained_variance(pred: torch.Tensor, target: torch.Tensor) -> float:
    """1 − Var(target − pred) / Var(target); 0 when the target does not vary (T-RECORD)."""
    var = torch.var(target)
    if float(var) <= 1e-8:
        return 0.0
    return float(1.0 - torch.var(target - pred) / var)


class PPOLearner:
    """The actor, the critic, their AdamW optimizers and the run's random stream (T-ADAMW, T-DETERMINISM);
    the rollout acts on ``rollout`` copies of both when given, sampling from ``rollout_gen``
    (RES-ROLLOUT-DEVICE)."""

    def __init__(self, config: Mapping[str, Any], n_agents: int, state_dim: int, device: torch.device,
                 init: torch.Generator, gen: torch.Generator, rollout: torch.device | None = None,
                 rollout_gen: torch.Generator | None = None):
        self.config, self.device, self.gen = config, device, gen
        self.central = config["critic"]["input"] == "state+observation"
        a, c = config["actor"], config["critic"]
        self.actor = nets.SharedActor(a["width"], a["blocks"], init).to(device)
        critic_in = state_dim + nets.OBS_DIM if self.central else nets.OBS_DIM
        self.critic = nets.ValueNet(critic_in, c["width"], c["blocks"], init).to(device)
        opt = config["optimizer"]
        kw = {"eps": opt["eps"], "weight_decay": opt["weight_decay"], "betas": tuple(opt["betas"])}
        self.actor_opt = torch.optim.AdamW(self.actor.parameters(), lr=config["lr"]["actor"], **kw)
        self.critic_opt = torch.optim.AdamW(self.critic.parameters(), lr=config["lr"]["critic"], **kw)
        self.n_agents = n_agents
        # RES-ROLLOUT-DEVICE: the per-tick forward passes on one agent set run where that batch is fastest
        self.rollout_device = rollout or device
        self.acting_actor, self.acting_critic = acting.copy_to(self.actor, rollout), acting.copy_to(self.critic, rollout)
        self.rollout_gen = rollout_gen if rollout_gen is not None else gen

    def sync_rollout(self) -> None:
        """RES-ROLLOUT-DEVICE: the rollout's copies take the learner's weights; called after every update
        and on resume, so that no action is drawn from stale weights."""
        acting.sync(self.acting_actor, self.actor)
        acting.sync(self.acting_critic, self.critic)

    # ------------------------------------------------------------------ acting

    def critic_input(self, obs: torch.Tensor, state: torch.Tensor | None) -> torch.Tensor:
        """IPPO: the observation; MAPPO: [global state, observation] per agent (T-CRITIC)."""
        if not self.central:
            return obs
        assert state is not None
        if state.dim() < obs.dim():  # one state per copy, shared by its agents
            state = state.unsqueeze(-2).expand(*obs.shape[:-1], state.shape[-1])
        return torch.cat((state, obs), dim=-1)

    @torch.no_grad()
    def act(self, obs: torch.Tensor, mask: torch.Tensor, state: torch.Tensor | None
            ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """Sample every agent's action from its masked policy (T-MASK); [E, R] actions, log-probs, values."""
        logp_all = F.log_softmax(nets.masked_logits(self.acting_actor(obs), mask), dim=-1)
        flat = logp_all.reshape(-1, logp_all.shape[-1])
        actions = torch.multinomial(flat.exp(), 1, generator=self.rollout_gen).squeeze(-1)
        logp = flat.gather(-1, actions.unsqueeze(-1)).squeeze(-1)
        values = self.acting_critic(self.critic_input(obs, state))
        shape = obs.shape[:-1]
        return actions.view(shape), logp.view(shape), values

    def collect(self, vec: Any, obs: dict[str, np.ndarray], ticks: int, episodes: EpisodeStats
                ) -> tuple[Rollout, dict[str, np.ndarray]]:
        """``ticks`` joint steps of every copy (T-ENV-STEP), resetting copies whose episode ended; the samples
        are gathered on the rollout's device and moved to the learner's once (RES-ROLLOUT-DEVICE)."""
        dev = self.rollout_device
        buf: dict[str, list[torch.Tensor]] = {k: [] for k in ("obs", "mask", "state", "actions", "logp", "values",
                                                              "rewards", "dones")}
        for _ in range(ticks):
            o = torch.from_numpy(obs["obs"]).to(dev)
            m = torch.from_numpy(obs["mask"]).to(dev)
            s = torch.from_numpy(obs["state"]).to(dev) if self.central else None
            actions, logp, values = self.act(o, m, s)
            nxt, _team, term, trunc, infos = vec.step(actions.cpu().numpy())
            ended = np.logical_or(term, trunc)
            for key, value in (("obs", o), ("mask", m), ("state", s), ("actions", actions), ("logp", logp),
                               ("values", values)):
                buf[key].append(value)
            buf["rewards"].append(torch.from_numpy(step_info(infos, "rewards").astype(np.float32)).to(dev))
            buf["dones"].append(torch.from_numpy(ended.copy()).to(dev))
            episodes.add(infos, ended)
            obs = restart(vec, nxt, ended)
        with torch.no_grad():
            o = torch.from_numpy(obs["obs"]).to(dev)
            s = torch.from_numpy(obs["state"]).to(dev) if self.central else None
            last = self.acting_critic(self.critic_input(o, s)).to(self.device)
        stack = {k: torch.stack(v).to(self.device) for k, v in buf.items() if k != "state"}
        state = torch.stack(buf["state"]).to(self.device) if self.central else None
        return Rollout(stack["obs"], stack["mask"], state, stack["actions"], stack["logp"], stack["values"],
                       stack["rewards"], stack["dones"], last), obs

    # ------------------------------------------------------------------ learning

    def update(self, batch: Rollout, steps_done: int) -> dict[str, Any]:
        """T-PPO-UPDATE: epochs of shuffled minibatches; clipped actor and value objectives; KL stop."""
        cfg, p = self.config, self.config["ppo"]
        adv, returns = gae(batch.rewards, batch.values, batch.dones, batch.last_values, cfg["gamma"], p["gae_lambda"])
        n_agents = batch.obs.shape[2]
        obs = batch.obs.reshape(-1, batch.obs.shape[-1])
        mask = batch.mask.reshape(-1, batch.mask.shape[-1])
        state = batch.state.reshape(-1, batch.state.shape[-1]) if batch.state is not None else None
        actions, old_logp = batch.actions.reshape(-1), batch.logp.reshape(-1)
        old_values, returns, adv = batch.values.reshape(-1), returns.reshape(-1), adv.reshape(-1)
        adv_mean, adv_std = adv.mean(), adv.std()
        if p["normalize_advantages"]:  # RES-ADVANTAGE-NORM
            adv = (adv - adv_mean) / adv_std if float(adv_std) > 1e-4 else adv - adv_mean
        learn_actor = not actor_frozen(cfg, steps_done)
        coef = entropy_coefficient(cfg, steps_done)
        limit = p["kl_stop_factor"] * p["target_kl"]
        sums: dict[str, list[float]] = {k: [] for k in ("actor_loss", "critic_loss", "entropy", "approx_kl",
                                                        "clip_fraction")}
        stopped = False
        count, seen = obs.shape[0], 0
        for _epoch in range(p["epochs"]):
            order = torch.randperm(count, generator=self.gen, device=self.device)
            for idx in order.split(p["minibatch"]):
                logp_all = F.log_softmax(nets.masked_logits(self.actor(obs[idx]), mask[idx]), dim=-1)
                logp = logp_all.gather(-1, actions[idx].unsqueeze(-1)).squeeze(-1)
                entropy = -(logp_all.exp() * logp_all).sum(-1).mean()
                log_ratio = logp - old_logp[idx]
                ratio = log_ratio.exp()
                actor_loss = -clipped_surrogate(ratio, adv[idx], p["clip"]) - coef * entropy
                approx_kl = ((ratio - 1.0) - log_ratio).mean()
                if learn_actor:
                    self.actor_opt.zero_grad()
                    actor_loss.backward()
                    torch.nn.utils.clip_grad_norm_(self.actor.parameters(), p["max_grad_norm"])
                    self.actor_opt.step()
                te = idx // n_agents
                value = self.critic(self.critic_input(obs[idx], state[te] if state is not None else None))
                critic_loss = clipped_value_loss(value, old_values[idx], returns[idx], p["value_clip"], p["value_loss"])
                self.critic_opt.zero_grad()
                critic_loss.backward()
                torch.nn.utils.clip_grad_norm_(self.critic.parameters(), p["max_grad_norm"])
                self.critic_opt.step()
                seen += int(idx.numel())
                for key, value_ in (("actor_loss", actor_loss), ("critic_loss", critic_loss), ("entropy", entropy),
                                    ("approx_kl", approx_kl),
                                    ("clip_fraction", ((ratio - 1.0).abs() > p["clip"]).float().mean())):
                    sums[key].append(float(value_.detach()))
                if learn_actor and float(approx_kl.detach()) > limit:  # RES-KL-STOP: ends the whole update
                    stopped = True
                    break
            if stopped:
                break
        self.sync_rollout()  # RES-ROLLOUT-DEVICE: the next rollout acts with the weights just learned
        with torch.no_grad():
            predicted = torch.cat([
                self.critic(self.critic_input(obs[idx], state[idx // n_agents] if state is not None else None))
                for idx in torch.arange(count, device=self.device).split(p["minibatch"])])
        return {**{k: float(np.mean(v)) for k, v in sums.items()},
                "explained_variance": explained_variance(predicted, returns),
                "advantage_mean": float(adv_mean), "advantage_std": float(adv_std),
                "entropy_coefficient": coef, "actor_updated": learn_actor, "kl_early_stop": stopped,
                "minibatches": len(sums["entropy"]), "samples": seen}

    # ------------------------------------------------------------------ checkpoints

    def state_dict(self) -> dict[str, Any]:
        return {"actor": self.actor.state_dict(), "critic": self.critic.state_dict(),
                "actor_opt": self.actor_opt.state_dict(), "critic_opt": self.critic_opt.state_dict(),
                "gen": self.gen.get_state(),
                # RES-ROLLOUT-DEVICE: a rollout stream of its own is part of the resumable state (T-RESUME)
                **({"rollout_gen": self.rollout_gen.get_state()} if self.rollout_gen is not self.gen else {})}

    def load_state_dict(self, data: Mapping[str, Any]) -> None:
        self.actor.load_state_dict(data["actor"])
        self.critic.load_state_dict(data["critic"])
        self.actor_opt.load_state_dict(data["actor_opt"])
        self.critic_opt.load_state_dict(data["critic_opt"])
        self.gen.set_state(data["gen"])
        if self.rollout_gen is not self.gen and "rollout_gen" in data:
            self.rollout_gen.set_state(data["rollout_gen"])
        self.sync_rollout()

    def policy_net(self) -> torch.nn.Module:
        return self.actor
