"""Reference controllers (spec chapter 11)."""

from __future__ import annotations

from typing import Any, Mapping

from agspec.suggest import choice_message

CONTROLLERS = ("random", "greedy", "parallel-aware", "centralized")


def make_controller(name: str, seed: int | None = None, grid: Mapping[str, Any] | None = None):
    """Construct a reference controller by name (C-RANDOM, C-GREEDY, C-PARALLEL-AWARE, C-CENTRALIZED).

    ``grid`` is the scenario's ``grid`` object (public scenario information, C-INFORMATION): the
    structured controllers route material on its G_handoff (C-STAGING). Without it they assume the
    v1 default topology (D-TOPOLOGY: Moore radius 1), right only for grids that use it.
    """
    if name == "greedy":
        from agspec.controllers.greedy import GreedyController

        return GreedyController(parallel_aware=False, grid=grid)
    if name == "parallel-aware":
        from agspec.controllers.greedy import GreedyController

        return GreedyController(parallel_aware=True, grid=grid)
    if name == "centralized":
        from agspec.controllers.centralized import CentralizedController

        return CentralizedController(grid=grid)
    if name == "random":
        from agspec.controllers.random_masked import RandomMaskedController

        return RandomMaskedController(seed)
    raise ValueError(choice_message("controller", name, CONTROLLERS))  # F-SUGGEST
