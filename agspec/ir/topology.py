"""Robot interaction graphs of a grid (spec D-GRID, D-TOPOLOGY, D-KTOPO).

AssemblyGrid v1 keeps three robot relations apart although they coincide in v1: observation
locality G_obs, bilateral-handoff locality G_handoff and cooperative-manipulation locality
G_manip (paper, "Structural relations and interaction graphs").  Each has its own function here so
that a caller says which relation it means; in v1 all three are induced by the scenario's
``grid.topology`` and ``grid.radius``.

Nodes are cells ``(row, col)`` (R-IDS: row-major order = tuple order).  Supported topologies:

* ``moore``       — cells adjacent iff max(|di|, |dj|) <= radius (v1 default, radius 1);
* ``von_neumann`` — cells adjacent iff |di| + |dj| <= radius;
* ``line``        — cells adjacent iff they share a row and |dj| <= radius: every row is a
  separate production line (RES-TOPOLOGY-LINE, an agspec resolution: the paper only names Moore).

With ``radius > 1`` (RES-RADIUS, outside the official suite) G_manip uses the full relation, while
G_handoff and G_obs keep only the pairs that are also Moore radius-1 neighbours: the action encoding
addresses only the eight direction cells (O-ACTION-ENCODING).  With radius 1 the three coincide.

The coalition bound k_topo = omega(G_manip) is *derived*, never declared (D-KTOPO); it is computed
with networkx's clique enumeration.  Default Moore radius 1: 4 on any grid with at least 2 rows and
2 columns; von Neumann and line radius 1: 2; a 1x1 grid: 1.

The action encoding and the observation address G_handoff and G_obs neighbours by direction slot
(O-ACTION-ENCODING): :func:`direction_slots` gives, per cell, the (direction index, neighbour) pairs
of such a graph.  Every user of a locality relation (interpreter, controllers, adapters, invariant
checker) takes it from here, so no caller re-derives the relation from the grid.

All functions are pure and build fresh graphs (grids are small).
"""

from __future__ import annotations

from typing import Callable

import networkx as nx

from agspec.formats.actions import DIRECTIONS

Cell = tuple[int, int]

TOPOLOGIES = ("moore", "von_neumann", "line")
DEFAULT_TOPOLOGY = "moore"
DEFAULT_RADIUS = 1


class TopologyError(ValueError):
    """Unknown topology name or a radius that is not a positive integer."""


def _moore(di: int, dj: int, radius: int) -> bool:
    return max(di, dj) <= radius


def _von_neumann(di: int, dj: int, radius: int) -> bool:
    return di + dj <= radius


def _line(di: int, dj: int, radius: int) -> bool:
    return di == 0 and dj <= radius


_ADJACENCY: dict[str, Callable[[int, int, int], bool]] = {
    "moore": _moore,
    "von_neumann": _von_neumann,
    "line": _line,
}


def cells(rows: int, cols: int) -> list[Cell]:
    """D-GRID: all cells of an M x N grid in row-major order."""
    return [(i, j) for i in range(rows) for j in range(cols)]


def adjacent(a: Cell, b: Cell, topology: str = DEFAULT_TOPOLOGY, radius: int = DEFAULT_RADIUS) -> bool:
    """D-TOPOLOGY: whether two distinct cells are neighbours under ``topology`` and ``radius``."""
    _check(topology, radius)
    if a == b:
        return False
    return _ADJACENCY[topology](abs(a[0] - b[0]), abs(a[1] - b[1]), radius)


def _check(topology: str, radius: int) -> None:
    if not isinstance(topology, str) or topology not in _ADJACENCY:
        raise TopologyError(f"unknown topology {topology!r} (known: {', '.join(TOPOLOGIES)})")
    if isinstance(radius, bool) or not isinstance(radius, int) or radius < 1:
        raise TopologyError(f"topology radius must be an integer >= 1, got {radius!r}")


