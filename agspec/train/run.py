"""One training run, start to finish or resumed (spec/16-training.md, T-RUN-DIR, T-RESUME).

The loop is the curriculum's (T-CURRICULUM): for each realization block in order, every copy
starts an episode of the block's realization, and the learner takes the block's steps in chunks
(one PPO update, or up to the next record row for QMIX).  Record rows, checkpoints, the policy file
and validation are written between chunks, never inside one, so a run cut anywhere resumes from its
last checkpoint and reaches the same result as a run never cut (T-RESUME).
"""

from __future__ import annotations

import platform
import time
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np
import torch

import agspec
from agspec import threads
from agspec.checkpoint import rundir
from agspec.checkpoint.files import load_checkpoint, save_checkpoint, save_policy
from agspec.formats.digest import file_sha256
from agspec.train import config as cfg
from agspec.train import acting, curriculum
from agspec.train.record import RECORD_SCHEMA, Record, episode_means
from agspec.train.rollout import EpisodeStats, make_vector, start_block, vector_mode

Progress = Callable[[Mapping[str, Any]], None]


def streams(seed: int, device: torch.device) -> tuple[torch.Generator, torch.Generator, np.random.Generator]:
    """T-DETERMINISM: three independent streams from the run's seed: weight initialization (CPU),
    the learner's sampling (on the device) and NumPy's (QMIX exploration and replay)."""
    a, b, c = np.random.SeedSequence(seed).generate_state(3, dtype=np.uint64)
    init = torch.Generator().manual_seed(int(a) & (2**63 - 1))
    gen = torch.Generator(device=device).manual_seed(int(b) & (2**63 - 1))
    return init, gen, np.random.default_rng(int(c))


def versions() -> dict[str, Any]:
    import gymnasium
    import pettingzoo

    return {"agspec": agspec.__version__, "torch": torch.__version__, "numpy": np.__version__,
            "gymnasium": gymnasium.__version__, "pettingzoo": pettingzoo.__version__,
            "python": platform.python_version(), "platform": platform.platform(), "threads": torch.get_num_threads()}


def _checked(key: str, name: str) -> torch.device:
    try:
        device = torch.device(name)
    except RuntimeError as exc:
        raise cfg.ConfigError(f"{key} {name!r}: {exc}") from None
    if device.type == "cuda" and not torch.cuda.is_available():
        raise cfg.ConfigError(f"{key} {name!r}: this torch has no CUDA device (torch {torch.__version__})")
    return device


def _device(config: Mapping[str, Any]) -> torch.device:
    return _checked("runtime.device", config["runtime"]["device"])


def _rollout_device(config: Mapping[str, Any]) -> torch.device | None:
    """RES-ROLLOUT-DEVICE: where the rollout's copy lives, or None for the learner's own networks."""
    name = config["runtime"]["rollout_device"]
    if name != acting.LEARNER:
        _checked("runtime.rollout_device", name)
    return acting.rollout_device(config)


def _learner(config: Mapping[str, Any], n_agents: int, state_dim: int, device: torch.device,
             rollout: torch.device | None = None) -> Any:
    init, gen, rng = streams(config["seed"], device)
    if config["algorithm"] == "qmix":
        from agspec.train.qmix import QMIXLearner

        return QMIXLearner(config, n_agents, state_dim, device, init, gen, rng, rollout)
    from agspec.train.ppo import PPOLearner

    rollout_gen = acting.rollout_stream(config["seed"], gen, device, rollout)
    return PPOLearner(config, n_agents, state_dim, device, init, gen, rollout, rollout_gen)


def _dims(instance: Mapping[str, Any]) -> tuple[int, int]:
    from agspec.marl.parallel import AssemblyGridParallelEnv

    env = AssemblyGridParallelEnv(dict(instance))
    return len(env.possible_agents), int(env.state_space.shape[0])


