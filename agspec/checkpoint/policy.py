"""A trained network as an evaluable policy (spec/16-training.md, T-EVAL-ACTION; F-POLICY-PYTHON).

``factory_from_run(RUN_DIR)`` is what ``agspec evaluate --policy RUN_DIR`` calls: it returns
``factory(env)`` (once per episode) whose policy maps the PettingZoo observations to the masked
argmax of the actor's logits (IPPO, MAPPO) or of the Q values (QMIX), first index on ties — the
paper's deterministic evaluation action.  ``action="sample"`` (a target ending in ``#sample``) plays
the training-time behaviour instead — a draw from the masked softmax (IPPO, MAPPO) or ε-greedy at the
final ε (QMIX) — seeded by the episode's execution seed, for monitoring only (T-VALIDATION).  A loaded network is kept per (file, size, mtime), so the
file is read once per process however many episodes it plays.
"""

from __future__ import annotations

import os
from functools import lru_cache
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np
import torch

from agspec.checkpoint import nets
from agspec.checkpoint.files import CheckpointError, load_policy_file
from agspec.checkpoint.rundir import POLICY

SAMPLE_SUFFIX = "#sample"
FINAL_EPSILON = 0.05  # T-QMIX-EXPLORATION: the behaviour policy's ε once the schedule has ended


def split_target(target: str | os.PathLike) -> tuple[Path, str]:
    """(path, action): a target ending in ``#sample`` asks for the sampled behaviour."""
    text = str(target)
    if text.endswith(SAMPLE_SUFFIX):
        return Path(text[: -len(SAMPLE_SUFFIX)]), "sample"
    return Path(text), "greedy"


def policy_path(target: str | os.PathLike) -> Path:
    """A run directory's ``policy.pt``, or a policy file itself."""
    path = split_target(target)[0]
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


def sampled_actions(net: torch.nn.Module, kind: str, obs: np.ndarray, mask: np.ndarray,
                    gen: torch.Generator) -> np.ndarray:
    """The training-time behaviour: a masked softmax draw (actor) or ε-greedy at the final ε (Q net)."""
    with torch.no_grad():
        scores = net(torch.from_numpy(obs))
        m = torch.from_numpy(mask)
        if kind == "qnet":
            best = nets.greedy(scores, m)
            explore = torch.rand(best.shape, generator=gen) < FINAL_EPSILON
            uniform = torch.multinomial(m.float(), 1, generator=gen).squeeze(-1)
            return torch.where(explore, uniform, best).numpy()
        probs = torch.softmax(nets.masked_logits(scores, m), dim=-1)
        return torch.multinomial(probs, 1, generator=gen).squeeze(-1).numpy()


def factory_from_run(target: str | os.PathLike, action: str | None = None
                     ) -> Callable[[Any], Callable[..., dict[str, int]]]:
    """F-POLICY-PYTHON: ``factory(env) -> policy(observations, infos) -> actions``."""
    path, suffix_action = split_target(target)
    action = action or suffix_action
    net, meta = load_network(path)
    kind = meta["architecture"]["net"]

    def factory(env: Any) -> Callable[..., dict[str, int]]:
        seed = int((getattr(env, "instance", None) or {}).get("seeds", {}).get("execution") or 0)
        gen = torch.Generator().manual_seed(seed)

        def policy(observations: Mapping[str, Any], infos: Mapping[str, Any]) -> dict[str, int]:
            agents = list(observations)
            obs = np.stack([observations[a]["observation"] for a in agents])
            mask = np.stack([observations[a]["action_mask"] for a in agents])
            chosen = sampled_actions(net, kind, obs, mask, gen) if action == "sample" else greedy_actions(net, obs, mask)
            return {a: int(x) for a, x in zip(agents, chosen)}

        return policy

    return factory
