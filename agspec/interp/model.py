"""Read-only view of an instance IR that the rules consult (spec D-GRID, D-TOPOLOGY, RC-*).

Everything here is derived once from the instance IR at reset and never changes during an episode.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import Any

import networkx as nx

from agspec.formats.actions import DIRECTION_NAMES, DIRECTIONS, HANDOFF0, IDLE, N_ACTIONS, RECEIVE0
from agspec.interp import geometry
from agspec.interp.state import cell_id
from agspec.ir import topology, variants

Cell = tuple[int, int]
DirectionSlots = dict[Cell, tuple[tuple[int, str, Cell], ...]]

__all__ = ["DIRECTIONS", "DIRECTION_NAMES", "Model", "OperationSpec", "RecipeSpec"]


@dataclass(frozen=True)
class OperationSpec:
    id: str
    type: str
    inputs: tuple[str, ...]
    output: str
    after: tuple[str, ...]
    kmin: int
    kmax: int
    roles: tuple[tuple[str, str | None], ...]  # (role name, bound input token or None), recipe order
    resources: tuple[str, ...]
    duration: int
    weight: float
    xor_group: str | None


@dataclass(frozen=True)
class RecipeSpec:
    id: str
    value: float
    raw: tuple[str, ...]
    operations: tuple[OperationSpec, ...]  # topological order, ties by id
    xor_groups: dict[str, tuple[str, ...]]
    terminal: str
    critical_path: int  # longest chain of operation durations (RC-DURATION)

    def op(self, op_id: str) -> OperationSpec:
        for op in self.operations:
            if op.id == op_id:
                return op
        raise KeyError(op_id)

    @cached_property
    def input_tokens(self) -> frozenset[str]:
        """Every token some operation consumes: the tokens a product still needs while none of its
        XOR groups has chosen (O-PICK-OPTIONS; no alternative is closed yet, RC-XOR)."""
        return frozenset(tok for op in self.operations for tok in op.inputs)

    @cached_property
    def downstream(self) -> dict[str, int]:
        """Longest duration chain strictly after each operation (for productive weights)."""
        succ: dict[str, list[str]] = {op.id: [] for op in self.operations}
        group_alts = self.xor_groups
        for op in self.operations:
            for pred in op.after:
                for p in group_alts.get(pred, (pred,)):
                    succ[p].append(op.id)
        memo: dict[str, int] = {}
        for op in reversed(self.operations):
            memo[op.id] = max((self.op(s).duration + memo[s] for s in succ[op.id]), default=0)
        return memo


def _recipe_spec(ir: dict[str, Any]) -> RecipeSpec:
    groups = {g["id"]: tuple(g["alternatives"]) for g in ir.get("xor", [])}
    group_of = {alt: gid for gid, alts in groups.items() for alt in alts}
    ops = {}
    graph = nx.DiGraph()
    for op in ir["operations"]:
        graph.add_node(op["id"])
    for op in ir["operations"]:
        for pred in op.get("after", []):
            for p in groups.get(pred, (pred,)):
                graph.add_edge(p, op["id"])
        ops[op["id"]] = OperationSpec(
            id=op["id"],
            type=op.get("type", op["id"]),
            inputs=tuple(op["inputs"]),
            output=op["outputs"][0],
            after=tuple(op.get("after", [])),
            kmin=int(op["arity"][0]),
            kmax=int(op["arity"][1]),
            roles=tuple((r["name"], r.get("binds")) for r in op["roles"]),
            resources=tuple(op.get("resources", [])),
            duration=int(op["duration"]),
            weight=float(op.get("weight", 1.0)),
            xor_group=group_of.get(op["id"]),
        )
    order = list(nx.lexicographical_topological_sort(graph))
    consumed = {tok for op in ops.values() for tok in op.inputs}
    produced = [op.output for op in ops.values() if op.output not in consumed]
    terminal = produced[0] if produced else "FINAL"
    for node in graph.nodes:
        graph.nodes[node]["d"] = ops[node].duration
    critical = 0
    for node in order:  # longest path by node weights
        best = max((graph.nodes[p]["cp"] for p in graph.predecessors(node)), default=0)
        graph.nodes[node]["cp"] = best + ops[node].duration
        critical = max(critical, graph.nodes[node]["cp"])
    return RecipeSpec(
        id=ir["id"],
        value=float(ir.get("value", 1.0)),
        raw=tuple(ir["raw"]),
        operations=tuple(ops[o] for o in order),
        xor_groups=groups,
        terminal=terminal,
        critical_path=critical,
    )


@dataclass(frozen=True)
class Model:
    instance: dict[str, Any]
    rows: int
    cols: int
    profile: dict[str, Any]
    recipes: dict[str, RecipeSpec]
    resource_capacity: dict[str, int]
    wip_cap: int
    release_interval: int
    mode: str  # "continuing" | "batch"
    horizon: int
    batch_size: int | None
    shelf_capacity: int
    replenish_interval: int
    support_timeout: int
    switch_lock: int
    support_visible: bool
    k_topo: int
    pick_duration: int
    handoff_duration: int
    deliver_duration: int

    @staticmethod
    def from_instance(instance: dict[str, Any]) -> "Model":
        sc = instance["scenario"]
        grid = sc["grid"]
        ev = sc["evaluation"]
        prof = instance["profile"]
        caps: dict[str, int] = {}
        for r in instance["recipes"].values():
            caps.update({k: int(v) for k, v in r.get("resources", {}).items()})
        caps.update({k: int(v) for k, v in sc.get("resources", {}).items()})
        rows, cols = int(grid["rows"]), int(grid["cols"])
        return Model(
            instance=instance,
            rows=rows,
            cols=cols,
            profile=prof,
            recipes={rid: _recipe_spec(r) for rid, r in instance["recipes"].items()},
            resource_capacity=caps,
            wip_cap=int(sc["release"]["wip_cap"]),
            release_interval=int(sc["release"]["interval"]),
            mode=ev["mode"],
            horizon=int(ev.get("horizon", ev.get("timeout", 0))),
            batch_size=ev.get("batch_size"),
            shelf_capacity=int(sc["shelves"]["capacity"]),
            replenish_interval=int(sc["shelves"]["replenish_interval"]),
            support_timeout=int(sc["coordination"]["support_timeout"]),
            switch_lock=int(sc["coordination"]["switch_lock"]),
            support_visible=variants.enabled("support_visible", sc),
            k_topo=topology.grid_k_topo(*topology.grid_spec(grid)),
            pick_duration=int(prof["durations"]["pick"]),
            handoff_duration=int(prof["durations"]["handoff"]),
            deliver_duration=int(prof["durations"]["deliver"]),
        )

    @cached_property
    def grid_spec(self) -> tuple[int, int, str, int]:
        """(rows, cols, topology, radius) of the scenario grid, with the v1 defaults (D-TOPOLOGY)."""
        return topology.grid_spec(self.instance["scenario"]["grid"])

    @cached_property
    def topology(self) -> str:
        return self.grid_spec[2]

    @cached_property
    def cells(self) -> tuple[Cell, ...]:
        return tuple((i, j) for i in range(self.rows) for j in range(self.cols))

    @cached_property
    def input_column(self) -> tuple[Cell, ...]:
        """The cells of column 0, row-major: the robots that may pick (O-PICK-OPTIONS, R-PICK)."""
        return tuple(c for c in self.cells if c[1] == 0)

    @cached_property
    def manipulation_graph(self) -> nx.Graph:
        """G_manip (D-TOPOLOGY), from agspec.ir.topology: who may share a coalition (R-CANDIDATES)."""
        return topology.manipulation_graph(*self.grid_spec)

    @cached_property
    def neighbours(self) -> dict[Cell, tuple[Cell, ...]]:
        """Open neighbourhood N(u) minus u in G_manip, in row-major order (D-TOPOLOGY)."""
        graph = self.manipulation_graph
        return {c: tuple(sorted(graph[c])) for c in self.cells}

    @cached_property
    def _adjacency(self) -> frozenset[tuple[Cell, Cell]]:
        return frozenset(pair for a, b in self.manipulation_graph.edges for pair in ((a, b), (b, a)))

    @staticmethod
    def _slots(graph: nx.Graph) -> DirectionSlots:
        return {c: tuple((d, DIRECTION_NAMES[d], n) for d, n in around)
                for c, around in topology.direction_slots(graph).items()}

    @cached_property
    def handoff_slots(self) -> DirectionSlots:
        """Each cell's G_handoff neighbours as (direction index, direction name, cell), in
        O-ACTION-ENCODING direction order: the handoff/receive slots that can ever match (R-HANDOFF, O-MASK)."""
        return self._slots(topology.handoff_graph(*self.grid_spec))

    @cached_property
    def observation_slots(self) -> DirectionSlots:
        """Each cell's G_obs neighbours as (direction index, direction name, cell), in direction order:
        the neighbour entries of its observation (O-OBSERVATION)."""
        return self._slots(topology.observation_graph(*self.grid_spec))

    @cached_property
    def handoff_partner(self) -> dict[tuple[Cell, int], tuple[Cell, int]]:
        """(u, d) -> (v, d'): the G_handoff neighbour v of u in direction d and the direction d' that
        points back at u (R-HANDOFF clause 1); absent when u has no such neighbour."""
        return {(c, d): (n, DIRECTIONS.index((c[0] - n[0], c[1] - n[1])))
                for c, around in self.handoff_slots.items() for d, _, n in around}

    @cached_property
    def direction_masks(self) -> dict[Cell, tuple[tuple[bool, ...], tuple[bool, ...]]]:
        """The static part of O-MASK per cell: idle plus the receive slot of every G_handoff neighbour
        (for an empty robot) and idle plus its handoff slot (for a holding robot)."""
        out = {}
        for c, around in self.handoff_slots.items():
            receive, handoff = [False] * N_ACTIONS, [False] * N_ACTIONS
            receive[IDLE] = handoff[IDLE] = True
            for d, _, _ in around:
                receive[RECEIVE0 + d] = handoff[HANDOFF0 + d] = True
            out[c] = (tuple(receive), tuple(handoff))
        return out

    @cached_property
    def mask_rows(self) -> tuple[tuple[Cell, tuple[bool, ...], tuple[bool, ...], bool], ...]:
        """Per cell in row-major order: the cell, its receive and handoff templates (:attr:`direction_masks`)
        and whether it is in the output column (R-DELIVERY), what O-MASK's commonest answers read."""
        return tuple((c, *self.direction_masks[c], c[1] == self.cols - 1) for c in self.cells)

    @cached_property
    def conflict_parameters(self) -> tuple[float, float, bool]:
        """G-CONFLICT's profile parameters: rho_conf, the clearance (homogeneous population: one for
        all robots) and whether trajectory segments are tested (variant ``trajectory_conflicts``)."""
        return (float(self.profile["rho_conf"]), float(self.profile["clearance"]),
                variants.enabled("trajectory_conflicts", self.profile))

    @cached_property
    def plans(self) -> geometry.PlanMemo:
        """G-MOTION plans of candidates and logistics activities, remembered across epochs (a cache, not state)."""
        return geometry.PlanMemo(self.profile)

    @cached_property
    def cell_ids(self) -> tuple[str, ...]:
        """The robot ids "i,j" of ``cells``, in the same row-major order (D-GRID)."""
        return tuple(cell_id(c) for c in self.cells)

    @cached_property
    def realized(self) -> dict[tuple, Any]:
        """R-CANDIDATES realizations remembered across epochs (a cache, not state): a candidate is a pure
        function of its occurrence, members, holders and the members' poses (agspec.interp.candidates)."""
        return {}

    def adjacent(self, a: Cell, b: Cell) -> bool:
        """G_manip adjacency (D-TOPOLOGY), from agspec.ir.topology."""
        return (a, b) in self._adjacency

    def resource_cap(self, name: str) -> int:
        return self.resource_capacity.get(name, 1)
