"""Where the rollout acts (spec/16-training.md, RES-ROLLOUT-DEVICE).

The rollout evaluates the actor (and, for PPO, the critic) once per tick on one agent set — 20 to 48
rows.  On a GPU such a batch is bound by launch and transfer latency, not arithmetic; the update's
large minibatches are where the GPU pays, and a GPU shared by many runs of a campaign is their
scarce part.  So the rollout may act on a copy of the networks on its own device, loaded from the
learner's after every change of the learner's weights (and at the start and on resume), so that
every action is drawn from exactly the weights the plain loop would use.  The copy changes where
arithmetic happens, never the protocol (one environment copy, RES-ONE-COPY; the same ticks, updates
and schedules).
"""

from __future__ import annotations

import copy
from typing import Any, Mapping

import numpy as np
import torch

# the configured value that keeps the rollout on the learner's own networks (no copy): the default,
# because on the one GPU machine measured the learner's GPU ran the per-tick forward passes of a lone
# run sooner than one CPU thread did (RES-ROLLOUT-DEVICE)
LEARNER = "learner"


def same_device(a: torch.device, b: torch.device) -> bool:
    """``cuda`` and ``cuda:0`` are one device; a device without an index is the first of its type."""
    return a.type == b.type and (a.index or 0) == (b.index or 0)


def rollout_device(config: Mapping[str, Any]) -> torch.device | None:
    """RES-ROLLOUT-DEVICE: the device the rollout's copy lives on, or None when the learner's own networks
    act (``learner``).  A device name puts a copy there, even on the learner's device (same stream,
    same bytes: what the tests use to check the copy's synchronization)."""
    name = config["runtime"]["rollout_device"]
    return None if name == LEARNER else torch.device(name)


def describe(learner: torch.device, rollout: torch.device | None) -> str:
    """What run.json records as ``rollout_device``: where the rollout's arithmetic ran."""
    return str(learner if rollout is None else rollout)


def rollout_stream(seed: int, learner_gen: torch.Generator, learner: torch.device,
                   rollout: torch.device | None) -> torch.Generator:
    """T-DETERMINISM, RES-ROLLOUT-DEVICE: on the learner's device the rollout samples from the learner's
    stream (so a copy there changes no byte); on another device a generator cannot be shared, and the
    rollout draws from a fourth stream of the run's seed (the first three are :func:`run.streams`')."""
    if rollout is None or same_device(rollout, learner):
        return learner_gen
    word = np.random.SeedSequence(seed).generate_state(4, dtype=np.uint64)[3]
    return torch.Generator(device=rollout).manual_seed(int(word) & (2**63 - 1))


def copy_to(module: torch.nn.Module, device: torch.device | None) -> torch.nn.Module:
    """The module itself when ``device`` is None, else a frozen copy on ``device``."""
    if device is None:
        return module
    return copy.deepcopy(module).to(device).requires_grad_(False)


def sync(copy_: torch.nn.Module, source: torch.nn.Module) -> None:
    """Load ``source``'s weights into its copy (a no-op when they are one module)."""
    if copy_ is not source:
        copy_.load_state_dict(source.state_dict())
