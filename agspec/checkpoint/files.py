"""Checkpoints and the final policy file (spec/16-training.md, T-RUN-DIR, T-RESUME).

``checkpoint.pt`` holds everything a run needs to continue as if it had never stopped: the
learner's networks, optimizers and random streams, the curriculum position, the finished episodes
not yet recorded and the training record's length.  ``policy.pt`` holds only the network the
evaluation runs, with what identifies it; both are written through a temporary file and a rename.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping

import torch

from agspec.formats import output

CHECKPOINT_SCHEMA = "agspec-training-checkpoint/1"
POLICY_SCHEMA = "agspec-policy-checkpoint/1"


class CheckpointError(ValueError):
    """A checkpoint or policy file that is not one of ours or does not fit the run."""


def _save(data: Mapping[str, Any], path: Path) -> None:
    with output.atomic_path(path, stable=True) as tmp:  # F-OUTPUT-FAILURES; the archive's name as before
        torch.save(dict(data), tmp)


def _load(path: Path, schema: str) -> dict[str, Any]:
    try:
        data = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # torch raises many kinds for a damaged or foreign file
        raise CheckpointError(f"{path}: not a readable checkpoint ({type(exc).__name__}: {exc})") from None
    if not isinstance(data, dict) or data.get("schema") != schema:
        raise CheckpointError(f"{path}: not an agspec checkpoint (schema {schema} expected)")
    return data


def save_checkpoint(path: Path, data: Mapping[str, Any]) -> None:
    _save({"schema": CHECKPOINT_SCHEMA, **data}, path)


def load_checkpoint(path: Path) -> dict[str, Any]:
    return _load(path, CHECKPOINT_SCHEMA)


def save_policy(path: Path, config: Mapping[str, Any], config_sha256: str, network: torch.nn.Module,
                steps: int) -> None:
    """The evaluated network with its architecture and identity (T-EVAL-ACTION)."""
    algorithm = config["algorithm"]
    arch = {"net": "qnet", **config["qnet"]} if algorithm == "qmix" else {"net": "shared-actor", **config["actor"]}
    state = {k: v.detach().cpu() for k, v in network.state_dict().items()}
    _save({"schema": POLICY_SCHEMA, "algorithm": algorithm, "architecture": arch, "scenario": config["scenario"],
           "seed": config["seed"], "steps": steps, "config_sha256": config_sha256, "state_dict": state}, path)


def load_policy_file(path: Path) -> dict[str, Any]:
    return _load(path, POLICY_SCHEMA)
