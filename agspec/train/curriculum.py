"""The training curriculum and the validation instances (spec/16-training.md, T-CURRICULUM, T-VALIDATION).

One declared scenario per run; the budget split evenly into consecutive blocks, one per training
realization; realization r is regenerated from the scenario's parameters under the run-specific
seeds of RES-TRAINING-SEEDS.  Validation and final-test instances are the suite's own (S-SPLITS):
the training realizations never coincide with them because their seeds lie in other ranges.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

from agspec.ir.fingerprint import fingerprint
from agspec.marl.curriculum import seed_pair


@dataclass(frozen=True)
class Block:
    """One realization block of the curriculum."""

    block: int  # 0-based position in the fixed order
    index: int  # the suite index whose scenario parameters it takes (0-4)
    generation_seed: int
    execution_seed: int
    first_step: int  # environment steps done before the block starts
    steps: int


def realization_seeds(config: Mapping[str, Any], r: int) -> tuple[int, int]:
    """RES-TRAINING-SEEDS: (base + family offset + 100·seed + 10·stage + r) for generation and execution."""
    c = config["curriculum"]
    return seed_pair(c["family_offset"], config["seed"], c["stage"], r, c["generation_seed_base"],
                     c["execution_seed_base"])


def plan(config: Mapping[str, Any]) -> list[Block]:
    """T-CURRICULUM: the blocks in their fixed order, each with an equal share of the budget."""
    c = config["curriculum"]
    per_block = config["budget"]["env_steps"] // c["realizations"]
    out = []
    for r, index in enumerate(c["indices"]):
        gen, exe = realization_seeds(config, r)
        out.append(Block(r, int(index), gen, exe, r * per_block, per_block))
    return out


def training_instances(config: Mapping[str, Any], blocks: list[Block]) -> list[dict[str, Any]]:
    """Each block's instance IR: the scenario realized under the block's seeds (S-REALIZATION)."""
    from agspec.catalogue import load_scenario_bundle
    from agspec.ir.instance import make_instance

    scenario, recipes, profile = load_scenario_bundle(config["scenario"])
    return [make_instance(scenario, recipes, profile, generation_seed=b.generation_seed,
                          execution_seed=b.execution_seed) for b in blocks]


def suite_instances(config: Mapping[str, Any], indices: list[int]) -> list[dict[str, Any]]:
    """Suite instances of the run's scenario (validation 200–204, final test 1000–1049)."""
    from agspec.catalogue import load_scenario_bundle
    from agspec.ir.instance import make_instance

    if not indices:
        return []
    scenario, recipes, profile = load_scenario_bundle(config["scenario"])
    return [make_instance(scenario, recipes, profile, index=i) for i in indices]


def describe(block: Block, instance: Mapping[str, Any]) -> dict[str, Any]:
    """The block as recorded in run.json: seeds, steps, instance id and fingerprint (F-FINGERPRINT)."""
    return {"block": block.block, "index": block.index, "generation_seed": block.generation_seed,
            "execution_seed": block.execution_seed, "first_step": block.first_step, "steps": block.steps,
            "instance_id": instance["id"], "fingerprint": fingerprint(instance)}
