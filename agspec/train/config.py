"""The paper's MARL configurations (tab:marlconfig) as plain data (spec/16-training.md, T-CONFIG).

One mapping per algorithm, laid out like the table's rows; :func:`resolve` adds the run's algorithm,
scenario and seed and applies overrides given as dotted keys (``ppo.clip=0.2``).  No module here
imports torch: a resolved configuration is JSON data that a campaign can plan, hash and ship.

Values the table does not state but the original release fixes are marked with the Resolution that
settles them (spec/16-training.md).
"""

from __future__ import annotations

import copy
import hashlib
import json
from typing import Any, Mapping

import yaml

from agspec.marl.curriculum import EXECUTION_BASE, FAMILY_SEED_OFFSET, GENERATION_BASE
from agspec.suggest import choice_message

CONFIG_SCHEMA = "agspec-training-config/1"
ALGORITHMS = ("ippo", "mappo", "qmix")
PAPER_BUDGET = 1_536_000

# T-CURRICULUM, RES-TRAINING-SEEDS: the original's run-specific realization seeds

# tab:marlconfig rows shared by the three methods
_COMMON: dict[str, Any] = {
    "schema": CONFIG_SCHEMA,
    # "Training budget": 1,536,000 environment steps (T-ENV-STEP: one joint tick of one copy)
    "budget": {"env_steps": PAPER_BUDGET},
    # "Discount": gamma = 0.99
    "gamma": 0.99,
    # "Optimizer": AdamW (eps = 1e-5); weight decay and betas are torch's defaults (RES-ADAMW-DEFAULTS)
    "optimizer": {"name": "AdamW", "eps": 1e-5, "weight_decay": 0.01, "betas": [0.9, 0.999]},
    # "Training curriculum": one difficulty per run, the budget split evenly over five realizations
    # regenerated from suite indices 0-4 under run-specific seeds, consecutive blocks (T-CURRICULUM)
    "curriculum": {
        "realizations": 5,
        "indices": [0, 1, 2, 3, 4],
        "stage": 0,  # RES-CURRICULUM-STAGE
        "generation_seed_base": GENERATION_BASE,
        "execution_seed_base": EXECUTION_BASE,
        "family_offset": None,  # resolved from the scenario's family (FAMILY_SEED_OFFSET)
    },
    # "Initialization": random weights; no demonstrations, behavior cloning, or pretraining
    "initialization": "random",
    # T-REWARD: coalition_milestone_v1 (A-REWARD-MILESTONE); support credit per method below
    "reward": {"name": "coalition_milestone_v1", "support_credit": None},
    # T-VALIDATION: online monitoring on the validation split (RES-VALIDATION-SCHEDULE)
    "validation": {"indices": [200, 201, 202, 203, 204], "initial": True, "every_block": True, "actions": ["greedy"]},
    # T-RECORD: one training-record row per 16,000 environment steps (the original's interval)
    "record": {"every_steps": 16_000},
    # T-RUN-DIR: resumable checkpoints (block boundaries always; also every N steps where cheap)
    "checkpoint": {"every_steps": 16_000},
    # T-COPIES: environment copies stepped together; the original stepped one (RES-ONE-COPY)
    "rollout": {"envs": 1},
    # execution choices that never change a result on CPU (T-COPIES: sync or async vector env); where the
    # rollout acts: the learner's networks, or a copy on a named device (RES-ROLLOUT-DEVICE)
    "runtime": {"device": "cpu", "rollout_device": "learner", "vector": "auto", "threads": None},
}

# "Execution network" IPPO/MAPPO: the shared actor (T-ACTOR)
_SHARED_ACTOR = {"kind": "shared-residual", "width": 256, "blocks": 2, "activation": "tanh",
                 "input_layer_norm": True, "heads": ["family", "slot"], "init": "orthogonal"}

_PPO = {
    # "On-policy update" (T-PPO-UPDATE)
    "ppo": {
        "gae_lambda": 0.95,
        "clip": 0.10,
        "value_clip": 0.20,
        "steps_per_update": 1600,
        "epochs": 4,
        "minibatch": 4096,
        "max_grad_norm": 0.5,
        "target_kl": 0.02,
        "kl_stop_factor": 1.5,  # RES-KL-STOP
        "value_loss": "huber",  # RES-VALUE-LOSS
        "normalize_advantages": True,  # RES-ADVANTAGE-NORM
    },
    # "Learning rate": actor 1e-4, critic 3e-4
    "lr": {"actor": 1e-4, "critic": 3e-4},
    # "Exploration / regularization": entropy coefficient 0.015 -> 0.001 linearly over the budget
    "entropy": {"start": 0.015, "end": 0.001},
    # "Warm-up": 3,200-step critic warm-up (actor frozen) (T-WARMUP)
    "warmup": {"critic_steps": 3200},
}

