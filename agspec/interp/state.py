"""Global state of one AssemblyGrid v1 episode (spec D-STATE).

The state is plain data.  It is owned and mutated by exactly one :class:`~agspec.interp.tick.Simulator`;
rule functions in :mod:`agspec.interp.rules` take it as their first argument, like the store of the
WebAssembly reference interpreter.  Snapshots for traces and observations are built from it by pure
functions (:mod:`agspec.interp.snapshot`, :mod:`agspec.interp.observe`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any

from agspec.interp.geometry import RobotPose

Cell = tuple[int, int]  # (row, col); row-major order is tuple order (R-IDS)
Item = tuple[int, str]  # (product id, token)

# Ticks-as-reservations: an activity started at epoch t with total duration D occupies its robots at
# epochs t..t+D-1 and its effect applies on the transition into t+D (R-EXECUTION).


@lru_cache(maxsize=4096)  # pure; robot ids are formatted for every observation and event of every tick
def cell_id(cell: Cell) -> str:
    """Canonical robot id "i,j" (R-IDS)."""
    return f"{cell[0]},{cell[1]}"


def item_id(item: Item) -> str:
    """Canonical material item id "pid:token" (R-IDS)."""
    return f"{item[0]}:{item[1]}"


@dataclass
class Robot:
    cell: Cell
    pose: RobotPose
    holding: Item | None = None
    busy_until: int = 0
    incoming: Item | None = None  # receiver side of a handoff in flight
    supports: str | None = None  # candidate id of the pending support (R-SUPPORT)
    switch_lock: int = -1  # switching to another candidate is masked while t < switch_lock (R-SWITCH-LOCK)
    activity: str | None = None  # id of the activity the robot is committed to
    op_label: str | None = None  # observable label of the current activity kind
    role_label: str | None = None  # observable role in the current operation
    team_participations: int = 0

    def free(self, t: int) -> bool:
        """R-EXECUTION: free = not occupied by an activity and not receiving a transfer."""
        return self.busy_until <= t and self.incoming is None


@dataclass
class Product:
    pid: int
    recipe: str
    spawn_time: int
    due_time: int
    mass: float
    value: float
    source_rows: dict[str, int]
    completed: set[str] = field(default_factory=set)
    in_progress: set[str] = field(default_factory=set)
    xor_choice: dict[str, str] = field(default_factory=dict)  # group id -> chosen alternative (RC-XOR)
    raw_taken: set[str] = field(default_factory=set)  # raw tokens picked or reserved by a pick (R-PICK)
    delivered: bool = False
    complete_time: int | None = None


@dataclass
class Proposal:
    """A pending support record of one candidate (R-SUPPORT-LIFECYCLE: one clock per candidate)."""

    cid: str
    created_at: int
    expires_at: int
    votes: set[Cell] = field(default_factory=set)


@dataclass
class Activity:
    """A committed activity: pick, handoff, delivery or recipe operation (R-EXECUTION)."""

    aid: str
    kind: str  # "pick" | "handoff" | "deliver" | "operation"
    members: tuple[Cell, ...]
    resources: frozenset[str]
    plan: Any  # geometry.Plan
    target: tuple[float, float]  # common target point used by G-CONFLICT
    start: int
    end: int
    seq: int
    product: int | None = None
    # operation fields
    operation: str | None = None
    op_type: str | None = None
    candidate: str | None = None
    roles: tuple[tuple[Cell, str], ...] = ()
    first_proposed_at: int | None = None
    # logistics fields
    item: Item | None = None
    shelf_row: int | None = None
    sender: Cell | None = None
    receiver: Cell | None = None

    @property
    def is_operation(self) -> bool:
        return self.kind == "operation"


@dataclass
class State:
    t: int
    rows: int
    cols: int
    robots: dict[Cell, Robot]
    shelves: list[dict[str, int]]  # stock per shelf row, token -> units
    shelf_access: dict[int, tuple[int, ...]]  # shelf row -> left-column robot rows allowed to pick there
    products: list[Product] = field(default_factory=list)
    item_holder: dict[Item, Cell] = field(default_factory=dict)
    proposals: dict[str, Proposal] = field(default_factory=dict)
    activities: list[Activity] = field(default_factory=list)  # active, in creation order
    next_seq: int = 0
    next_team: int = 0
    released: int = 0
    delivered: int = 0
    lost_releases: int = 0
    release_opportunities: int = 0
    counters: dict[str, float] = field(default_factory=dict)

    @property
    def wip(self) -> int:
        return self.released - self.delivered

    def robots_row_major(self) -> list[Robot]:
        return [self.robots[c] for c in sorted(self.robots)]
