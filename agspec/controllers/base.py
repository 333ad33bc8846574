"""Controller interface and the shared logistics helpers of the reference controllers (spec 11).

A decentralized controller maps each robot's execution information I_t^u (its observation, which
carries its action mask) to an action; it never sees the global state (C-INFORMATION).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any, Mapping, Protocol

import networkx as nx

from agspec.interp.model import DIRECTIONS
from agspec.interp.observe import DELIVER, HANDOFF0, IDLE, OP0, PICK0, RECEIVE0
from agspec.ir import topology

Obs = Mapping[str, Any]
Cell = tuple[int, int]


class Controller(Protocol):
    name: str
    information: str  # "local" or "global"

    def reset(self, seed: int | None) -> None: ...

    def act(self, observations: Mapping[str, Obs], privileged: Any = None) -> dict[str, int]: ...


@lru_cache(maxsize=4096)  # pure: robot ids repeat every tick, parsing them dominated the controllers' profile
def parse_cell(robot: str) -> tuple[int, int]:
    i, j = robot.split(",")
    return int(i), int(j)


GridSpec = tuple[int, int, str, int]  # (rows, cols, topology, radius): agspec.ir.topology.grid_spec


def grid_key(grid: Mapping[str, Any] | None, rows: int, cols: int) -> GridSpec:
    """The grid a controller plans on: the scenario's ``grid`` object (public scenario information,
    C-INFORMATION) or, without one, the v1 default topology (D-TOPOLOGY: Moore radius 1) on the
    observed size."""
    if grid is None:
        return (rows, cols, topology.DEFAULT_TOPOLOGY, topology.DEFAULT_RADIUS)
    return topology.grid_spec(grid)


@dataclass(frozen=True, eq=False)  # identity hash: the memo keys below stay cheap
class Routes:
    """C-STAGING on one grid: route distances in G_handoff, staging sets in G_manip, the G_obs
    neighbourhoods of C-PARALLEL-AWARE's congestion — every relation from agspec.ir.topology."""

    rows: int
    cols: int
    handoff: nx.Graph
    manip: nx.Graph
    obs: nx.Graph
    # memo (not state): target -> hop counts to it, one BFS per target (the graph never changes)
    _to: dict[Cell, dict[Cell, int]] = field(default_factory=dict, repr=False)

    def distance(self, a: Cell, b: Cell) -> int | None:
        """Route distance: hop count from a to b in G_handoff (None: b is unreachable from a)."""
        to = self._to.get(b)
        if to is None:
            to = self._to[b] = nx.single_source_shortest_path_length(self.handoff, b) if b in self.handoff else {}
        return to.get(a)

    def observed_around(self, cell: Cell) -> tuple[Cell, ...]:
        """The G_obs neighbours of ``cell`` (row-major)."""
        return tuple(sorted(self.obs[cell])) if cell in self.obs else ()

    def staging_set(self, anchor: Cell) -> tuple[Cell, ...]:
        """C-STAGING: anchor plus its G_manip neighbours (row-major) adjacent in G_manip to all cells
        chosen so far, up to 4; then any remaining neighbours."""
        return _staging_set(self, anchor)

    def item_target(self, product: int, token: str, final: bool, at: Cell) -> Cell:
        """C-STAGING: where a held item at ``at`` should go: the output column for a terminal item,
        else a cell of its product's staging set (anchored in the item's G_handoff component)."""
        return _item_target(self, product, token, final, at)

    def _target(self, product: int, token: str, final: bool, at: Cell) -> Cell:
        if final:
            return (at[0], self.cols - 1)
        anchor = (product % max(1, self.rows - 1), max(0, self.cols - 3))
        if self.distance(at, anchor) is None:  # RES-STAGING-TOPOLOGY: e.g. another row of a `line` grid
            anchor = (at[0], anchor[1])
        cells = self.staging_set(anchor)
        return cells[token_slot(token) % len(cells)]


@lru_cache(maxsize=64)  # pure: one set of graphs per grid
def routes(grid: GridSpec) -> Routes:
    rows, cols, topo, radius = grid
    return Routes(rows, cols, topology.handoff_graph(rows, cols, topo, radius),
                  topology.manipulation_graph(rows, cols, topo, radius),
                  topology.observation_graph(rows, cols, topo, radius))


@lru_cache(maxsize=65536)  # pure: items, tokens and cells repeat every tick
def _item_target(r: Routes, product: int, token: str, final: bool, at: Cell) -> Cell:
    return r._target(product, token, final, at)


@lru_cache(maxsize=4096)  # pure function of the grid: one computation per (anchor, grid)
def _staging_set(r: Routes, anchor: Cell) -> tuple[Cell, ...]:
    chosen = [anchor]
    neighbours = sorted(r.manip[anchor]) if anchor in r.manip else []
    for n in neighbours:
        if len(chosen) == 4:
            break
        if all(r.manip.has_edge(n, c) for c in chosen):
            chosen.append(n)
    for n in neighbours:  # fallback: any remaining neighbours
        if len(chosen) == 4:
            break
        if n not in chosen:
            chosen.append(n)
    return tuple(chosen)


@lru_cache(maxsize=4096)  # pure: a token's staging slot never changes
def token_slot(token: str) -> int:
    """C-STAGING: the slot of a token in its product's staging set."""
    return sum((k + 1) * ord(ch) for k, ch in enumerate(token)) % 4


__all__ = ["DELIVER", "HANDOFF0", "IDLE", "OP0", "PICK0", "RECEIVE0", "DIRECTIONS"]