ALGORITHM_TABLE: dict[str, dict[str, Any]] = {
    "ippo": {
        **_PPO,
        "actor": dict(_SHARED_ACTOR),
        # "Training value model": local critic on the agent's own observation; same residual trunk
        "critic": {"input": "observation", "width": 256, "blocks": 2},
        "reward": {"support_credit": "agent"},
    },
    "mappo": {
        **_PPO,
        "actor": dict(_SHARED_ACTOR),
        # privileged agent-conditioned global critic on the concatenated global state and observation
        "critic": {"input": "state+observation", "width": 256, "blocks": 2},
        "reward": {"support_credit": "agent"},
    },
    "qmix": {
        # "Execution network": shared Q network, tanh MLP with two hidden layers of width 256 (T-QNET)
        "qnet": {"hidden": [256, 256], "activation": "tanh", "init": "torch-default"},
        # "Training value model": monotonic mixer over the global state, mixing width 64,
        # hypernetwork hidden width 128, non-negative weights (T-MIXER)
        "mixer": {"width": 64, "hyper_hidden": 128, "hyper_layers": 2, "non_negative": "softplus"},
        # "Learning rate": 5e-4
        "lr": {"q": 5e-4},
        # "Exploration": epsilon-greedy 1.0 -> 0.05 linearly over the first 75 %, then 0.05 (T-QMIX-EXPLORATION)
        "epsilon": {"start": 1.0, "end": 0.05, "decay_fraction": 0.75},
        # "Replay / target" (T-QMIX-UPDATE)
        "replay": {"capacity": 50_000, "batch": 64, "train_every": 4, "target_sync_every": 1600,
                   "td_target": "single-network", "loss": "mse", "max_grad_norm": 10.0},  # RES-ADAMW-DEFAULTS
        # "Warm-up": 3,200 transitions in the replay before the first update
        "warmup": {"replay_transitions": 3200},
        "reward": {"support_credit": "mean"},
        # T-RUN-DIR: the replay makes a checkpoint large; QMIX checkpoints at block boundaries only
        "checkpoint": {"every_steps": None},
    },
}


class ConfigError(ValueError):
    """A bad algorithm, scenario, override or value (the message names the key).

    ``invalid_input`` marks a file whose content is invalid (F-EXIT-CODES: exit 1), as opposed to a
    bad option or a file that cannot be reached (exit 2)."""

    def __init__(self, message: str, invalid_input: bool = False):
        super().__init__(message)
        self.invalid_input = invalid_input


def _merge(base: dict[str, Any], extra: Mapping[str, Any]) -> dict[str, Any]:
    out = copy.deepcopy(base)
    for key, value in extra.items():
        if isinstance(value, Mapping) and isinstance(out.get(key), dict):
            out[key] = _merge(out[key], value)
        else:
            out[key] = copy.deepcopy(value)
    return out


def paper_defaults(algorithm: str) -> dict[str, Any]:
    """The table's configuration of ``algorithm`` (no scenario or seed yet)."""
    if algorithm not in ALGORITHMS:
        raise ConfigError(choice_message("algorithm", algorithm, ALGORITHMS))  # F-SUGGEST
    return {"algorithm": algorithm, **_merge(_COMMON, ALGORITHM_TABLE[algorithm])}


def parse_override(text: str) -> tuple[str, Any]:
    """``key.sub=value`` -> (key, value); the value is read as YAML (numbers, lists, null, strings)."""
    key, sep, raw = text.partition("=")
    key = key.strip()
    if not sep or not key:
        raise ConfigError(f"--set {text!r}: expected KEY=VALUE, e.g. ppo.clip=0.2")
    try:
        value = yaml.safe_load(raw) if raw.strip() else None
    except yaml.YAMLError as exc:
        raise ConfigError(f"--set {text!r}: the value is not readable: {exc}") from None
    return key, value


def apply_overrides(config: dict[str, Any], overrides: Mapping[str, Any]) -> dict[str, Any]:
    """Set dotted keys; a key must already exist (a typo never adds a silent new setting)."""
    out = copy.deepcopy(config)
    for dotted, value in overrides.items():
        parts = dotted.split(".")
        node = out
        for depth, part in enumerate(parts):
            if not isinstance(node, dict) or part not in node:
                where = ".".join(parts[:depth]) or "the configuration"
                known = ", ".join(sorted(node)) if isinstance(node, dict) else "none (not a section)"
                raise ConfigError(f"unknown setting {dotted!r}: {where} has no {part!r} (known: {known})")
            if depth == len(parts) - 1:
                if isinstance(node[part], dict) and not isinstance(value, Mapping):
                    raise ConfigError(f"{dotted!r} is a section; set one of its keys ({', '.join(sorted(node[part]))})")
                node[part] = _merge(node[part], value) if isinstance(value, Mapping) and isinstance(node[part], dict) \
                    else copy.deepcopy(value)
            node = node[part]
    return out