def _grid_graph(rows: int, cols: int, topology: str, radius: int, *, directions_only: bool = False) -> nx.Graph:
    """The undirected neighbour graph on the cells of an M x N grid (D-TOPOLOGY).

    ``directions_only`` keeps only pairs within the eight radius-1 direction cells (RES-RADIUS).
    """
    _check(topology, radius)
    if rows < 0 or cols < 0:
        raise TopologyError(f"grid size must be non-negative, got {rows}x{cols}")
    rel = _ADJACENCY[topology]
    graph = nx.Graph()
    nodes = cells(rows, cols)
    graph.add_nodes_from(nodes)
    for i, j in nodes:
        # Only look forward (row-major) inside the radius window: every edge is added once.
        for di in range(0, radius + 1):
            for dj in range(-radius, radius + 1):
                if (di, dj) <= (0, 0):
                    continue
                ni, nj = i + di, j + dj
                if directions_only and max(di, abs(dj)) > 1:
                    continue
                if 0 <= ni < rows and 0 <= nj < cols and rel(abs(di), abs(dj), radius):
                    graph.add_edge((i, j), (ni, nj))
    return graph


def manipulation_graph(
    rows: int, cols: int, topology: str = DEFAULT_TOPOLOGY, radius: int = DEFAULT_RADIUS
) -> nx.Graph:
    """D-TOPOLOGY: G_manip — pairs that may jointly take part in one direct-manipulation coalition.

    Coalition members are pairwise adjacent in this graph (R-CANDIDATES), so coalitions are cliques.
    """
    return _grid_graph(rows, cols, topology, radius)


def handoff_graph(
    rows: int, cols: int, topology: str = DEFAULT_TOPOLOGY, radius: int = DEFAULT_RADIUS
) -> nx.Graph:
    """D-TOPOLOGY: G_handoff — pairs that may perform a direct bilateral transfer (R-HANDOFF).

    Only pairs in the eight direction cells (RES-RADIUS): handoff actions name a direction.
    """
    return _grid_graph(rows, cols, topology, radius, directions_only=True)


def observation_graph(
    rows: int, cols: int, topology: str = DEFAULT_TOPOLOGY, radius: int = DEFAULT_RADIUS
) -> nx.Graph:
    """D-TOPOLOGY: G_obs — pairs whose task-level dynamic state is mutually observable
    (O-OBSERVATION); only the eight direction cells carry neighbour slots (RES-RADIUS)."""
    return _grid_graph(rows, cols, topology, radius, directions_only=True)


def direction_slots(graph: nx.Graph) -> dict[Cell, tuple[tuple[int, Cell], ...]]:
    """O-ACTION-ENCODING: for each cell of a direction-cell graph (G_handoff or G_obs), its neighbours
    as (direction index d, cell) in direction order d = 0 .. 7 (RES-RADIUS: only the eight radius-1
    cells can be neighbours in these graphs)."""
    out = {}
    for c in graph.nodes:
        around = graph[c]
        out[c] = tuple((d, (c[0] + di, c[1] + dj)) for d, (di, dj) in enumerate(DIRECTIONS)
                       if (c[0] + di, c[1] + dj) in around)
    return out


def k_topo(graph: nx.Graph) -> int:
    """D-KTOPO: k_topo^max = omega(G_manip), the clique number (0 for an empty graph)."""
    return max((len(clique) for clique in nx.find_cliques(graph)), default=0)


def grid_k_topo(
    rows: int, cols: int, topology: str = DEFAULT_TOPOLOGY, radius: int = DEFAULT_RADIUS
) -> int:
    """D-KTOPO: the clique number of the manipulation graph of an M x N grid.

    Every pair of neighbours differs by at most ``radius`` in row and in column under all three
    topologies, so every clique fits in an (r+1) x (r+1) box, and the relation is translation
    invariant: the clique number of the grid equals that of its top-left
    min(M, r+1) x min(N, r+1) corner, which is what is built (large grids stay cheap).
    """
    _check(topology, radius)
    window = radius + 1
    return k_topo(manipulation_graph(min(rows, window), min(cols, window), topology, radius))


def default_k_topo() -> int:
    """D-KTOPO: k_topo of the default v1 topology (Moore radius 1 on a grid of at least 2x2) = 4.

    A recipe on its own (without a scenario grid) is checked against this bound (RC-ARITY).
    """
    return grid_k_topo(2, 2, DEFAULT_TOPOLOGY, DEFAULT_RADIUS)


def grid_spec(grid: dict) -> tuple[int, int, str, int]:
    """Read (rows, cols, topology, radius) from a scenario ``grid`` object, with v1 defaults."""
    return (
        int(grid["rows"]),
        int(grid["cols"]),
        grid.get("topology", DEFAULT_TOPOLOGY),
        grid.get("radius", DEFAULT_RADIUS),
    )
