"""Reference controllers (spec chapter 11)."""

from __future__ import annotations

CONTROLLERS = ("random", "greedy", "parallel-aware", "centralized")


def make_controller(name: str, seed: int | None = None):
    """Construct a reference controller by name (C-RANDOM, C-GREEDY, C-PARALLEL-AWARE, C-CENTRALIZED)."""
    if name == "greedy":
        from agspec.controllers.greedy import GreedyController

        return GreedyController(parallel_aware=False)
    if name == "parallel-aware":
        from agspec.controllers.greedy import GreedyController

        return GreedyController(parallel_aware=True)
    if name == "centralized":
        from agspec.controllers.centralized import CentralizedController

        return CentralizedController()
    if name == "random":
        from agspec.controllers.random_masked import RandomMaskedController

        return RandomMaskedController(seed)
    raise ValueError(f"unknown controller {name!r}; choose one of {', '.join(CONTROLLERS)}")