class Run:
    """The mutable progress of one run; everything in ``position`` goes into the checkpoint."""

    def __init__(self, config: dict[str, Any], out: Path, progress: Progress | None):
        self.config, self.out, self.notify = config, out, progress or (lambda _row: None)
        self.digest = cfg.digest(config)
        self.blocks = curriculum.plan(config)
        self.instances = curriculum.training_instances(config, self.blocks)
        self.validation = curriculum.suite_instances(config, list(config["validation"]["indices"]))
        self.record = Record(out / rundir.RECORD)
        self.device = _device(config)
        n_agents, state_dim = _dims(self.instances[0])
        for inst in self.instances[1:]:
            if _dims(inst) != (n_agents, state_dim):  # the scenario fixes both (T-CURRICULUM)
                raise cfg.ConfigError("the training realizations differ in agents or state size")
        self.rollout = _rollout_device(config)
        self.learner = _learner(config, n_agents, state_dim, self.device, self.rollout)
        self.position: dict[str, Any] = {"block": 0, "block_step": 0, "steps": 0, "updates": 0, "row_steps": 0,
                                         "checkpoint_steps": 0, "pending": [], "diagnostics": {},
                                         "validation": None, "resumed": 0}
        self.started = time.perf_counter()
        self.elapsed_before = 0.0

    # ------------------------------------------------------------------ bookkeeping

    def elapsed(self) -> float:
        return round(self.elapsed_before + time.perf_counter() - self.started, 3)

    def summary(self, status: str) -> dict[str, Any]:
        c = self.config
        out = {"schema": rundir.RUN_SCHEMA, "status": status, "algorithm": c["algorithm"], "scenario": c["scenario"],
               "seed": c["seed"], "config_sha256": self.digest, "budget": c["budget"]["env_steps"],
               "steps": self.position["steps"], "updates": self.position["updates"],
               "realizations": [curriculum.describe(b, i) for b, i in zip(self.blocks, self.instances)],
               "device": str(self.device), "rollout_device": acting.describe(self.device, self.rollout),
               "runtime": dict(c["runtime"]), "versions": versions(), "resumed": self.position["resumed"],
               "wall_time_s": self.elapsed(), "validation": self.position["validation"], "policy": None}
        if status == "complete":
            out["policy"] = {"path": rundir.POLICY, "sha256": file_sha256(self.out / rundir.POLICY)}
        return out

    def write_summary(self, status: str) -> dict[str, Any]:
        data = self.summary(status)
        rundir.write_json_atomic(self.out / rundir.SUMMARY, data)
        return data

    def checkpoint(self) -> None:
        """T-RESUME: the QMIX replay goes to a file named by the step count first, then the checkpoint that
        names it replaces the old one, then older replays go: a cut at any point leaves a matching pair."""
        pos = self.position
        pos["checkpoint_steps"] = pos["steps"]
        replay = None
        if self.config["algorithm"] == "qmix":
            replay = rundir.replay_name(pos["steps"])
            self.learner.replay.save(self.out / replay)
        save_checkpoint(self.out / rundir.CHECKPOINT, {
            "config_sha256": self.digest, "position": dict(pos), "learner": self.learner.state_dict(),
            "record_bytes": self.record.size(), "elapsed_s": self.elapsed(), "replay": replay})
        for old in self.out.glob(rundir.REPLAY_GLOB):
            if old.name != replay:
                old.unlink()

    def restore(self) -> None:
        data = load_checkpoint(self.out / rundir.CHECKPOINT)
        if data.get("config_sha256") != self.digest:
            raise rundir.RunDirError(f"{self.out / rundir.CHECKPOINT} belongs to another configuration")
        self.learner.load_state_dict(data["learner"])
        if self.config["algorithm"] == "qmix":
            from agspec.train.qmix import Replay

            self.learner.replay = Replay.load(self.out / data["replay"])
        self.position = dict(data["position"])
        self.position["resumed"] += 1
        self.record.truncate(int(data["record_bytes"]))
        self.elapsed_before = float(data["elapsed_s"])

    def row(self, episodes: EpisodeStats, final_of_block: bool = False) -> None:
        """T-RECORD: a progress row with the episodes finished since the previous one."""
        pos = self.position
        pos["pending"] = pos["pending"] + episodes.drain()
        due = pos["steps"] // self.config["record"]["every_steps"] > pos["row_steps"] // self.config["record"]["every_steps"]
        if not (due or final_of_block) or pos["row_steps"] == pos["steps"]:
            return
        row = {"kind": "progress", "steps": pos["steps"], "block": self.blocks[min(pos["block"], len(self.blocks) - 1)].block,
               "updates": pos["updates"], **episode_means(pos["pending"]), **pos["diagnostics"],
               "elapsed_s": self.elapsed()}
        self.record.write(row)
        pos["pending"], pos["row_steps"] = [], pos["steps"]
        self.notify({"phase": "train", "total": self.config["budget"]["env_steps"], **row})

    def validate(self, phase: str) -> None:
        """T-VALIDATION: the current policy, greedily (and sampled, if asked), on the validation indices,
        through the evaluation's own episode runner."""
        save_policy(self.out / rundir.POLICY, self.config, self.digest, self.learner.policy_net(), self.position["steps"])
        if not self.validation:
            return
        from agspec.checkpoint.policy import SAMPLE_SUFFIX
        from agspec.policy.contract import PolicySpec
        from agspec.policy.episode import run_episode

        for action in self.config["validation"]["actions"]:
            target = str(self.out / rundir.POLICY) + (SAMPLE_SUFFIX if action == "sample" else "")
            spec = PolicySpec("checkpoint", target, f"validation-{action}")
            delivered, completion = [], []
            for instance in self.validation:
                metrics = run_episode(instance, spec).metrics
                delivered.append(int(metrics["delivered"]))
                completion.append(float(metrics["completion_rate"]))
            row = {"kind": "validation", "phase": phase, "action": action, "steps": self.position["steps"],
                   "indices": list(self.config["validation"]["indices"]), "delivered": delivered,
                   "delivered_mean": float(np.mean(delivered)), "completion_rate_mean": float(np.mean(completion)),
                   "elapsed_s": self.elapsed()}
            self.record.write(row)
            if action == "greedy" or self.position["validation"] is None or self.position["validation"]["phase"] != phase:
                self.position["validation"] = {k: row[k] for k in ("phase", "action", "steps", "indices", "delivered",
                                                                   "delivered_mean", "completion_rate_mean")}
            self.notify({"phase": "validation", "total": self.config["budget"]["env_steps"], **row})

    # ------------------------------------------------------------------ the loop

    def chunk(self, vec: Any, obs: dict[str, np.ndarray], block: curriculum.Block, episodes: EpisodeStats
              ) -> dict[str, np.ndarray]:
        """One PPO update, or QMIX steps up to the next record row or the block's end."""
        pos, copies = self.position, self.config["rollout"]["envs"]
        left = block.steps - pos["block_step"]
        if self.config["algorithm"] == "qmix":
            every = self.config["record"]["every_steps"]
            n = min(left, every - pos["steps"] % every)
            n = max(copies, n - n % copies)
            obs = self.learner.run_ticks(vec, obs, n // copies, episodes)
            pos["updates"] = self.learner.updates
            pos["diagnostics"] = self.learner.stats()
        else:
            n = min(self.config["ppo"]["steps_per_update"], left)
            batch, obs = self.learner.collect(vec, obs, n // copies, episodes)
            pos["diagnostics"] = self.learner.update(batch, pos["steps"] + n)
            pos["updates"] += 1
        pos["steps"] += n
        pos["block_step"] += n
        return obs

    def at_episode_start(self, episodes: EpisodeStats) -> bool:
        return all(ep["length"] == 0 for ep in episodes.open)

    def train(self, resume: bool) -> dict[str, Any]:
        c = self.config
        if resume:
            self.restore()
        else:
            self.record.path.unlink(missing_ok=True)  # a run that never reached its first checkpoint starts over
            self.record.write({"kind": "header", "schema": RECORD_SCHEMA, "algorithm": c["algorithm"],
                               "scenario": c["scenario"], "seed": c["seed"], "config_sha256": self.digest,
                               "budget": c["budget"]["env_steps"], "agspec_version": agspec.__version__})
            if c["validation"]["initial"]:
                self.validate("initial")
            else:
                save_policy(self.out / rundir.POLICY, c, self.digest, self.learner.policy_net(), 0)
            self.checkpoint()
        self.write_summary("running")
        pos = self.position
        every_ckpt = c["checkpoint"]["every_steps"]
        vec = make_vector(self.instances[pos["block"] if pos["block"] < len(self.blocks) else 0], c["rollout"]["envs"],
                          c["reward"]["support_credit"], c["algorithm"] != "ippo", vector_mode(c))
        try:
            while pos["block"] < len(self.blocks):
                block = self.blocks[pos["block"]]
                episodes = EpisodeStats(c["rollout"]["envs"])
                obs = start_block(vec, self.instances[block.block])
                while pos["block_step"] < block.steps:
                    obs = self.chunk(vec, obs, block, episodes)
                    self.row(episodes, final_of_block=pos["block_step"] >= block.steps)
                    if (every_ckpt and pos["block_step"] < block.steps and self.at_episode_start(episodes)
                            and pos["steps"] - pos["checkpoint_steps"] >= every_ckpt):
                        self.checkpoint()  # T-RESUME: every copy is at an episode start, so no env state is lost
                pos["block"] += 1
                pos["block_step"] = 0
                if c["validation"]["every_block"] or pos["block"] == len(self.blocks):
                    self.validate(f"block-{block.block}")
                else:
                    save_policy(self.out / rundir.POLICY, c, self.digest, self.learner.policy_net(), pos["steps"])
                self.checkpoint()
                self.write_summary("running")
        finally:
            vec.close()
        return self.write_summary("complete")


def run(config: dict[str, Any], out_dir: Any, *, resume: bool = False, progress: Progress | None = None
        ) -> dict[str, Any]:
    """Train one run into ``out_dir`` (see :func:`agspec.train.api.train`)."""
    cfg.check(config)
    out = Path(out_dir)
    rundir.refuse_foreign(out)  # before the lock file is made: never write into a directory that is not a run
    with rundir.exclusive(out):
        if resume and rundir.is_complete(out):
            rundir.prepare(out, config, resume=True)  # still refuse another configuration
            return rundir.read_summary(out)
        has_checkpoint = rundir.prepare(out, config, resume)
        if not (out / rundir.CONFIG).exists():
            rundir.write_json_atomic(out / rundir.CONFIG, config)
        # CAMP-THREADS: the process's intra-op threads, runtime.threads or the budget; run.json's versions record them
        threads.apply(threads.budget(1, config["runtime"]["threads"] or threads.inherited()))
        return Run(config, out, progress).train(resume=has_checkpoint)


__all__ = ["run", "streams", "versions"]
