"""Random masked reference (spec C-RANDOM): each robot samples uniformly among its legal actions."""

from __future__ import annotations

import random
from itertools import compress
from typing import Any, Mapping

from agspec.controllers.base import Obs, parse_cell
from agspec.formats.actions import N_ACTIONS


class RandomMaskedController:
    name = "random"
    information = "local"

    def __init__(self, seed: int | None = None):
        self._seed = seed
        self._rng = random.Random(seed)
        self._order: tuple[tuple[str, ...], list[str]] = ((), [])  # robot ids as given -> row-major

    def reset(self, seed: int | None = None) -> None:
        # C-RANDOM: one seeded stream per episode; robots draw in row-major order.
        self._rng = random.Random(seed if seed is not None else self._seed)

    def row_major(self, robots: tuple[str, ...]) -> list[str]:
        """The robots in row-major order; the same robots come every epoch, so sorted once."""
        if robots != self._order[0]:
            self._order = (robots, sorted(robots, key=parse_cell))
        return self._order[1]

    def act(self, observations: Mapping[str, Obs], privileged: Any = None) -> dict[str, int]:
        out = {}
        for robot in self.row_major(tuple(observations)):
            legal = list(compress(range(N_ACTIONS), observations[robot]["mask"]))  # ascending legal actions
            out[robot] = self._rng.choice(legal)
        return out
