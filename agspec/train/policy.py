"""A trained network as an evaluable policy (spec/16-training.md, T-EVAL-ACTION; F-POLICY-PYTHON).

``factory_from_run(RUN_DIR)`` is what ``agspec evaluate --policy RUN_DIR`` calls: it returns
``factory(env)`` (once per episode) whose policy maps the PettingZoo observations to the masked
argmax of the actor's logits (IPPO, MAPPO) or of the Q values (QMIX), first index on ties — the
paper's deterministic evaluation action.  A loaded network is kept per (file, size, mtime), so the
file is read once per process however many episodes it plays.
"""

from __future__ import annotations

import os
from functools import lru_cache
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np
import torch

from agspec.train import nets
from agspec.train.checkpoint import CheckpointError, load_policy_file
from agspec.train.rundir import POLICY


def policy_path(target: str | os.PathLike) -> Path:
    """A run directory's ``policy.pt``, or a policy file itself."""
    path = Path(target)
    return path / POLICY if path.is_dir() else path


def build_network(data: Mapping[str, Any]) -> torch.nn.Module:
    """The evaluated network of a policy file, weights loaded, in eval mode."""
    arch = data["architecture"]
    gen = torch.Generator().manual_seed(0)  # overwritten by the stored weights
    if arch["net"] == "qnet":
        net: torch.nn.Module = nets.QNet(arch["hidden"], gen)
    elif arch["net"] == "shared-actor":
        net = nets.SharedActor(arch["width"], arch["blocks"], gen)
    else:
        raise CheckpointError(f"unknown network {arch['net']!r} in the policy file")
    net.load_state_dict(data["state_dict"])
    return net.eval()


@lru_cache(maxsize=8)
def _cached(path: str, size: int, mtime_ns: int) -> tuple[torch.nn.Module, dict[str, Any]]:
    data = load_policy_file(Path(path))
    meta = {k: v for k, v in data.items() if k != "state_dict"}
    return build_network(data), meta


def load_network(target: str | os.PathLike) -> tuple[torch.nn.Module, dict[str, Any]]:
    """(network, metadata) of a run directory or policy file; CheckpointError if it is none."""
    path = policy_path(target)
    try:
        st = path.stat()
    except OSError as exc:
        raise CheckpointError(f"{path}: {exc.strerror or exc}") from None
    return _cached(str(path.resolve()), st.st_size, st.st_mtime_ns)


def greedy_actions(net: torch.nn.Module, obs: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """T-EVAL-ACTION: the masked argmax (first index on ties) for a batch of agents."""
    with torch.no_grad():
        return nets.greedy(net(torch.from_numpy(obs)), torch.from_numpy(mask)).numpy()


def factory_from_run(target: str | os.PathLike) -> Callable[[Any], Callable[..., dict[str, int]]]:
    """F-POLICY-PYTHON: ``factory(env) -> policy(observations, infos) -> actions``."""
    net, _meta = load_network(target)

    def factory(env: Any) -> Callable[..., dict[str, int]]:
        def policy(observations: Mapping[str, Any], infos: Mapping[str, Any]) -> dict[str, int]:
            agents = list(observations)
            obs = np.stack([observations[a]["observation"] for a in agents])
            mask = np.stack([observations[a]["action_mask"] for a in agents])
            return {a: int(x) for a, x in zip(agents, greedy_actions(net, obs, mask))}

        return policy

    return factory
