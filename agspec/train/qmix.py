"""QMIX as tab:marlconfig gives it (spec/16-training.md, T-QMIX-*).

A shared Q network (T-QNET) acts ε-greedily on each agent's observation; a monotonic mixer over the
global state (T-MIXER) combines the chosen agents' values into Q_tot for a single-network TD target
with mean-squared error (T-QMIX-UPDATE).  The replay holds joint transitions (every agent's
observation, mask and action, the team reward, the global state); observations are ~1 % non-zero,
so the replay stores them sparse and loses nothing (T-REPLAY).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping

import numpy as np
import torch
from torch.nn import functional as F

from agspec.checkpoint import nets
from agspec.formats import output
from agspec.train import acting
from agspec.train.rollout import EpisodeStats, restart, step_info


def epsilon(config: Mapping[str, Any], step: int) -> float:
    """T-QMIX-EXPLORATION: ε of the ``step``-th environment step (1-based), linear from start to end over
    the first ``decay_fraction`` of the budget, then held."""
    e = config["epsilon"]
    decay = max(1, int(config["budget"]["env_steps"] * e["decay_fraction"]))
    return max(e["end"], e["start"] - (e["start"] - e["end"]) * (step - 1) / decay)


def _pack(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    flat = x.reshape(-1)
    idx = np.flatnonzero(flat).astype(np.int32)
    return idx, flat[idx].astype(np.float32)


class Replay:
    """T-REPLAY: a uniform FIFO replay of joint transitions; arrays stored sparse (indices and values),
    masks as bits.  Sampling returns dense arrays; nothing is rounded."""

    FIELDS = ("obs_i", "obs_v", "mask", "actions", "reward", "next_i", "next_v", "next_mask", "done",
              "state_i", "state_v", "next_state_i", "next_state_v")

    def __init__(self, capacity: int, n_agents: int, obs_dim: int, n_actions: int, state_dim: int):
        self.capacity, self.n_agents, self.obs_dim, self.n_actions, self.state_dim = (
            capacity, n_agents, obs_dim, n_actions, state_dim)
        self.slots: list[tuple] = []
        self.position = 0  # the slot the next transition overwrites once full

    def __len__(self) -> int:
        return len(self.slots)

    def add(self, obs, mask, actions, reward, next_obs, next_mask, done, state, next_state) -> None:
        entry = (*_pack(obs), np.packbits(mask.astype(bool), axis=-1), actions.astype(np.int16), float(reward),
                 *_pack(next_obs), np.packbits(next_mask.astype(bool), axis=-1), bool(done), *_pack(state),
                 *_pack(next_state))
        if len(self.slots) < self.capacity:
            self.slots.append(entry)
        else:
            self.slots[self.position] = entry
        self.position = (self.position + 1) % self.capacity

    def _dense(self, pairs: list[tuple[np.ndarray, np.ndarray]], shape: tuple[int, ...]) -> np.ndarray:
        out = np.zeros((len(pairs), int(np.prod(shape))), dtype=np.float32)
        for row, (idx, val) in enumerate(pairs):
            out[row, idx] = val
        return out.reshape((len(pairs), *shape))

    def _bits(self, packed: list[np.ndarray]) -> np.ndarray:
        return np.unpackbits(np.stack(packed), axis=-1, count=self.n_actions).astype(np.int8)

    def sample(self, batch: int, rng: np.random.Generator) -> dict[str, np.ndarray]:
        """``batch`` distinct transitions drawn uniformly (T-QMIX-UPDATE)."""
        picks = [self.slots[i] for i in rng.choice(len(self.slots), size=min(batch, len(self.slots)), replace=False)]
        agents = (self.n_agents, self.obs_dim)
        return {
            "obs": self._dense([(s[0], s[1]) for s in picks], agents),
            "mask": self._bits([s[2] for s in picks]),
            "actions": np.stack([s[3] for s in picks]).astype(np.int64),
            "reward": np.array([s[4] for s in picks], dtype=np.float32),
            "next_obs": self._dense([(s[5], s[6]) for s in picks], agents),
            "next_mask": self._bits([s[7] for s in picks]),
            "done": np.array([s[8] for s in picks], dtype=np.float32),
            "state": self._dense([(s[9], s[10]) for s in picks], (self.state_dim,)),
            "next_state": self._dense([(s[11], s[12]) for s in picks], (self.state_dim,)),
        }

    def save(self, path: Path) -> None:
        """The whole replay as one ``.npz`` (written through a temporary file)."""
        arrays: dict[str, np.ndarray] = {"position": np.array([self.position]),
                                         "shape": np.array([self.capacity, self.n_agents, self.obs_dim,
                                                            self.n_actions, self.state_dim])}
        for k, name in enumerate(self.FIELDS):
            column = [s[k] for s in self.slots]
            if isinstance(column[0] if column else None, np.ndarray):
                arrays[name + "_len"] = np.array([c.shape[0] for c in column], dtype=np.int64)
                arrays[name] = np.concatenate(column) if column else np.zeros(0)
            else:
                arrays[name] = np.array(column)
        with output.atomic_path(path) as tmp:  # F-OUTPUT-FAILURES (the suffix stays .npz)
            np.savez(tmp, **arrays)

    @classmethod
    def load(cls, path: Path) -> "Replay":
        with np.load(path) as data:
            replay = cls(*(int(v) for v in data["shape"]))
            replay.position = int(data["position"][0])
            columns = []
            for name in cls.FIELDS:
                if name + "_len" in data:
                    bounds = np.cumsum(data[name + "_len"])[:-1]
                    columns.append(np.split(data[name], bounds) if len(data[name + "_len"]) else [])
                else:
                    columns.append(list(data[name]))
        n = len(columns[0])
        for k in range(n):
            row = [c[k] for c in columns]
            row[4], row[8] = float(row[4]), bool(row[8])
            replay.slots.append(tuple(row))
        return replay


class QMIXLearner:
    """The Q network, the mixer, their targets, one AdamW optimizer, the run's random streams; the rollout
    acts on a ``rollout`` copy of the Q network when given (RES-ROLLOUT-DEVICE)."""

    def __init__(self, config: Mapping[str, Any], n_agents: int, state_dim: int, device: torch.device,
                 init: torch.Generator, gen: torch.Generator, rng: np.random.Generator,
                 rollout: torch.device | None = None):
        self.config, self.device, self.gen, self.rng = config, device, gen, rng
        q, m = config["qnet"], config["mixer"]
        self.qnet = nets.QNet(q["hidden"], init).to(device)
        self.mixer = nets.QMixer(n_agents, state_dim, m["width"], m["hyper_hidden"], m["hyper_layers"], init).to(device)
        self.target_qnet = nets.QNet(q["hidden"], init).to(device)
        self.target_mixer = nets.QMixer(n_agents, state_dim, m["width"], m["hyper_hidden"], m["hyper_layers"],
                                        init).to(device)
        self.sync()
        opt = config["optimizer"]
        self.opt = torch.optim.AdamW([*self.qnet.parameters(), *self.mixer.parameters()], lr=config["lr"]["q"],
                                     eps=opt["eps"], weight_decay=opt["weight_decay"], betas=tuple(opt["betas"]))
        self.replay = Replay(config["replay"]["capacity"], n_agents, nets.OBS_DIM, nets.N_ACTIONS, state_dim)
        self.step = 0  # environment steps taken (1-based once the first is taken)
        self.last: dict[str, float] = {}
        self.updates = 0
        # RES-ROLLOUT-DEVICE: ε-greedy acting needs no torch stream (its coins are NumPy's), only the weights
        self.rollout_device = rollout or device
        self.acting_qnet = acting.copy_to(self.qnet, rollout)

    def sync_rollout(self) -> None:
        """RES-ROLLOUT-DEVICE: the rollout's copy takes the learner's weights; called after every TD update
        and on resume, so that every tick acts with the weights the plain loop would use."""
        acting.sync(self.acting_qnet, self.qnet)

    def sync(self) -> None:
        """T-QMIX-UPDATE: hard target synchronisation."""
        self.target_qnet.load_state_dict(self.qnet.state_dict())
        self.target_mixer.load_state_dict(self.mixer.state_dict())

    @torch.no_grad()
    def act(self, obs: np.ndarray, mask: np.ndarray, eps: list[float]) -> np.ndarray:
        """ε-greedy per agent: with probability ε a legal action uniformly, else the masked argmax of Q
        (T-QMIX-EXPLORATION, T-EVAL-ACTION)."""
        q = self.acting_qnet(torch.from_numpy(obs).to(self.rollout_device))
        actions = nets.greedy(q, torch.from_numpy(mask).to(self.rollout_device)).cpu().numpy()
        coins = self.rng.random(actions.shape)
        for e, a in zip(*np.nonzero(coins < np.asarray(eps)[:, None])):
            legal = np.flatnonzero(mask[e, a])
            actions[e, a] = legal[self.rng.integers(len(legal))]
        return actions

    def train_step(self) -> dict[str, float]:
        """T-QMIX-UPDATE: one minibatch, single-network TD target, MSE, gradient-norm clip."""
        r = self.config["replay"]
        b = {k: torch.from_numpy(v).to(self.device) for k, v in self.replay.sample(r["batch"], self.rng).items()}
        batch, n_agents = b["actions"].shape
        q_all = self.qnet(b["obs"].reshape(batch * n_agents, -1)).view(batch, n_agents, -1)
        chosen = q_all.gather(-1, b["actions"].unsqueeze(-1)).squeeze(-1)
        q_tot = self.mixer(chosen, b["state"])
        with torch.no_grad():
            nxt = self.target_qnet(b["next_obs"].reshape(batch * n_agents, -1)).view(batch, n_agents, -1)
            best = nets.masked_logits(nxt, b["next_mask"]).max(dim=-1).values
            target = b["reward"] + self.config["gamma"] * (1.0 - b["done"]) * self.target_mixer(best, b["next_state"])
        loss = F.mse_loss(q_tot, target)
        self.opt.zero_grad()
        loss.backward()
        torch.nn.utils.clip_grad_norm_([*self.qnet.parameters(), *self.mixer.parameters()], r["max_grad_norm"])
        self.opt.step()
        self.sync_rollout()  # RES-ROLLOUT-DEVICE: the next tick acts with the weights just learned
        self.updates += 1
        return {"td_loss": float(loss.detach()), "mean_q_tot": float(q_tot.detach().mean()),
                "median_abs_q_tot": float(q_tot.detach().abs().median())}

    def run_ticks(self, vec: Any, obs: dict[str, np.ndarray], ticks: int, episodes: EpisodeStats
                  ) -> dict[str, np.ndarray]:
        """``ticks`` joint steps of every copy; each copy's transition is one environment step."""
        r, warm = self.config["replay"], self.config["warmup"]["replay_transitions"]
        copies = obs["obs"].shape[0]
        for _ in range(ticks):
            eps = [epsilon(self.config, self.step + 1 + e) for e in range(copies)]
            actions = self.act(obs["obs"], obs["mask"], eps)
            nxt, _team, term, trunc, infos = vec.step(actions)
            ended = np.logical_or(term, trunc)
            rewards = step_info(infos, "rewards")
            for e in range(copies):
                self.step += 1
                # T-REWARD: QMIX's team reward (support credit as the agents' mean) is the same for all agents
                self.replay.add(obs["obs"][e], obs["mask"][e], actions[e], rewards[e][0], nxt["obs"][e],
                                nxt["mask"][e], ended[e], obs["state"][e], nxt["state"][e])
                if len(self.replay) >= warm and self.step % r["train_every"] == 0:
                    self.last = self.train_step()
                if self.step % r["target_sync_every"] == 0:
                    self.sync()
            self.last_epsilon = eps[-1]
            episodes.add(infos, ended)
            obs = restart(vec, nxt, ended)
        return obs

    def stats(self) -> dict[str, Any]:
        return {**self.last, "epsilon": epsilon(self.config, max(self.step, 1)), "replay_size": len(self.replay),
                "updates": self.updates}

    def state_dict(self) -> dict[str, Any]:
        return {"qnet": self.qnet.state_dict(), "mixer": self.mixer.state_dict(),
                "target_qnet": self.target_qnet.state_dict(), "target_mixer": self.target_mixer.state_dict(),
                "opt": self.opt.state_dict(), "gen": self.gen.get_state(), "rng": self.rng.bit_generator.state,
                "step": self.step, "updates": self.updates, "last": dict(self.last)}

    def load_state_dict(self, data: Mapping[str, Any]) -> None:
        self.qnet.load_state_dict(data["qnet"])
        self.mixer.load_state_dict(data["mixer"])
        self.target_qnet.load_state_dict(data["target_qnet"])
        self.target_mixer.load_state_dict(data["target_mixer"])
        self.opt.load_state_dict(data["opt"])
        self.gen.set_state(data["gen"])
        self.rng.bit_generator.state = data["rng"]
        self.step, self.updates, self.last = int(data["step"]), int(data["updates"]), dict(data["last"])
        self.sync_rollout()

    def policy_net(self) -> torch.nn.Module:
        return self.qnet