def flatten_settings(data: Mapping[str, Any], defaults: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """A settings file's mapping (sections or dotted keys) as dotted keys down to the defaults' leaves,
    so that :func:`apply_overrides` checks every key of the file."""
    out: dict[str, Any] = {}
    for key, value in data.items():
        dotted = f"{prefix}{key}"
        node: Any = defaults
        for part in dotted.split("."):
            node = node.get(part) if isinstance(node, Mapping) else None
        if isinstance(value, Mapping) and isinstance(node, Mapping):
            out.update(flatten_settings(value, defaults, dotted + "."))
        else:
            out[dotted] = value
    return out


def _positive_int(config: Mapping[str, Any], dotted: str, allow_none: bool = False) -> None:
    node: Any = config
    for part in dotted.split("."):
        node = node[part]
    if node is None and allow_none:
        return
    if isinstance(node, bool) or not isinstance(node, int) or node < 1:
        raise ConfigError(f"{dotted} must be a positive integer, got {node!r}")


def check(config: Mapping[str, Any]) -> None:
    """The consistency a run needs before it starts (T-CURRICULUM, T-COPIES); raises ConfigError."""
    for key in ("budget.env_steps", "curriculum.realizations", "rollout.envs", "record.every_steps"):
        _positive_int(config, key)
    _positive_int(config, "checkpoint.every_steps", allow_none=True)
    steps, blocks, envs = config["budget"]["env_steps"], config["curriculum"]["realizations"], config["rollout"]["envs"]
    if len(config["curriculum"]["indices"]) != blocks:
        raise ConfigError(f"curriculum.indices has {len(config['curriculum']['indices'])} entries for "
                          f"{blocks} realizations")
    if steps % blocks:
        raise ConfigError(f"budget.env_steps = {steps} must split evenly over {blocks} realizations (T-CURRICULUM)")
    per_block = steps // blocks
    if per_block % envs:
        raise ConfigError(f"each realization block ({per_block} steps) must split evenly over rollout.envs = {envs} "
                          "copies (T-COPIES)")
    for key in ("record.every_steps", "checkpoint.every_steps"):
        section, name = key.split(".")
        if config[section][name] is not None and config[section][name] % envs:
            raise ConfigError(f"{key} = {config[section][name]} must be a multiple of rollout.envs = {envs} (T-COPIES)")
    if config["algorithm"] in ("ippo", "mappo"):
        for key in ("ppo.steps_per_update", "ppo.epochs", "ppo.minibatch"):
            _positive_int(config, key)
        if config["ppo"]["steps_per_update"] % envs:
            raise ConfigError(f"ppo.steps_per_update = {config['ppo']['steps_per_update']} must split evenly over "
                              f"rollout.envs = {envs} copies (T-COPIES)")
    else:
        for key in ("replay.capacity", "replay.batch", "replay.train_every", "replay.target_sync_every"):
            _positive_int(config, key)
    if config["runtime"]["vector"] not in ("auto", "sync", "async"):
        raise ConfigError(f"runtime.vector must be auto, sync or async, got {config['runtime']['vector']!r}")
    threads = config["runtime"]["threads"]
    if threads is not None and (isinstance(threads, bool) or not isinstance(threads, int) or threads < 1):
        raise ConfigError(f"runtime.threads must be a positive integer or null, got {threads!r}")
    if not isinstance(config["runtime"]["device"], str):
        raise ConfigError("runtime.device must be a string such as cpu or cuda")
    if not isinstance(config["runtime"]["rollout_device"], str):
        raise ConfigError("runtime.rollout_device must be learner or a device such as cpu (RES-ROLLOUT-DEVICE)")
    actions = config["validation"]["actions"]
    if not isinstance(actions, list) or not actions or any(a not in ("greedy", "sample") for a in actions):
        raise ConfigError(f"validation.actions must be a non-empty list of greedy and sample, got {actions!r}")
    for index in config["validation"]["indices"]:
        if isinstance(index, bool) or not isinstance(index, int) or index < 0:
            raise ConfigError(f"validation.indices must be suite indices, got {index!r}")


def resolve(algorithm: str, scenario: str, seed: int, family: str | None,
            overrides: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The full configuration of one run: the table, the run's identity, then the overrides."""
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ConfigError(f"seed must be a non-negative integer, got {seed!r}")
    config = paper_defaults(algorithm)
    config.update(scenario=str(scenario), seed=seed)
    # RES-TRAINING-SEEDS: the family offset of the three official families; any other family takes 0
    config["curriculum"]["family_offset"] = FAMILY_SEED_OFFSET.get(family or "", 0)
    config["reward"]["support_credit"] = ALGORITHM_TABLE[algorithm]["reward"]["support_credit"]
    for fixed in ("algorithm", "scenario", "seed", "schema"):
        if fixed in (overrides or {}):
            raise ConfigError(f"{fixed} is part of the run's identity; give it as its own option, not --set")
    config = apply_overrides(config, overrides or {})
    check(config)
    return config


def digest(config: Mapping[str, Any]) -> str:
    """SHA-256 of the configuration's canonical JSON (sorted keys, compact), without ``runtime``: how a
    run executes (device, threads, vector mode) is recorded in run.json, not part of what it is (T-CONFIG)."""
    identity = {k: v for k, v in config.items() if k != "runtime"}
    return hashlib.sha256(json.dumps(identity, sort_keys=True, separators=(",", ":")).encode()).hexdigest()
