"""Controller interface and the shared logistics helpers of the reference controllers (spec 11).

A decentralized controller maps each robot's execution information I_t^u (its observation, which
carries its action mask) to an action; it never sees the global state (C-INFORMATION).
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any, Mapping, Protocol

from agspec.interp.model import DIRECTIONS
from agspec.interp.observe import DELIVER, HANDOFF0, IDLE, OP0, PICK0, RECEIVE0

Obs = Mapping[str, Any]


class Controller(Protocol):
    name: str
    information: str  # "local" or "global"

    def reset(self, seed: int | None) -> None: ...

    def act(self, observations: Mapping[str, Obs], privileged: Any = None) -> dict[str, int]: ...


@lru_cache(maxsize=4096)  # pure: robot ids repeat every tick, parsing them dominated the controllers' profile
def parse_cell(robot: str) -> tuple[int, int]:
    i, j = robot.split(",")
    return int(i), int(j)


def chebyshev(a: tuple[int, int], b: tuple[int, int]) -> int:
    """Route distance on the Moore graph = BFS hop count = Chebyshev distance (C-STAGING)."""
    return max(abs(a[0] - b[0]), abs(a[1] - b[1]))


@lru_cache(maxsize=4096)  # pure function of the grid: one computation per (anchor, grid size)
def staging_set(anchor: tuple[int, int], rows: int, cols: int) -> tuple[tuple[int, int], ...]:
    """C-STAGING: anchor plus Moore neighbours (row-major) adjacent to all cells chosen so far, up to 4."""
    chosen = [anchor]
    neighbours = [
        (anchor[0] + di, anchor[1] + dj)
        for di in (-1, 0, 1)
        for dj in (-1, 0, 1)
        if (di, dj) != (0, 0) and 0 <= anchor[0] + di < rows and 0 <= anchor[1] + dj < cols
    ]
    for n in neighbours:
        if len(chosen) == 4:
            break
        if all(chebyshev(n, c) <= 1 for c in chosen):
            chosen.append(n)
    for n in neighbours:  # fallback: any remaining neighbours
        if len(chosen) == 4:
            break
        if n not in chosen:
            chosen.append(n)
    return tuple(chosen)


def item_target(product: int, token: str, final: bool, at: tuple[int, int], rows: int, cols: int) -> tuple[int, int]:
    """C-STAGING: where a held item should go: the output column for a terminal item, else a staging cell."""
    if final:
        return (at[0], cols - 1)
    anchor = (product % max(1, rows - 1), max(0, cols - 3))
    cells = staging_set(anchor, rows, cols)
    return cells[token_slot(token) % len(cells)]


@lru_cache(maxsize=4096)  # pure: a token's staging slot never changes
def token_slot(token: str) -> int:
    """C-STAGING: the slot of a token in its product's staging set."""
    return sum((k + 1) * ord(ch) for k, ch in enumerate(token)) % 4


__all__ = ["DELIVER", "HANDOFF0", "IDLE", "OP0", "PICK0", "RECEIVE0", "DIRECTIONS"]
