"""The training API (spec/16-training.md): what the CLI and the campaign build on.

    config = resolve_config("mappo", "coalition-medium", seed=3, overrides={"budget.env_steps": 16000})
    summary = train(config, "runs/mappo-coalition-medium-s3")          # or resume=True after a cut
    is_complete("runs/mappo-coalition-medium-s3")                        # True once run.json says so
    factory = load_policy("runs/mappo-coalition-medium-s3")              # F-POLICY-PYTHON factory

Everything here takes and returns plain JSON data; torch is imported only when a run starts or a
policy is loaded (the extra ``agspec[train]``).
"""

from __future__ import annotations

import os
from typing import Any, Callable, Mapping

from agspec.checkpoint.rundir import RunDirError, is_complete, read_summary
from agspec.extras import MissingExtra, require_torch
from agspec.suggest import choice_message
from agspec.train.config import ConfigError, resolve

__all__ = ["ConfigError", "MissingExtra", "RunDirError", "is_complete", "load_policy", "read_summary",
           "resolve_config", "train"]


def scenario_family(scenario: str) -> str | None:
    """The family of a scenario name or file (T-CURRICULUM's seed offset); ConfigError if unknown."""
    from agspec.catalogue import CatalogueError, InvalidDocumentError, load_scenario_bundle

    try:
        ir, _recipes, _profile = load_scenario_bundle(scenario)
    except InvalidDocumentError as exc:
        raise ConfigError(str(exc), invalid_input=True) from None
    except CatalogueError as exc:
        raise ConfigError(str(exc)) from None
    return ir.get("family")


def resolve_config(algorithm: str, scenario: str, seed: int,
                   overrides: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The full resolved configuration of one run (tab:marlconfig + the run's identity + overrides)."""
    from agspec.train.config import ALGORITHMS

    if algorithm not in ALGORITHMS:  # before loading the scenario: the cheaper error first
        raise ConfigError(choice_message("algorithm", algorithm, ALGORITHMS))  # F-SUGGEST
    return resolve(algorithm, scenario, seed, scenario_family(scenario), overrides)


def train(config: Mapping[str, Any], out_dir: str | os.PathLike, *, resume: bool = False,
          progress: Callable[[Mapping[str, Any]], None] | None = None) -> dict[str, Any]:
    """Run (or resume) one training run into ``out_dir``; return the run summary (also ``run.json``).

    ``progress`` is called with plain dicts (``{"phase", "steps", "total", …}``) as the run goes.
    Raises ConfigError, RunDirError (an existing run that is not this one, a resume with another
    configuration) or MissingExtra.
    """
    require_torch()
    from agspec.train.run import run

    return run(dict(config), out_dir, resume=resume, progress=progress)


def load_policy(run_dir: str | os.PathLike, action: str | None = None) -> Callable[[Any], Callable[..., dict[str, int]]]:
    """A policy factory for ``agspec evaluate --policy RUN_DIR`` (F-POLICY-PYTHON): ``factory(env)``
    returns ``policy(observations, infos) -> actions``, the masked argmax of the trained network
    (T-EVAL-ACTION); ``action="sample"`` plays the sampled training-time behaviour instead."""
    require_torch()
    from agspec.checkpoint.policy import factory_from_run

    return factory_from_run(run_dir, action)
