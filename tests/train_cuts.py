"""Cutting a training run anywhere and resuming it (spec/16-training.md, T-RESUME): the generator of
the "a resumed run is not the run" class, shared by tests/test_train_resume.py (bounded) and
benchmarks/fuzz_resume.py (every cut point, with and without seeded mutants)."""

from __future__ import annotations

import contextlib
import shutil
from pathlib import Path
from typing import Any, Iterator
from unittest import mock

from agspec.train.api import read_summary, resolve_config, train
from agspec.train.record import read_record, without_wall_time

ROOT = Path(__file__).resolve().parents[1]


def short_scenario(directory: Path) -> str:
    """flow-easy with a 4-tick horizon, so that 4-step updates end exactly at episode starts and the
    trainer's mid-block checkpoints happen (T-RESUME)."""
    text = (ROOT / "catalogue" / "scenarios" / "flow-easy.ag").read_text()
    text = text.replace('"../', f'"{ROOT}/catalogue/').replace("scenario flow-easy", "scenario flow-short")
    text = text.replace("horizon 400", "horizon 4").replace("suite official", "suite unofficial")
    path = directory / "flow-short.ag"
    path.write_text(text)
    return str(path)


def tiny(algorithm: str, scenario: str = "flow-easy", seed: int = 0, **extra: Any) -> dict[str, Any]:
    """A budget of a few ticks: 8 steps per block, 8-step updates, no validation unless asked."""
    overrides = {"budget.env_steps": 40, "record.every_steps": 8, "validation.indices": [], "runtime.threads": 1}
    if algorithm == "qmix":
        overrides.update({"replay.capacity": 64, "warmup.replay_transitions": 8, "replay.target_sync_every": 8})
    else:
        overrides.update({"ppo.steps_per_update": 8, "ppo.minibatch": 64, "warmup.critic_steps": 8,
                          "checkpoint.every_steps": 8})
    overrides.update(extra)
    return resolve_config(algorithm, scenario, seed, overrides)


def cut_config(algorithm: str, directory: Path) -> dict[str, Any]:
    """The fuzzed run: 4-step chunks on 4-tick episodes, a (PPO) checkpoint after each and a record row
    after every other one, so that checkpoints hold finished episodes not yet recorded."""
    extra: dict[str, Any] = {"record.every_steps": 8}
    if algorithm != "qmix":
        extra.update({"ppo.steps_per_update": 4, "checkpoint.every_steps": 4})
    return tiny(algorithm, short_scenario(directory), **extra)


class Cut(Exception):
    """Raised from the progress callback: the run stops as if killed between two chunks."""


def outcome(out: Path) -> dict[str, Any]:
    summary = read_summary(out)
    return {"policy": summary["policy"], "steps": summary["steps"], "updates": summary["updates"],
            "record": without_wall_time(read_record(out / "record.jsonl"))}


def differences(a: dict[str, Any], b: dict[str, Any]) -> list[str]:
    out = [f"{k}: {a[k]!r} != {b[k]!r}" for k in ("policy", "steps", "updates") if a[k] != b[k]]
    if a["record"] != b["record"]:
        first = next((i for i, (x, y) in enumerate(zip(a["record"], b["record"])) if x != y),
                     min(len(a["record"]), len(b["record"])))
        out.append(f"record differs from row {first} ({len(a['record'])} vs {len(b['record'])} rows)")
    return out


def cut_and_resume(config: dict[str, Any], out: Path, cut_row: int, cuts: int = 1) -> dict[str, Any]:
    """Run ``config`` into ``out``, killing it at the ``cut_row``-th progress notification (and, with
    ``cuts`` > 1, again as often after each resume), then resume it to the end."""
    shutil.rmtree(out, ignore_errors=True)
    seen = 0

    def cutter(_row: Any) -> None:
        nonlocal seen
        seen += 1
        if seen == cut_row:
            raise Cut

    resume = False
    for _ in range(cuts):
        seen = 0
        try:
            train(config, out, resume=resume, progress=cutter)
            return outcome(out)
        except Cut:
            resume = True
    train(config, out, resume=True)
    return outcome(out)


@contextlib.contextmanager
def mutant(name: str) -> Iterator[None]:
    """Seeded bugs of resumption, each the kind a trainer plausibly has (T-RESUME)."""
    from agspec.train import ppo, qmix, record, run

    if name == "sampling-stream-not-restored":
        def ppo_load(self, data):
            keep = self.gen.get_state()
            ppo_original(self, data)
            self.gen.set_state(keep)

        def qmix_load(self, data):
            keep = self.rng.bit_generator.state
            qmix_original(self, data)
            self.rng.bit_generator.state = keep

        ppo_original, qmix_original = ppo.PPOLearner.load_state_dict, qmix.QMIXLearner.load_state_dict
        with mock.patch.object(ppo.PPOLearner, "load_state_dict", ppo_load), \
                mock.patch.object(qmix.QMIXLearner, "load_state_dict", qmix_load):
            yield
    elif name == "optimizer-not-restored":
        def ppo_load(self, data):
            ppo_original(self, {**data, "actor_opt": self.actor_opt.state_dict(),
                                "critic_opt": self.critic_opt.state_dict()})

        def qmix_load(self, data):
            qmix_original(self, {**data, "opt": self.opt.state_dict()})

        ppo_original, qmix_original = ppo.PPOLearner.load_state_dict, qmix.QMIXLearner.load_state_dict
        with mock.patch.object(ppo.PPOLearner, "load_state_dict", ppo_load), \
                mock.patch.object(qmix.QMIXLearner, "load_state_dict", qmix_load):
            yield
    elif name == "record-not-cut-back":
        with mock.patch.object(record.Record, "truncate", lambda self, size: None):
            yield
    elif name == "pending-episodes-dropped":
        original = run.Run.restore

        def restore(self):
            original(self)
            self.position["pending"] = []

        with mock.patch.object(run.Run, "restore", restore):
            yield
    else:
        raise KeyError(name)


MUTANTS = ("sampling-stream-not-restored", "optimizer-not-restored", "record-not-cut-back", "pending-episodes-dropped")
