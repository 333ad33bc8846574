"""The paper's training realizations and the evaluation splits as instance lists (A-PZ-SPLIT, A-TRAINING-REALIZATIONS).

Pure functions, the one place of the training seed formula: the environment's ``split="training"``
option (:mod:`agspec.marl.parallel`) and the trainer's curriculum both call them.

The paper trains each run on five realizations regenerated from the scenario parameters of suite
indices 0–4 under run-specific seeds (S-SPLITS, informative there), in consecutive blocks of equal
budget in the order r = 0 … 4.  The original derives the seeds as

    generation = 80000 + family offset + 100·algorithm seed + 10·stage + r
    execution  = 90000 + family offset + 100·algorithm seed + 10·stage + r

with family offsets 0 (coalition), 300000 (flow) and 600000 (concurrency); a run trains one
difficulty in one stage, so ``stage`` is 0 for the paper's runs.  Validation (200–204) and
final-test (1000–1049) instances are the canonical suite instances, identical for every run.
"""

from __future__ import annotations

from typing import Any, Mapping, Sequence

from agspec.catalogue import SPLITS
from agspec.ir.instance import make_instance

GENERATION_BASE = 80_000
EXECUTION_BASE = 90_000
FAMILY_SEED_OFFSET: Mapping[str, int] = {"coalition": 0, "flow": 300_000, "concurrency": 600_000}
REALIZATIONS = 5  # r = 0 … 4: the parameters of suite indices 0–4 (S-SPLITS "training")
MAX_STAGE = 9  # 10·stage + r stays below 100, so two (seed, stage, r) never share a seed
MAX_SEED = 2_999  # 100·seed stays below the next family's offset (300000)

# the split names the environment accepts (A-PZ-SPLIT); "train" is an alias of "training"
SPLIT_ALIASES: Mapping[str, str] = {"train": "training", "training": "training", "validation": "validation",
                                    "final-test": "final-test"}


class CurriculumError(ValueError):
    """A training realization that the formula does not define (message says which argument)."""


def _check(name: str, value: Any, high: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= high:
        raise CurriculumError(f"{name} must be an integer in 0..{high}, got {value!r}")
    return value


def family_offset(family: str) -> int:
    """The family's seed offset (A-TRAINING-REALIZATIONS); only the paper's three families have one."""
    try:
        return FAMILY_SEED_OFFSET[family]
    except KeyError:
        raise CurriculumError(f"the training seed formula is defined for the families "
                              f"{', '.join(FAMILY_SEED_OFFSET)}; the scenario's family is {family!r}") from None


def seed_pair(offset: int, seed: int, stage: int, r: int, generation_base: int = GENERATION_BASE,
              execution_base: int = EXECUTION_BASE) -> tuple[int, int]:
    """The one seed formula (A-TRAINING-REALIZATIONS, RES-TRAINING-SEEDS): base + offset + 100·seed + 10·stage + r.

    The trainer calls it with its configured bases and offset (T-CURRICULUM); the environment's
    training split through :func:`training_seeds`, with the paper's.
    """
    tail = offset + 100 * seed + 10 * stage + r
    return generation_base + tail, execution_base + tail


def training_seeds(family: str, seed: int, stage: int = 0, r: int = 0) -> tuple[int, int]:
    """(generation seed, execution seed) of training realization ``r`` of algorithm seed ``seed``."""
    _check("seed", seed, MAX_SEED)
    _check("stage", stage, MAX_STAGE)
    _check("realization", r, REALIZATIONS - 1)
    return seed_pair(family_offset(family), seed, stage, r)


def training_instance(bundle: tuple[Mapping[str, Any], Mapping[str, Any], Mapping[str, Any]], seed: int,
                      stage: int = 0, r: int = 0) -> dict[str, Any]:
    """Training realization ``r``: the scenario's parameters, realized under the run's seeds (S-REALIZATION).

    ``bundle`` is ``(scenario IR, recipes, profile IR)`` as :func:`agspec.catalogue.load_scenario_bundle`
    returns it.  Scenario parameters do not depend on the suite index in v1, so the realization of
    "suite index r" under other seeds is the scenario realized with those seeds.
    """
    scenario, recipes, profile = bundle
    gen, exe = training_seeds(str(scenario.get("family")), seed, stage, r)
    return make_instance(scenario, recipes, profile, generation_seed=gen, execution_seed=exe)


def training_instances(bundle: tuple[Mapping[str, Any], Mapping[str, Any], Mapping[str, Any]], seed: int,
                       stage: int = 0) -> list[dict[str, Any]]:
    """The run's five training realizations in the paper's block order r = 0 … 4."""
    return [training_instance(bundle, seed, stage, r) for r in range(REALIZATIONS)]


def block_sizes(budget: int, parts: int = REALIZATIONS) -> list[int]:
    """The budget split evenly over the realizations (the last blocks take the remainder, one each)."""
    if isinstance(budget, bool) or not isinstance(budget, int) or budget < 0:
        raise CurriculumError(f"budget must be a non-negative integer, got {budget!r}")
    base, extra = divmod(budget, parts)
    return [base + (1 if k >= parts - extra else 0) for k in range(parts)]


def realization_at(step: int, budget: int, parts: int = REALIZATIONS) -> int:
    """Which realization's block holds env step ``step`` (0-based) of a ``budget``-step run."""
    edge = 0
    for r, size in enumerate(block_sizes(budget, parts)):
        edge += size
        if step < edge:
            return r
    return parts - 1


def split_name(split: str) -> str:
    """The canonical name of an environment split (A-PZ-SPLIT)."""
    try:
        return SPLIT_ALIASES[split]
    except (KeyError, TypeError):
        raise CurriculumError(f"split must be one of {', '.join(SPLIT_ALIASES)}, got {split!r}") from None


def split_indices(split: str) -> Sequence[int]:
    """The suite indices of an evaluation split (validation 200–204, final-test 1000–1049)."""
    name = split_name(split)
    if name == "training":
        raise CurriculumError("the training split has no suite indices: its realizations come from the run's seed")
    return SPLITS[name]


__all__ = ["CurriculumError", "EXECUTION_BASE", "FAMILY_SEED_OFFSET", "GENERATION_BASE", "REALIZATIONS",
           "block_sizes", "family_offset", "realization_at", "split_indices", "split_name", "training_instance",
           "training_instances", "training_seeds"]
