"""The eleven formal invariants of AssemblyGrid v1 as trace predicates (spec chapter 08).

Each invariant is ONE function named after its spec ID (``inv_conservation`` is INV-CONSERVATION,
and so on) with the signature ``(ctx, prev, rec) -> list[Violation]``:

* ``ctx``  — a :class:`Context`: the instance IR, what is derived from it once (recipes, grid
  relations, capacities) and the little memory some invariants need across records
  (INV-LIFETIME: activity id -> fixed attributes first seen; INV-CONSERVATION: items that
  disappeared);
* ``prev`` — the previous record (the header or a tick record), or ``None`` for the header;
* ``rec``  — the record checked: the header (state ``s_0``) or a tick record
  ``{t, actions, events, state: s_{t+1}, observations?: I_t}`` (F-TRACE).

State clauses are evaluated on ``rec["state"]``; transition clauses on the pair
``(prev["state"], rec)``; observation and mask clauses on ``rec["observations"]`` against the
pre-action state ``prev["state"]`` (O-OBSERVATION: observations of epoch ``t`` are built from
``s_t``).

The checker reads traces only — JSON produced by any implementation — and never the reference
interpreter: nothing here imports :mod:`agspec.interp` (STYLE §2, INV-TRACE).  It may read
``agspec.ir`` (the grid relations of D-TOPOLOGY).  Events are read for two things only: the
activities that start and complete within one transition (realized duration 1, never visible in a
state record: ``pick_started``, ``handoff_started``, ``admitted``, ``delivery_started`` with their
``end``) and coerced actions (``action_coerced``, R-ACTION-VALIDATION).

:func:`check_trace` runs all eleven over a whole trace with the INV-TRACE vacuity guard.
"""

from __future__ import annotations

import json
import math
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping

from agspec.ir import topology

Json = dict[str, Any]

N_ACTIONS = 114  # O-ACTION-ENCODING
IDLE, DELIVER, PICK0, HANDOFF0, RECEIVE0, OP0 = 0, 1, 2, 34, 42, 50
PICK_SLOTS, OP_SLOTS = 32, 64
DIRECTIONS = ((-1, 0), (-1, 1), (0, 1), (1, 1), (1, 0), (1, -1), (0, -1), (-1, -1))
DIRECTION_NAMES = ("N", "NE", "E", "SE", "S", "SW", "W", "NW")
REACH_TOLERANCE = 1e-9  # G-REACH
CONFLICT_TOLERANCE = 1e-12  # G-CONFLICT
SUPPORT_TOLERANCE = 1e-12

# O-OBSERVATION: the exact field lists of a local observation and of its entries.
OBS_FIELDS = frozenset(
    {"robot", "t", "grid", "holding", "busy", "failed", "supports", "neighbours", "pick_options",
     "operation_options", "mask"}
)
NEIGHBOUR_FIELDS = frozenset({"dir", "robot", "holding", "busy", "failed", "op", "role"})
HELD_FIELDS = frozenset({"product", "token", "final"})
OPERATION_OPTION_FIELDS = frozenset(
    {"id", "product", "recipe", "operation", "type", "kmin", "size", "role", "members", "duration",
     "min_reach_margin", "support"}
)
PICK_OPTION_FIELDS = frozenset({"id", "product", "recipe", "token", "shelf_row", "stock"})

INVARIANT_IDS = (
    "INV-CONSERVATION", "INV-SUPPORT", "INV-PROGRESS", "INV-RECIPE", "INV-LOCALITY", "INV-LIFETIME",
    "INV-ARITY", "INV-EXCLUSIVITY", "INV-OBSERVATION", "INV-MASKING", "INV-ACCOUNTING",
)
TRACE_EMPTY, TRACE_TRUNCATED, TRACE_VACUOUS = "TRACE-EMPTY", "TRACE-TRUNCATED", "TRACE-VACUOUS"


# --------------------------------------------------------------------------- data


@dataclass(frozen=True)
class Violation:
    """One failed invariant clause.

    ``invariant`` is the spec ID (``INV-…`` or ``TRACE-…``), ``tick`` the epoch of the state record
    in which it is observed (``t + 1`` for the transition ``t -> t + 1``; observation and mask
    clauses use the decision epoch ``t`` of the observation), ``entity`` the robot, item, activity,
    product or candidate id concerned, ``message`` a human explanation.
    """

    invariant: str
    tick: int | None
    entity: str | None
    message: str

    def __str__(self) -> str:
        where = f"t={self.tick}" if self.tick is not None else "t=?"
        who = f" [{self.entity}]" if self.entity is not None else ""
        return f"{self.invariant} {where}{who}: {self.message}"


@dataclass(frozen=True)
class OpInfo:
    id: str
    inputs: tuple[str, ...]
    output: str
    after: tuple[str, ...]
    kmin: int
    kmax: int
    roles: tuple[tuple[str, str | None], ...]  # (name, bound input or None), declaration order
    resources: tuple[str, ...]
    xor_group: str | None


@dataclass(frozen=True)
class RecipeInfo:
    id: str
    raw: tuple[str, ...]
    ops: dict[str, OpInfo]
    groups: dict[str, tuple[str, ...]]  # XOR group id -> alternatives
    terminal: str
    tokens: frozenset[str]  # raw tokens and operation outputs

    def producers(self, token: str) -> list[str]:
        return [op.id for op in self.ops.values() if op.output == token]


def _recipe_info(ir: Mapping[str, Any]) -> RecipeInfo:
    groups = {g["id"]: tuple(g["alternatives"]) for g in ir.get("xor", []) or []}
    group_of = {alt: gid for gid, alts in groups.items() for alt in alts}
    ops = {}
    for op in ir["operations"]:
        ops[op["id"]] = OpInfo(
            id=op["id"],
            inputs=tuple(op["inputs"]),
            output=op["outputs"][0],
            after=tuple(op.get("after", [])),
            kmin=int(op["arity"][0]),
            kmax=int(op["arity"][1]),
            roles=tuple((r["name"], r.get("binds")) for r in op["roles"]),
            resources=tuple(op.get("resources", [])),
            xor_group=group_of.get(op["id"]),
        )
    consumed = {tok for op in ops.values() for tok in op.inputs}
    terminals = sorted({op.output for op in ops.values() if op.output not in consumed})
    terminal = terminals[0] if terminals else "FINAL"
    tokens = frozenset(ir.get("raw", [])) | {op.output for op in ops.values()}
    return RecipeInfo(ir["id"], tuple(ir.get("raw", [])), ops, groups, terminal, tokens)


def parse_cell(robot: str) -> tuple[int, int]:
    i, j = robot.split(",")
    return int(i), int(j)


def cell_id(cell: tuple[int, int]) -> str:
    return f"{cell[0]},{cell[1]}"


def parse_candidate(cid: str) -> tuple[int, str, list[str]] | None:
    """R-IDS: ``op:{pid}:{op}:{i},{j};{i},{j}`` -> (pid, op, member ids); None if malformed."""
    parts = cid.split(":")
    if len(parts) != 4 or parts[0] != "op":
        return None
    try:
        pid = int(parts[1])
    except ValueError:
        return None
    members = parts[3].split(";") if parts[3] else []
    return pid, parts[2], members


def parse_item(item: str) -> tuple[int, str] | None:
    pid, sep, token = item.partition(":")
    if not sep:
        return None
    try:
        return int(pid), token
    except ValueError:
        return None


@dataclass
class StateView:
    """Indexes of one state record, computed once per record."""

    t: int
    robots: dict[str, Json]
    products: dict[int, Json]
    activities: list[Json]
    act_by_id: dict[str, Json]
    membership: dict[str, list[str]]  # robot id -> ids of the activities it is a member of
    holders: dict[str, list[str]]  # item id -> robots whose `holding` is that item
    items: dict[str, str]
    proposals: dict[str, Json]
    shelves: list[Json]
    _free: dict[str, bool] = field(default_factory=dict)  # memo of free(); a view never changes

    def free(self, robot: str) -> bool:
        """D-STATE: free iff busy_until <= t and no incoming transfer."""
        known = self._free.get(robot)
        if known is None:
            r = self.robots.get(robot) or {}
            known = self._free[robot] = int(r.get("busy_until") or 0) <= self.t and r.get("incoming") is None
        return known


def _view(state: Json) -> StateView:
    robots = state.get("robots") or {}
    holders: dict[str, list[str]] = {}
    for rid, r in robots.items():
        h = r.get("holding")
        for item in (h if isinstance(h, list) else [h] if h is not None else []):
            holders.setdefault(str(item), []).append(rid)
    activities = list(state.get("activities") or [])
    membership: dict[str, list[str]] = {}
    for a in activities:
        for m in a.get("members", []):
            membership.setdefault(m, []).append(a.get("id"))
    return StateView(
        t=int(state.get("t", 0)),
        robots=robots,
        products={int(p["id"]): p for p in state.get("products") or []},
        activities=activities,
        act_by_id={a.get("id"): a for a in activities},
        membership=membership,
        holders=holders,
        items=dict(state.get("items") or {}),
        proposals=dict(state.get("proposals") or {}),
        shelves=list(state.get("shelves") or []),
    )


@dataclass
class Transition:
    """What happened between ``s_t`` and ``s_{t+1}``: the activities that started and completed."""

    t: int
    started: list[Json]  # new in s_{t+1} or started and completed within the transition
    completing: list[Json]  # activities whose end is t + 1 (R-COMPLETION), with `sender` for handoffs


@dataclass
class Context:
    """The instance IR, what is derived from it, and the invariants' memory across records."""

    instance: Json
    recipes: dict[str, RecipeInfo]
    rows: int
    cols: int
    topology: str
    radius: int
    k_topo: int
    capacities: dict[str, int]
    shelf_capacity: int
    support_timeout: int
    support_visible: bool
    wip_cap: int
    interval: int
    mode: str
    batch_size: int | None
    spacing: float
    reach: float
    rho_conf: float
    clearance: float
    shelf_access: dict[int, tuple[int, ...]]
    realization_products: list[Json]
    # memory across records
    lifetime: dict[str, tuple] = field(default_factory=dict)  # INV-LIFETIME: activity id -> fixed attributes
    lifetime_gone: set[str] = field(default_factory=set)
    gone_items: dict[str, int] = field(default_factory=dict)  # INV-CONSERVATION: item -> epoch it disappeared
    counts: Counter = field(default_factory=Counter)  # invariant ID -> objects evaluated
    evaluated: Counter = field(default_factory=Counter)  # invariant ID -> records evaluated
    skipped: dict[str, str] = field(default_factory=dict)  # invariant ID -> why a clause was skipped
    _views: dict[int, tuple[Json, StateView]] = field(default_factory=dict)
    # static neighbourhoods of the grid, memoized per robot (the grid never changes within a trace)
    _direction_nb: dict[str, list[tuple[int, str]]] = field(default_factory=dict)
    _observable: dict[str, frozenset[str]] = field(default_factory=dict)
    _transitions: dict[tuple[int, int], tuple[Json, Json, Transition]] = field(default_factory=dict)

    @staticmethod
    def from_instance(instance: Mapping[str, Any]) -> "Context":
        sc = instance["scenario"]
        grid = sc["grid"]
        rows, cols, topo, radius = topology.grid_spec(grid)
        caps: dict[str, int] = {}
        for r in instance["recipes"].values():
            caps.update({k: int(v) for k, v in (r.get("resources") or {}).items()})
        caps.update({k: int(v) for k, v in (sc.get("resources") or {}).items()})
        prof = instance["profile"]
        ev = sc["evaluation"]
        real = instance["realization"]
        return Context(
            instance=dict(instance),
            recipes={rid: _recipe_info(r) for rid, r in instance["recipes"].items()},
            rows=rows,
            cols=cols,
            topology=topo,
            radius=int(radius),
            k_topo=topology.grid_k_topo(rows, cols, topo, int(radius)),
            capacities=caps,
            shelf_capacity=int(sc["shelves"]["capacity"]),
            support_timeout=int(sc["coordination"]["support_timeout"]),
            support_visible=bool(sc["coordination"].get("support_visible", True)),
            wip_cap=int(sc["release"]["wip_cap"]),
            interval=int(sc["release"]["interval"]),
            mode=ev["mode"],
            batch_size=ev.get("batch_size"),
            spacing=float(prof["spacing"]),
            reach=float(prof["reach"]),
            rho_conf=float(prof["rho_conf"]),
            clearance=float(prof["clearance"]),
            shelf_access={int(e["shelf_row"]): tuple(int(r) for r in e["robot_rows"]) for e in real["shelf_access"]},
            realization_products=list(real["products"]),
        )

    # ---- grid relations (D-TOPOLOGY)

    def manip_adjacent(self, a: str, b: str) -> bool:
        """G_manip adjacency of two robot ids."""
        return topology.adjacent(parse_cell(a), parse_cell(b), self.topology, self.radius)

    def direction_adjacent(self, a: str, b: str) -> bool:
        """G_handoff / G_obs adjacency: G_manip restricted to the eight direction cells (RES-RADIUS)."""
        ca, cb = parse_cell(a), parse_cell(b)
        return max(abs(ca[0] - cb[0]), abs(ca[1] - cb[1])) <= 1 and topology.adjacent(ca, cb, self.topology, self.radius)

    def in_grid(self, cell: tuple[int, int]) -> bool:
        return 0 <= cell[0] < self.rows and 0 <= cell[1] < self.cols

    def direction_neighbours(self, robot: str) -> list[tuple[int, str]]:
        """(direction index, robot id) of u's G_handoff / G_obs neighbours, in DIRECTIONS order."""
        cached = self._direction_nb.get(robot)
        if cached is None:
            cached = self._direction_nb[robot] = self._direction_neighbours(robot)
        return cached

    def _direction_neighbours(self, robot: str) -> list[tuple[int, str]]:
        c = parse_cell(robot)
        out = []
        for d, (di, dj) in enumerate(DIRECTIONS):
            n = (c[0] + di, c[1] + dj)
            if self.in_grid(n) and topology.adjacent(c, n, self.topology, self.radius):
                out.append((d, cell_id(n)))
        return out

    def capacity(self, resource: str) -> int:
        return self.capacities.get(resource, 1)

    def recipe_of(self, view: StateView, pid: int) -> RecipeInfo | None:
        p = view.products.get(pid)
        return self.recipes.get(p["recipe"]) if p is not None else None

    def terminal_item(self, view: StateView, pid: int) -> str | None:
        r = self.recipe_of(view, pid)
        return f"{pid}:{r.terminal}" if r else None

    # ---- cached derived data

    def view(self, state: Json) -> StateView:
        hit = self._views.get(id(state))
        if hit is not None and hit[0] is state:
            return hit[1]
        if len(self._views) > 8:
            self._views.clear()
        v = _view(state)
        self._views[id(state)] = (state, v)
        return v

    def transition(self, prev: Json, rec: Json) -> Transition:
        key = (id(prev), id(rec))
        hit = self._transitions.get(key)
        if hit is not None and hit[0] is prev and hit[1] is rec:
            return hit[2]
        if len(self._transitions) > 8:
            self._transitions.clear()
        tr = _transition(self, prev, rec)
        self._transitions[key] = (prev, rec, tr)
        return tr

    def count(self, invariant: str, n: int = 1) -> None:
        self.counts[invariant] += n


def _transition(ctx: Context, prev: Json, rec: Json) -> Transition:
    before, after = ctx.view(prev["state"]), ctx.view(rec["state"])
    t = int(rec.get("t", before.t))
    started: dict[str, Json] = {}
    for a in after.activities:
        if a.get("id") not in before.act_by_id:
            started[a.get("id")] = a
    # Activities that start and complete within this transition (D = 1) appear only as events; a
    # simulator that declares no events (record `events` null) has them derived from the two states
    # instead (F-CONFORM-LEVELS: an invariant never fails for data the simulator did not declare).
    if rec.get("events") is None:
        for act in _derived_activities(ctx, before, after, t):
            started.setdefault(act["id"], act)
    for ev in rec.get("events") or []:
        act = _activity_from_event(ctx, before, ev, t)
        if act is not None and act["id"] not in started:
            started[act["id"]] = act
    completing = []
    for a in before.activities:
        if int(a.get("end", 0)) <= t + 1:
            completing.append(_with_sender(a, before))
    for a in started.values():
        if int(a.get("end", 0)) <= t + 1 and a["id"] not in before.act_by_id:
            completing.append(_with_sender(a, before))
    return Transition(t=t, started=list(started.values()), completing=completing)


def _derived_activities(ctx: Context, before: StateView, after: StateView, t: int) -> list[Json]:
    """The D = 1 activities of a transition, derived from ``s_t`` and ``s_{t+1}`` alone (no events).

    Only changes that no activity of ``s_t`` or ``s_{t+1}`` explains are derived: an item that moved
    between two robots (a handoff), a raw token that appeared (a pick), a terminal item that left
    with its product's delivery (a delivery), an operation newly completed (an operation).
    """
    acts = before.activities + after.activities
    explained = {(a.get("kind"), a.get("item")) for a in acts if a.get("item") is not None}
    explained |= {("operation", a.get("product"), a.get("operation")) for a in acts if a.get("kind") == "operation"}
    was = {item: robots[0] for item, robots in before.holders.items()}
    now = {item: robots[0] for item, robots in after.holders.items()}
    base = {"start": t, "end": t + 1, "from_event": True, "derived": True}
    out: list[Json] = []
    for item in sorted(set(was) & set(now)):
        if was[item] != now[item] and ("handoff", item) not in explained:
            parsed = parse_item(item)
            out.append({**base, "id": f"derived:{t}:handoff:{item}", "kind": "handoff", "item": item,
                        "members": [was[item], now[item]], "sender": was[item], "receiver": now[item],
                        "product": parsed[0] if parsed else None, "resources": [f"token:{item}"]})
    for pid, p in sorted(after.products.items()):
        old = before.products.get(pid) or {}
        recipe = ctx.recipes.get(p.get("recipe"))
        for op in sorted(set(p.get("completed") or []) - set(old.get("completed") or [])):
            info = recipe.ops.get(op) if recipe else None
            if ("operation", pid, op) in explained or info is None:
                continue
            members = sorted({was[f"{pid}:{tok}"] for tok in info.inputs if f"{pid}:{tok}" in was}
                             | ({now[f"{pid}:{info.output}"]} if f"{pid}:{info.output}" in now else set()))
            out.append({**base, "id": f"derived:{t}:operation:{pid}:{op}", "kind": "operation", "members": members,
                        "product": pid, "operation": op})
        terminal = f"{pid}:{recipe.terminal}" if recipe else None
        if (p.get("delivered_at") is not None and old.get("delivered_at") is None and terminal in was
                and ("deliver", terminal) not in explained):
            out.append({**base, "id": f"derived:{t}:deliver:{pid}", "kind": "deliver", "members": [was[terminal]],
                        "product": pid, "item": terminal, "resources": [f"product:{pid}"]})
    for item in sorted(set(now) - set(was)):
        parsed = parse_item(item)
        recipe = ctx.recipe_of(after, parsed[0]) if parsed else None
        if recipe is not None and parsed[1] in recipe.raw and ("pick", item) not in explained:
            out.append({**base, "id": f"derived:{t}:pick:{item}", "kind": "pick", "members": [now[item]],
                        "product": parsed[0], "item": item, "resources": []})
    return out


def _with_sender(act: Json, before: StateView) -> Json:
    if act.get("kind") != "handoff" or "sender" in act:
        return act
    members = list(act.get("members", []))
    item = act.get("item")
    sender = next((m for m in members if (before.robots.get(m) or {}).get("holding") == item), members[0] if members else None)
    receiver = next((m for m in members if m != sender), None)
    return {**act, "sender": sender, "receiver": receiver}


def _activity_from_event(ctx: Context, before: StateView, ev: Json, t: int) -> Json | None:
    kind = ev.get("type")
    if "end" not in ev or "activity" not in ev:
        return None
    base = {"id": ev["activity"], "start": t, "end": int(ev["end"]), "from_event": True}
    if kind == "pick_started":
        return {**base, "kind": "pick", "members": [ev["robot"]], "product": ev["product"],
                "item": f"{ev['product']}:{ev['token']}", "resources": [f"shelf:{ev.get('shelf_row')}:{ev['token']}"],
                "shelf_row": ev.get("shelf_row")}
    if kind == "handoff_started":
        item = ev["item"]
        parsed = parse_item(item)
        return {**base, "kind": "handoff", "members": [ev["sender"], ev["receiver"]], "item": item,
                "product": parsed[0] if parsed else None, "sender": ev["sender"], "receiver": ev["receiver"],
                "resources": [f"token:{item}"]}
    if kind == "admitted":
        parsed = parse_candidate(ev.get("candidate", ""))
        if parsed is None:
            return None
        pid, op, members = parsed
        return {**base, "kind": "operation", "members": members, "product": pid, "operation": op,
                "candidate": ev["candidate"]}
    if kind == "delivery_started":
        pid = int(ev["product"])
        return {**base, "kind": "deliver", "members": [ev["robot"]], "product": pid,
                "item": ctx.terminal_item(before, pid), "resources": [f"product:{pid}"]}
    return None


def _tick_of(rec: Json) -> int:
    return int((rec.get("state") or {}).get("t", rec.get("t", 0)))


def _completed_ops(tr: Transition, pid: int) -> set[str]:
    return {a.get("operation") for a in tr.completing if a.get("kind") == "operation" and a.get("product") == pid}


# --------------------------------------------------------------------------- INV-CONSERVATION


def inv_conservation(ctx: Context, prev: Json | None, rec: Json) -> list[Violation]:
    """INV-CONSERVATION: every item has one consistent location; items appear only from a completed
    pick of a raw token or as a completed operation's declared output, and disappear only when
    consumed by their operation's completion or delivered (R-PICK, R-HANDOFF, R-COMPLETION,
    R-DELIVERY)."""
    ID = "INV-CONSERVATION"
    out: list[Violation] = []
    s = ctx.view(rec["state"])
    tick = s.t

    def bad(entity, msg):
        out.append(Violation(ID, tick, entity, msg))

    # 1. one location per item, consistent with `items`
    for rid, r in s.robots.items():
        h = r.get("holding")
        if isinstance(h, list):
            bad(rid, f"robot {rid} holds {len(h)} items {h}; a robot holds at most one item")
    for item, robots in s.holders.items():
        ctx.count(ID)
        if len(robots) > 1:
            bad(item, f"item {item} is held by {len(robots)} robots ({', '.join(sorted(robots))})")
        where = s.items.get(item)
        if where is None:
            bad(item, f"robot {robots[0]} holds {item}, but `items` does not list it")
        elif where not in robots:
            bad(item, f"`items` places {item} at robot {where}, but robot {robots[0]} holds it")
        parsed = parse_item(item)
        recipe = ctx.recipe_of(s, parsed[0]) if parsed else None
        if parsed is None or recipe is None:
            bad(item, f"item {item} does not belong to a released product")
        elif parsed[1] not in recipe.tokens:
            bad(item, f"item {item}: token `{parsed[1]}` is neither a raw material nor an operation output of "
                      f"recipe `{recipe.id}`")
    for item, where in s.items.items():
        if item not in s.holders:
            bad(item, f"`items` places {item} at robot {where}, but no robot holds it")
        if item in ctx.gone_items:
            bad(item, f"item {item} reappears after it disappeared at t={ctx.gone_items[item]}")
    if prev is None:
        return out

    # 2.-3. every change of the item set or of a holder is explained by a completion
    p = ctx.view(prev["state"])
    tr = ctx.transition(prev, rec)
    now = {item: robots[0] for item, robots in s.holders.items()}
    was = {item: robots[0] for item, robots in p.holders.items()}
    created: dict[str, Json] = {}
    consumed: dict[str, Json] = {}
    moved: dict[str, Json] = {}
    for a in tr.completing:
        ctx.count(ID)
        kind = a.get("kind")
        if kind == "pick":
            created[a.get("item")] = a
        elif kind == "handoff":
            moved[a.get("item")] = a
        elif kind == "deliver":
            consumed[a.get("item")] = a
        elif kind == "operation":
            recipe = ctx.recipe_of(p, a.get("product")) or ctx.recipe_of(s, a.get("product"))
            op = recipe.ops.get(a.get("operation")) if recipe else None
            if op is None:
                continue
            for tok in op.inputs:
                consumed[f"{a['product']}:{tok}"] = a
            created[f"{a['product']}:{op.output}"] = a
    for item in sorted(set(now) - set(was)):
        a = created.get(item)
        if a is None:
            bad(item, f"item {item} appeared at robot {now[item]} without a completing pick or operation "
                      "that produces it")
            continue
        if item in consumed and consumed[item] is not a:
            bad(item, f"item {item} appeared while it should have been consumed by {consumed[item].get('id')}")
        if now[item] not in a.get("members", []):
            bad(item, f"item {item} produced by {a.get('id')} is held by {now[item]}, not by a member "
                      f"({', '.join(a.get('members', []))})")
        if a.get("kind") == "pick":
            parsed = parse_item(item)
            recipe = ctx.recipe_of(s, parsed[0]) if parsed else None
            if recipe is None or parsed[1] not in recipe.raw:
                bad(item, f"pick {a.get('id')} produced {item}, which is not a raw token of its product")
    for item in sorted(set(was) - set(now)):
        if item not in consumed:
            bad(item, f"item {item} held by {was[item]} disappeared without being consumed by a completing "
                      "operation or delivered")
        ctx.gone_items.setdefault(item, tick)
    for item, a in consumed.items():
        if a.get("kind") == "operation" and item in now and created.get(item) is not a:
            bad(item, f"operation {a.get('id')} completed but its input {item} still exists (at {now[item]})")
    for item, a in created.items():
        if a.get("kind") == "operation" and item not in now:
            bad(item, f"operation {a.get('id')} completed but its output {item} does not exist")
    for item in sorted(set(was) & set(now)):
        if was[item] == now[item]:
            continue
        a = moved.get(item)
        if a is None:
            bad(item, f"item {item} moved from {was[item]} to {now[item]} without a completing handoff")
        elif (a.get("sender"), a.get("receiver")) != (was[item], now[item]):
            bad(item, f"item {item} moved from {was[item]} to {now[item]}, but handoff {a.get('id')} goes from "
                      f"{a.get('sender')} to {a.get('receiver')}")
    for item, a in moved.items():
        if item in now and now[item] != a.get("receiver"):
            bad(item, f"handoff {a.get('id')} completed but {item} is at {now[item]}, not at its receiver "
                      f"{a.get('receiver')}")
    return out


# --------------------------------------------------------------------------- INV-SUPPORT


def inv_support(ctx: Context, prev: Json | None, rec: Json) -> list[Violation]:
    """INV-SUPPORT: supporting or committing never creates a second owner (R-SUPPORT,
    R-SUPPORT-LIFECYCLE, R-EXPIRY, R-HELD-MATERIAL): one item per robot, one robot per item, a handoff
    in flight keeps its single owner, support records are consistent and support never moves material."""
    ID = "INV-SUPPORT"
    out: list[Violation] = []
    s = ctx.view(rec["state"])
    tick = s.t

    def bad(entity, msg):
        out.append(Violation(ID, tick, entity, msg))

    for rid, r in s.robots.items():
        if isinstance(r.get("holding"), list) and len(r["holding"]) > 1:
            bad(rid, f"robot {rid} owns {len(r['holding'])} items at once")
    for item, robots in s.holders.items():
        if len(robots) > 1:
            bad(item, f"item {item} has {len(robots)} owners ({', '.join(sorted(robots))}); support or "
                      "commitment must not create a second owner")
    # a handoff in flight keeps exactly one owner: the sender
    for a in s.activities:
        if a.get("kind") != "handoff":
            continue
        ctx.count(ID)
        item = a.get("item")
        owners = s.holders.get(item, [])
        members = a.get("members", [])
        if len(owners) != 1 or owners[0] not in members:
            bad(a.get("id"), f"handoff {a.get('id')} in flight: {item} is owned by {owners or 'nobody'}, expected "
                             f"exactly one member")
            continue
        for m in members:
            if m != owners[0]:
                r = s.robots.get(m) or {}
                if r.get("holding") is not None:
                    bad(m, f"receiver {m} of handoff {a.get('id')} already holds {r.get('holding')}")
                if r.get("incoming") not in (None, item):
                    bad(m, f"receiver {m} of handoff {a.get('id')} expects {r.get('incoming')}, not {item}")
    for rid, r in s.robots.items():
        if r.get("incoming") is not None:
            acts = [s.act_by_id.get(aid) for aid in s.membership.get(rid, [])]
            if not any(x and x.get("kind") == "handoff" and x.get("item") == r["incoming"] for x in acts):
                bad(rid, f"robot {rid} expects incoming {r['incoming']} without a handoff in flight")
    # during an operation every input is held by exactly one member
    for a in s.activities:
        if a.get("kind") != "operation":
            continue
        recipe = ctx.recipe_of(s, a.get("product"))
        op = recipe.ops.get(a.get("operation")) if recipe else None
        if op is None:
            continue
        for tok in op.inputs:
            item = f"{a['product']}:{tok}"
            owners = s.holders.get(item, [])
            if len(owners) != 1 or owners[0] not in a.get("members", []):
                bad(a.get("id"), f"operation {a.get('id')}: input {item} is held by {owners or 'nobody'}, "
                                 "expected exactly one coalition member")
    # support records (R-SUPPORT-LIFECYCLE)
    for cid, pr in s.proposals.items():
        ctx.count(ID)
        parsed = parse_candidate(cid)
        members = set(parsed[2]) if parsed else set()
        created, expires = pr.get("created_at"), pr.get("expires_at")
        if created is None or expires is None or expires != created + ctx.support_timeout:
            bad(cid, f"support record {cid}: expires_at {expires} != created_at {created} + timeout "
                     f"{ctx.support_timeout}")
        elif not (created < tick <= expires):
            bad(cid, f"support record {cid} created at {created}, expiring at {expires}, still exists at t={tick}")
        for sup in pr.get("supporters", []):
            if parsed is not None and sup not in members:
                bad(cid, f"robot {sup} supports {cid} but is not one of its members")
            if (s.robots.get(sup) or {}).get("supports") != cid:
                bad(sup, f"robot {sup} is listed as a supporter of {cid} but its pending support is "
                         f"{(s.robots.get(sup) or {}).get('supports')}")
    for rid, r in s.robots.items():
        cid = r.get("supports")
        if cid is None:
            continue
        pr = s.proposals.get(cid)
        if pr is None or rid not in pr.get("supporters", []):
            bad(rid, f"robot {rid} supports {cid}, but no support record lists it")
        if s.membership.get(rid):
            bad(rid, f"robot {rid} is committed to {s.membership[rid]} and still supports {cid}")
    if prev is None:
        return out
    # support never moves material: supporters and committed members change their item only through
    # a completion of an activity they belong to
    p = ctx.view(prev["state"])
    tr = ctx.transition(prev, rec)
    completing_members = {m for a in tr.completing for m in a.get("members", [])}
    for rid, r in p.robots.items():
        if r.get("supports") is None and not p.membership.get(rid):
            continue
        ctx.count(ID)
        after = (s.robots.get(rid) or {}).get("holding")
        if after != r.get("holding") and rid not in completing_members:
            what = f"supports {r.get('supports')}" if r.get("supports") else f"is committed to {p.membership[rid]}"
            bad(rid, f"robot {rid} {what} at t={p.t}, yet its item changed from {r.get('holding')} to {after} "
                     "without a completion of its own activity")
    return out


# --------------------------------------------------------------------------- INV-PROGRESS


def inv_progress(ctx: Context, prev: Json | None, rec: Json) -> list[Violation]:
    """INV-PROGRESS: completed operation sets only grow, and only by the operations completing in the
    transition; XOR choices and deliveries are never undone (R-COMPLETION, R-XOR-CLOSURE)."""
    ID = "INV-PROGRESS"
    out: list[Violation] = []
    if prev is None:
        s = ctx.view(rec["state"])
        for pid, prod in s.products.items():
            ctx.count(ID)
            if prod.get("completed") or prod.get("delivered_at") is not None:
                out.append(Violation(ID, s.t, str(pid), f"product {pid} starts with progress {prod.get('completed')}"))
        return out
    p, s = ctx.view(prev["state"]), ctx.view(rec["state"])
    tr = ctx.transition(prev, rec)
    tick = s.t
    for pid, before in p.products.items():
        ctx.count(ID)
        after = s.products.get(pid)
        if after is None:
            out.append(Violation(ID, tick, str(pid), f"released product {pid} vanished from the state"))
            continue
        lost = set(before.get("completed", [])) - set(after.get("completed", []))
        if lost:
            out.append(Violation(ID, tick, str(pid), f"product {pid}: completed operation(s) {sorted(lost)} were "
                                                    "removed; progress is monotone"))
        gained = set(after.get("completed", [])) - set(before.get("completed", []))
        expected = _completed_ops(tr, pid)
        if gained != expected:
            out.append(Violation(ID, tick, str(pid), f"product {pid}: operations {sorted(gained)} became completed, "
                                                    f"but the completing operation activities are {sorted(expected)}"))
        for group, choice in (before.get("xor") or {}).items():
            if (after.get("xor") or {}).get(group) != choice:
                out.append(Violation(ID, tick, str(pid), f"product {pid}: XOR choice {group}={choice} changed to "
                                                        f"{(after.get('xor') or {}).get(group)}"))
        if before.get("delivered_at") is not None and after.get("delivered_at") != before.get("delivered_at"):
            out.append(Violation(ID, tick, str(pid), f"product {pid} was delivered at {before['delivered_at']}; "
                                                    f"now delivered_at = {after.get('delivered_at')}"))
    return out


# --------------------------------------------------------------------------- INV-RECIPE


def inv_recipe(ctx: Context, prev: Json | None, rec: Json) -> list[Violation]:
    """INV-RECIPE: completed and executing sets are disjoint, predecessors and XOR groups are respected,
    in-progress matches the operation activities, and delivery happens only after the terminal output
    exists (R-READY, R-ADMISSION, R-COMPLETION, R-XOR-CLOSURE, R-DELIVERY)."""
    ID = "INV-RECIPE"
    out: list[Violation] = []
    s = ctx.view(rec["state"])
    tick = s.t
    running: dict[int, list[str]] = {}
    for a in s.activities:
        if a.get("kind") == "operation":
            running.setdefault(a.get("product"), []).append(a.get("operation"))
    for pid, prod in s.products.items():
        ctx.count(ID)
        recipe = ctx.recipes.get(prod.get("recipe"))
        if recipe is None:
            out.append(Violation(ID, tick, str(pid), f"product {pid} has unknown recipe {prod.get('recipe')!r}"))
            continue
        done, doing = set(prod.get("completed", [])), set(prod.get("in_progress", []))
        xor = prod.get("xor") or {}

        def bad(msg):
            out.append(Violation(ID, tick, str(pid), f"product {pid} ({recipe.id}): {msg}"))

        if done & doing:
            bad(f"operations {sorted(done & doing)} are both completed and in progress")
        for op_id in sorted(done | doing):
            op = recipe.ops.get(op_id)
            if op is None:
                bad(f"unknown operation `{op_id}`")
                continue
            for pred in op.after:
                if pred in recipe.groups:
                    chosen = xor.get(pred)
                    if chosen is None or chosen not in done:
                        bad(f"`{op_id}` runs after XOR group `{pred}`, whose chosen alternative ({chosen}) is not "
                            "completed")
                elif pred not in done:
                    bad(f"`{op_id}` is {'completed' if op_id in done else 'in progress'} but its predecessor "
                        f"`{pred}` is not completed")
        for gid, alts in recipe.groups.items():
            used = [a for a in alts if a in done | doing]
            if len(used) > 1:
                bad(f"XOR group `{gid}` has several alternatives executed: {used}")
            elif used and xor.get(gid) != used[0]:
                bad(f"XOR group `{gid}`: alternative `{used[0]}` executed but the recorded choice is {xor.get(gid)}")
        for gid in xor:
            if gid not in recipe.groups:
                bad(f"XOR choice for unknown group `{gid}`")
        if sorted(doing) != sorted(running.get(pid, [])):
            bad(f"in progress {sorted(doing)} but operation activities for {sorted(running.get(pid, []))}")
        if prod.get("delivered_at") is not None:
            producers = recipe.producers(recipe.terminal)
            if not any(op in done for op in producers):
                bad(f"delivered at {prod['delivered_at']} although no operation producing `{recipe.terminal}` "
                    "completed")
            if f"{pid}:{recipe.terminal}" in s.holders:
                bad(f"delivered but its terminal item is still held by {s.holders[f'{pid}:{recipe.terminal}']}")
            if prod["delivered_at"] > tick:
                bad(f"delivered_at {prod['delivered_at']} lies in the future of t={tick}")
    for a in s.activities:
        if a.get("kind") != "deliver":
            continue
        pid = a.get("product")
        recipe = ctx.recipe_of(s, pid)
        if recipe is None:
            continue
        item = f"{pid}:{recipe.terminal}"
        prod = s.products[pid]
        if a.get("item") not in (None, item) or s.holders.get(item, [None])[0] not in a.get("members", []):
            out.append(Violation(ID, tick, a.get("id"), f"delivery {a.get('id')} of product {pid} does not carry its "
                                                       f"terminal item {item}"))
        if not any(op in prod.get("completed", []) for op in recipe.producers(recipe.terminal)):
            out.append(Violation(ID, tick, a.get("id"), f"delivery {a.get('id')} started before product {pid}'s "
                                                       "terminal operation completed"))
    return out


# --------------------------------------------------------------------------- INV-LOCALITY


def inv_locality(ctx: Context, prev: Json | None, rec: Json) -> list[Violation]:
    """INV-LOCALITY: operation members are pairwise adjacent in G_manip; handoff partners adjacent in
    G_handoff; picks from column 0 with shelf access; deliveries from column N-1 (R-CANDIDATES, R-PICK,
    R-HANDOFF, R-DELIVERY)."""
    ID = "INV-LOCALITY"
    out: list[Violation] = []
    s = ctx.view(rec["state"])
    acts = list(s.activities)
    if prev is not None:  # activities living less than one tick are seen only in the transition
        acts += [a for a in ctx.transition(prev, rec).started if a.get("from_event")]
    for a in acts:
        ctx.count(ID)
        kind, members, aid = a.get("kind"), list(a.get("members", [])), a.get("id")
        if kind == "operation":
            for i, u in enumerate(members):
                for v in members[i + 1:]:
                    if not ctx.manip_adjacent(u, v):
                        out.append(Violation(ID, s.t, aid, f"coalition of {aid}: members {u} and {v} are not adjacent "
                                                           f"in G_manip ({ctx.topology}, radius {ctx.radius})"))
        elif kind == "handoff":
            if len(members) != 2 or not ctx.direction_adjacent(members[0], members[1]):
                out.append(Violation(ID, s.t, aid, f"handoff {aid} between {members} is not between G_handoff "
                                                   f"neighbours ({ctx.topology})"))
        elif kind == "pick":
            cell = parse_cell(members[0])
            row = a.get("shelf_row")
            if row is None:
                for r in a.get("resources", []):
                    if r.startswith("shelf:"):
                        row = int(r.split(":")[1])
            if cell[1] != 0:
                out.append(Violation(ID, s.t, aid, f"pick {aid} by {members[0]}, which is not in the input column"))
            elif row is not None and cell[0] not in ctx.shelf_access.get(int(row), ()):
                out.append(Violation(ID, s.t, aid, f"pick {aid}: robot row {cell[0]} has no access to shelf row {row}"))
        elif kind == "deliver":
            if parse_cell(members[0])[1] != ctx.cols - 1:
                out.append(Violation(ID, s.t, aid, f"delivery {aid} by {members[0]}, which is not in the output "
                                                   f"column {ctx.cols - 1}"))
    return out


# --------------------------------------------------------------------------- INV-LIFETIME


def _signature(a: Json) -> tuple:
    return (
        a.get("kind"),
        tuple(a.get("members", [])),
        tuple(sorted((a.get("roles") or {}).items())),
        a.get("operation"),
        a.get("product"),
        a.get("candidate"),
        a.get("item"),
        tuple(sorted(a.get("resources", []))),
        a.get("start"),
        a.get("end"),
    )


_SIGNATURE_FIELDS = ("kind", "members", "roles", "operation", "product", "candidate", "item", "resources", "start", "end")


def inv_lifetime(ctx: Context, prev: Json | None, rec: Json) -> list[Violation]:
    """INV-LIFETIME: members, roles, operation (and every other attribute) of an activity id never
    change while it exists; it ends exactly at its end epoch (R-ADMISSION, R-EXECUTION, R-COMPLETION)."""
    ID = "INV-LIFETIME"
    out: list[Violation] = []
    s = ctx.view(rec["state"])
    tick = s.t
    for a in s.activities:
        ctx.count(ID)
        aid = a.get("id")
        sig = _signature(a)
        first = ctx.lifetime.get(aid)
        if aid in ctx.lifetime_gone:
            out.append(Violation(ID, tick, aid, f"activity {aid} reappears after it ended"))
        if first is None:
            ctx.lifetime[aid] = sig
        elif first != sig:
            changed = [f"{name}: {x!r} -> {y!r}" for name, x, y in zip(_SIGNATURE_FIELDS, first, sig) if x != y]
            out.append(Violation(ID, tick, aid, f"activity {aid} changed while committed ({'; '.join(changed)})"))
        start, end = a.get("start"), a.get("end")
        if not (isinstance(start, int) and isinstance(end, int) and start < tick < end):
            out.append(Violation(ID, tick, aid, f"activity {aid} [{start}, {end}) is listed at t={tick}"))
    if prev is None:
        return out
    p = ctx.view(prev["state"])
    t = int(rec.get("t", p.t))
    for aid, a in p.act_by_id.items():
        gone = aid not in s.act_by_id
        if gone:
            ctx.lifetime_gone.add(aid)
        if gone != (int(a.get("end", 0)) == t + 1):
            out.append(Violation(ID, tick, aid, f"activity {aid} with end {a.get('end')} "
                                                f"{'ended' if gone else 'is still listed'} at t={tick}"))
    for aid, a in s.act_by_id.items():
        if aid not in p.act_by_id and a.get("start") != t:
            out.append(Violation(ID, tick, aid, f"activity {aid} first appears at t={tick} but claims start "
                                                f"{a.get('start')} (expected {t})"))
    return out


# --------------------------------------------------------------------------- INV-ARITY


def canonical_roles(op: OpInfo, members: list[str], holder_of: Mapping[str, str]) -> dict[str, str] | None:
    """RC-ROLES / R-ROLE-ASSIGNMENT: bound roles to the holders of their inputs, the remaining roles in
    declaration order to the remaining members in row-major order; None if a bound role cannot go to a
    member."""
    assigned: dict[str, str] = {}
    for name, binds in op.roles:
        if binds is None:
            continue
        holder = holder_of.get(binds)
        if holder is None or holder not in members or holder in assigned:
            return None
        assigned[holder] = name
    free = [name for name, binds in op.roles if binds is None]
    rest = sorted((m for m in members if m not in assigned), key=parse_cell)
    for k, m in enumerate(rest):
        assigned[m] = free[k] if k < len(free) else f"helper_extra_{k}"
    return assigned


def inv_arity(ctx: Context, prev: Json | None, rec: Json) -> list[Violation]:
    """INV-ARITY: k_min <= |members| <= min(k_max, k_topo), roles cover exactly the members, and a new
    activity's roles are the canonical assignment computed from the state before its admission
    (R-ROLE-ASSIGNMENT, R-ADMISSION)."""
    ID = "INV-ARITY"
    out: list[Violation] = []
    s = ctx.view(rec["state"])
    tick = s.t
    p = ctx.view(prev["state"]) if prev is not None else None
    for a in s.activities:
        if a.get("kind") != "operation":
            continue
        ctx.count(ID)
        aid = a.get("id")
        members = list(a.get("members", []))
        recipe = ctx.recipe_of(s, a.get("product"))
        op = recipe.ops.get(a.get("operation")) if recipe else None
        if op is None:
            out.append(Violation(ID, tick, aid, f"activity {aid} executes unknown operation {a.get('operation')!r}"))
            continue
        cap = min(op.kmax, ctx.k_topo)
        if not (op.kmin <= len(members) <= cap):
            out.append(Violation(ID, tick, aid, f"{aid} has {len(members)} members; `{op.id}` needs "
                                                f"{op.kmin}..min({op.kmax}, k_topo={ctx.k_topo}) = {op.kmin}..{cap}"))
        if len(set(members)) != len(members):
            out.append(Violation(ID, tick, aid, f"{aid} lists a member twice: {members}"))
        if members != sorted(members, key=parse_cell):
            out.append(Violation(ID, tick, aid, f"{aid}: members {members} are not in row-major order"))
        cand = a.get("candidate")
        if cand is not None:
            parsed = parse_candidate(cand)
            if parsed is None or parsed[0] != a.get("product") or parsed[1] != op.id or parsed[2] != members:
                out.append(Violation(ID, tick, aid, f"{aid} executes candidate {cand}, whose key does not match "
                                                    f"product {a.get('product')}, `{op.id}`, members {members}"))
        roles = dict(a.get("roles") or {})
        if set(roles) != set(members):
            out.append(Violation(ID, tick, aid, f"{aid}: roles are given for {sorted(roles)}, members are {members}"))
        names = list(roles.values())
        declared = {name for name, _ in op.roles}
        if len(set(names)) != len(names):
            out.append(Violation(ID, tick, aid, f"{aid}: a role is assigned twice: {sorted(names)}"))
        for n in names:
            if n not in declared and not n.startswith("helper_extra_"):
                out.append(Violation(ID, tick, aid, f"{aid}: role `{n}` is not declared by `{op.id}`"))
        if p is not None and aid not in p.act_by_id:
            # a new activity: roles must be the canonical assignment at the pre-admission state s_t
            holder_of = {tok: p.items.get(f"{a['product']}:{tok}") for tok in op.inputs}
            expected = canonical_roles(op, members, {k: v for k, v in holder_of.items() if v is not None})
            if expected is None:
                out.append(Violation(ID, tick, aid, f"{aid}: the bound roles of `{op.id}` cannot be filled by the "
                                                    f"members {members} (input holders at t={p.t}: {holder_of})"))
            elif expected != roles:
                out.append(Violation(ID, tick, aid, f"{aid}: roles {dict(sorted(roles.items()))} differ from the "
                                                    f"canonical assignment {dict(sorted(expected.items()))}"))
    return out


# --------------------------------------------------------------------------- INV-EXCLUSIVITY


def _target_distance(a: Json, b: Json) -> float | None:
    ta, tb = a.get("target"), b.get("target")
    if not (isinstance(ta, list) and isinstance(tb, list) and len(ta) == 2 and len(tb) == 2):
        return None
    return math.hypot(ta[0] - tb[0], ta[1] - tb[1])


def inv_exclusivity(ctx: Context, prev: Json | None, rec: Json) -> list[Violation]:
    """INV-EXCLUSIVITY: no robot in two activities; a robot is busy iff committed; exclusive resources
    are never shared and finite ones never exceed capacity (default 1); shelf stock stays within
    [0, capacity]; committed activities' targets keep the G-CONFLICT distance; new activities start on
    free robots (R-PICK, R-HANDOFF, R-ADMISSION, R-BLOCKING, R-DELIVERY, R-EXECUTION, R-REPLENISH)."""
    ID = "INV-EXCLUSIVITY"
    out: list[Violation] = []
    s = ctx.view(rec["state"])
    tick = s.t

    def bad(entity, msg):
        out.append(Violation(ID, tick, entity, msg))

    for rid, r in s.robots.items():
        ctx.count(ID)
        acts = s.membership.get(rid, [])
        if len(acts) > 1:
            bad(rid, f"robot {rid} is committed to {len(acts)} activities at once: {acts}")
        busy = int(r.get("busy_until") or 0) > tick
        if busy and not acts:
            bad(rid, f"robot {rid} is busy until {r.get('busy_until')} without an activity")
        if acts:
            a = s.act_by_id[acts[0]]
            if r.get("busy_until") != a.get("end"):
                bad(rid, f"robot {rid} is committed to {acts[0]} ending at {a.get('end')} but busy until "
                         f"{r.get('busy_until')}")
            if "activity" in r and r.get("activity") != acts[0]:
                bad(rid, f"robot {rid} records activity {r.get('activity')} but is a member of {acts[0]}")
    usage: dict[str, list[str]] = {}
    for a in s.activities:
        for res in set(a.get("resources", [])):
            usage.setdefault(res, []).append(a.get("id"))
    for res, users in usage.items():
        ctx.count(ID)
        if len(users) > ctx.capacity(res):
            bad(res, f"resource {res} (capacity {ctx.capacity(res)}) is held by {len(users)} activities: {users}")
    for row, shelf in enumerate(s.shelves):
        for tok, stock in shelf.items():
            ctx.count(ID)
            if not (isinstance(stock, int) and 0 <= stock <= ctx.shelf_capacity):
                bad(f"shelf:{row}:{tok}", f"shelf row {row} holds {stock!r} units of {tok}, outside "
                                          f"[0, {ctx.shelf_capacity}]")
    limit = ctx.rho_conf + ctx.clearance - CONFLICT_TOLERANCE  # G-CONFLICT, target part
    for i, a in enumerate(s.activities):
        for b in s.activities[i + 1:]:
            d = _target_distance(a, b)
            if d is not None and d < limit:
                bad(a.get("id"), f"committed activities {a.get('id')} and {b.get('id')} have targets {d:.3f} apart, "
                                 f"closer than the conflict distance {ctx.rho_conf + ctx.clearance:.3f}")
    if prev is None:
        return out
    p = ctx.view(prev["state"])
    tr = ctx.transition(prev, rec)
    starts: Counter = Counter()
    for a in tr.started:
        for m in a.get("members", []):
            starts[m] += 1
            if not p.free(m):
                bad(m, f"robot {m} starts {a.get('id')} at t={tr.t} although it was not free "
                       f"(busy until {(p.robots.get(m) or {}).get('busy_until')})")
    for m, n in starts.items():
        if n > 1:
            bad(m, f"robot {m} starts {n} activities in the same transition at t={tr.t}")
    return out


# --------------------------------------------------------------------------- INV-OBSERVATION


def _held_view(ctx: Context, view: StateView, item: str | None) -> Json | None:
    if item is None:
        return None
    parsed = parse_item(item)
    if parsed is None:
        return {"item": item}
    recipe = ctx.recipe_of(view, parsed[0])
    return {"product": parsed[0], "token": parsed[1], "final": bool(recipe and parsed[1] == recipe.terminal)}


def expected_pick_ids(ctx: Context, view: StateView, robot: str) -> list[str]:
    """O-PICK-OPTIONS recomputed from the state: ids in (release epoch, id string) order."""
    r = view.robots.get(robot) or {}
    cell = parse_cell(robot)
    if cell[1] != 0 or not view.free(robot) or r.get("holding") is not None or r.get("supports") is not None:
        return []
    options = []
    for pid, prod in view.products.items():
        if prod.get("delivered_at") is not None:
            continue
        recipe = ctx.recipes.get(prod.get("recipe"))
        if recipe is None or pid >= len(ctx.realization_products):
            continue
        xor = prod.get("xor") or {}
        needed = {tok for op in recipe.ops.values()
                  if not (op.xor_group and xor.get(op.xor_group) not in (None, op.id)) for tok in op.inputs}
        sources = ctx.realization_products[pid].get("source_rows", {})
        for tok in recipe.raw:
            if tok in prod.get("raw_taken", []) or tok not in needed or tok not in sources:
                continue
            row = int(sources[tok])
            stock = (view.shelves[row] if row < len(view.shelves) else {}).get(tok, 0)
            if cell[0] not in ctx.shelf_access.get(row, ()) or stock <= 0:
                continue
            if math.hypot(0.5 * ctx.spacing, (row - cell[0]) * ctx.spacing) > ctx.reach + REACH_TOLERANCE:
                continue
            options.append((prod.get("released_at", 0), f"pick:{pid}:{tok}:{row}"))
    return [oid for _, oid in sorted(options)]


def _mentioned_robots(obs: Json) -> set[str]:
    out = set()
    if isinstance(obs.get("robot"), str):
        out.add(obs["robot"])
    for nb in obs.get("neighbours") or []:
        if isinstance(nb, dict) and isinstance(nb.get("robot"), str):
            out.add(nb["robot"])
    for opt in obs.get("operation_options") or []:
        if not isinstance(opt, dict):
            continue
        out.update(m for m in opt.get("members") or [] if isinstance(m, str))
        parsed = parse_candidate(str(opt.get("id", "")))
        if parsed:
            out.update(parsed[2])
    if isinstance(obs.get("supports"), str):
        parsed = parse_candidate(obs["supports"])
        if parsed:
            out.update(parsed[2])
    return out


def inv_observation(ctx: Context, prev: Json | None, rec: Json) -> list[Violation]:
    """INV-OBSERVATION: an observation carries exactly the O-OBSERVATION fields of the robot itself, its
    G_obs neighbours (as in the pre-action state) and its own options; operation options contain the
    robot and show support fractions |supporters| / |U_c| of the pre-action state; no supporter
    identities, due dates or remote robots (chapter 6, O-EXPOSURE, O-SUPPORT-FRACTION)."""
    ID = "INV-OBSERVATION"
    observations = rec.get("observations")
    if prev is None:
        return []
    if not observations:
        ctx.skipped.setdefault(ID, "the trace carries no observations")
        return []
    out: list[Violation] = []
    p = ctx.view(prev["state"])
    t = int(rec.get("t", p.t))

    def bad(entity, msg):
        out.append(Violation(ID, t, entity, msg))

    all_options: dict[str, set[str]] = {}
    for robot, obs in observations.items():
        ctx.count(ID)
        if not isinstance(obs, dict):
            bad(robot, f"observation of {robot} is not an object")
            continue
        keys = set(obs)
        if keys != OBS_FIELDS:
            extra, missing = sorted(keys - OBS_FIELDS), sorted(OBS_FIELDS - keys)
            bad(robot, f"observation of {robot} has fields outside O-OBSERVATION {extra} / lacks {missing}")
        r = p.robots.get(robot)
        if r is None:
            bad(robot, f"observation for unknown robot {robot}")
            continue
        if obs.get("robot") != robot or obs.get("t") != t or obs.get("grid") != [ctx.rows, ctx.cols]:
            bad(robot, f"observation of {robot} is labelled robot={obs.get('robot')} t={obs.get('t')} "
                       f"grid={obs.get('grid')} (expected {robot}, {t}, {[ctx.rows, ctx.cols]})")
        if obs.get("holding") != _held_view(ctx, p, r.get("holding")):
            bad(robot, f"{robot} observes its holding as {obs.get('holding')}, the state has {r.get('holding')}")
        if obs.get("busy") != (not p.free(robot)):
            bad(robot, f"{robot} observes busy={obs.get('busy')}, the state says {not p.free(robot)}")
        if obs.get("supports") != r.get("supports"):
            bad(robot, f"{robot} observes its support as {obs.get('supports')}, the state has {r.get('supports')}")
        # neighbours: exactly the G_obs neighbours, with their state of s_t
        expected_nb = {nid: DIRECTION_NAMES[d] for d, nid in ctx.direction_neighbours(robot)}
        seen_nb = []
        for nb in obs.get("neighbours") or []:
            if not isinstance(nb, dict):
                bad(robot, f"{robot}: malformed neighbour entry {nb!r}")
                continue
            nid = nb.get("robot")
            seen_nb.append(nid)
            if set(nb) != NEIGHBOUR_FIELDS:
                bad(robot, f"{robot}: neighbour entry {nid} has fields {sorted(nb)}, expected {sorted(NEIGHBOUR_FIELDS)}")
            if nid not in expected_nb:
                bad(robot, f"{robot} observes robot {nid}, which is not its G_obs neighbour")
                continue
            if nb.get("dir") != expected_nb[nid]:
                bad(robot, f"{robot}: neighbour {nid} is labelled direction {nb.get('dir')}, expected {expected_nb[nid]}")
            nr = p.robots.get(nid) or {}
            if nb.get("holding") != _held_view(ctx, p, nr.get("holding")):
                bad(robot, f"{robot} observes {nid} holding {nb.get('holding')}, the state has {nr.get('holding')}")
            if nb.get("busy") != (not p.free(nid)):
                bad(robot, f"{robot} observes {nid} busy={nb.get('busy')}, the state says {not p.free(nid)}")
            if (nb.get("op") is None) != p.free(nid):
                bad(robot, f"{robot} observes {nid} with activity label {nb.get('op')!r} although it is "
                           f"{'free' if p.free(nid) else 'busy'}")
        if sorted(seen_nb, key=str) != sorted(expected_nb) or len(seen_nb) != len(set(seen_nb)):
            bad(robot, f"{robot} observes neighbours {seen_nb}, expected exactly {sorted(expected_nb)}")
        # operation options (O-OPERATION-OPTIONS, O-SUPPORT-FRACTION)
        ids = []
        keys_order = []
        for opt in obs.get("operation_options") or []:
            if not isinstance(opt, dict):
                bad(robot, f"{robot}: malformed operation option {opt!r}")
                continue
            cid = str(opt.get("id"))
            ids.append(cid)
            if set(opt) != OPERATION_OPTION_FIELDS:
                bad(cid, f"{robot}: option {cid} has fields {sorted(opt)}, expected {sorted(OPERATION_OPTION_FIELDS)}")
            parsed = parse_candidate(cid)
            if parsed is None:
                bad(cid, f"{robot}: option id {cid!r} is not a candidate id")
                continue
            pid, op_id, members = parsed
            if robot not in members or opt.get("members") != members:
                bad(cid, f"{robot} is offered {cid} with members {opt.get('members')}, which does not contain it "
                         "or does not match the id")
            if opt.get("size") != len(members) or opt.get("product") != pid or opt.get("operation") != op_id:
                bad(cid, f"{robot}: option {cid} reports size {opt.get('size')}, product {opt.get('product')}, "
                         f"operation {opt.get('operation')}, inconsistent with its id")
            pr = p.proposals.get(cid)
            expected = (len(pr.get("supporters", [])) / len(members)) if (pr and members and ctx.support_visible) else 0.0
            got = opt.get("support")
            if not isinstance(got, (int, float)) or abs(got - expected) > SUPPORT_TOLERANCE:
                bad(cid, f"{robot}: support fraction of {cid} is {got}, the pre-action state gives {expected}")
            keys_order.append((-(got if isinstance(got, (int, float)) else 0.0), cid))
        if keys_order != sorted(keys_order):
            bad(robot, f"{robot}: operation options are not ordered by (-support, id): {ids}")
        all_options[robot] = set(ids)
        # pick options (O-PICK-OPTIONS)
        picks = [o.get("id") if isinstance(o, dict) else o for o in obs.get("pick_options") or []]
        for o in obs.get("pick_options") or []:
            if isinstance(o, dict) and set(o) != PICK_OPTION_FIELDS:
                bad(robot, f"{robot}: pick option {o.get('id')} has fields {sorted(o)}, expected "
                           f"{sorted(PICK_OPTION_FIELDS)}")
        expected_picks = expected_pick_ids(ctx, p, robot)
        if picks != expected_picks:
            bad(robot, f"{robot}: pick options {picks}, O-PICK-OPTIONS gives {expected_picks}")
        # nothing about remote robots
        remote = sorted(_mentioned_robots(obs) - _observable_ids(ctx, robot))
        if remote:
            bad(robot, f"observation of {robot} mentions remote robot(s) {remote}")
    # O-EXPOSURE: the same key gives every member the same candidate
    for robot, ids in all_options.items():
        for cid in ids:
            parsed = parse_candidate(cid)
            for m in parsed[2] if parsed else []:
                if m in all_options and cid not in all_options[m]:
                    bad(cid, f"candidate {cid} is offered to {robot} but not to its member {m}")
    return out


def _observable_ids(ctx: Context, robot: str) -> frozenset[str]:
    """Robots an observation of ``robot`` may mention: itself, its G_obs neighbours and its G_manip
    neighbours (co-members of its candidates); memoized, the grid is static."""
    cached = ctx._observable.get(robot)
    if cached is None:
        ids = {robot} | {nid for _, nid in ctx.direction_neighbours(robot)}
        cached = ctx._observable[robot] = frozenset(ids | {cell_id(c) for c in _manip_neighbours(ctx, robot)})
    return cached


def _manip_neighbours(ctx: Context, robot: str) -> list[tuple[int, int]]:
    c = parse_cell(robot)
    r = ctx.radius
    out = []
    for i in range(c[0] - r, c[0] + r + 1):
        for j in range(c[1] - r, c[1] + r + 1):
            if (i, j) != c and ctx.in_grid((i, j)) and topology.adjacent(c, (i, j), ctx.topology, r):
                out.append((i, j))
    return out


# --------------------------------------------------------------------------- INV-MASKING


def expected_mask(ctx: Context, view: StateView, robot: str, obs: Json) -> list[bool]:
    """O-MASK recomputed from the pre-action state and the robot's own option lists."""
    mask = [False] * N_ACTIONS
    mask[IDLE] = True
    r = view.robots.get(robot) or {}
    if not view.free(robot):
        return mask
    options = obs.get("operation_options") or []
    pending = r.get("supports")
    if pending is not None and view.t < int(r.get("switch_lock", -1)):
        for k, opt in enumerate(options[:OP_SLOTS]):
            if isinstance(opt, dict) and opt.get("id") == pending:
                mask[OP0 + k] = True
        return mask
    for k in range(min(len(options), OP_SLOTS)):
        mask[OP0 + k] = True
    if pending is not None:
        return mask
    directions = [d for d, _ in ctx.direction_neighbours(robot)]
    if r.get("holding") is None:
        for k in range(min(len(obs.get("pick_options") or []), PICK_SLOTS)):
            mask[PICK0 + k] = True
        for d in directions:
            mask[RECEIVE0 + d] = True
    else:
        for d in directions:
            mask[HANDOFF0 + d] = True
        parsed = parse_item(r["holding"])
        recipe = ctx.recipe_of(view, parsed[0]) if parsed else None
        col = parse_cell(robot)[1]
        if (recipe is not None and parsed[1] == recipe.terminal and col == ctx.cols - 1
                and ctx.spacing * (ctx.cols - col) <= ctx.reach + REACH_TOLERANCE):
            mask[DELIVER] = True
    return mask


def _action_name(a: int) -> str:
    if a == IDLE:
        return "idle"
    if a == DELIVER:
        return "deliver"
    if PICK0 <= a < HANDOFF0:
        return f"pick slot {a - PICK0}"
    if HANDOFF0 <= a < RECEIVE0:
        return f"handoff {DIRECTION_NAMES[a - HANDOFF0]}"
    if RECEIVE0 <= a < OP0:
        return f"receive {DIRECTION_NAMES[a - RECEIVE0]}"
    if OP0 <= a < N_ACTIONS:
        return f"operation slot {a - OP0}"
    return f"out-of-range action {a}"


def inv_masking(ctx: Context, prev: Json | None, rec: Json) -> list[Violation]:
    """INV-MASKING: idle is always legal; a busy robot has only idle; the mask equals O-MASK (it hides no
    locally legal action, e.g. the pick slots of a free empty-handed input robot, and exposes nothing
    else); every applied action was legal, illegal choices appear as coerced to idle (O-MASK,
    R-ACTION-VALIDATION, R-SWITCH-LOCK)."""
    ID = "INV-MASKING"
    if prev is None:
        return []
    out: list[Violation] = []
    p = ctx.view(prev["state"])
    t = int(rec.get("t", p.t))
    actions = rec.get("actions") or {}
    coerced = {ev.get("robot"): ev.get("action") for ev in rec.get("events") or [] if ev.get("type") == "action_coerced"}
    chosen = dict(rec.get("chosen") or {})
    for robot, a in actions.items():
        if not (isinstance(a, int) and 0 <= a < N_ACTIONS):
            out.append(Violation(ID, t, robot, f"{robot}: applied action {a!r} is outside 0..{N_ACTIONS - 1}"))
    observations = rec.get("observations")
    if not observations:
        ctx.skipped.setdefault(ID, "the trace carries no masks")
        return out
    for robot, obs in observations.items():
        ctx.count(ID)
        mask = obs.get("mask") if isinstance(obs, dict) else None
        if not (isinstance(mask, list) and len(mask) == N_ACTIONS and set(map(type, mask)) == {bool}):
            out.append(Violation(ID, t, robot, f"{robot}: the mask is not {N_ACTIONS} booleans"))
            continue
        if not mask[IDLE]:
            out.append(Violation(ID, t, robot, f"{robot}: idle is masked; at least idle must always be legal"))
        if not p.free(robot) and True in mask[1:]:
            legal = [_action_name(k) for k in range(1, N_ACTIONS) if mask[k]]
            out.append(Violation(ID, t, robot, f"{robot} is busy but its mask allows {legal}"))
        expected = expected_mask(ctx, p, robot, obs)
        if mask != expected:  # name the differing actions only when there are some
            hidden = [_action_name(k) for k in range(N_ACTIONS) if expected[k] and not mask[k]]
            exposed = [_action_name(k) for k in range(N_ACTIONS) if mask[k] and not expected[k]]
            if hidden:
                out.append(Violation(ID, t, robot, f"{robot}: the mask hides locally legal action(s) {hidden}"))
            if exposed:
                out.append(Violation(ID, t, robot, f"{robot}: the mask allows action(s) {exposed} that O-MASK forbids"))
        a = actions.get(robot, IDLE)
        if isinstance(a, int) and 0 <= a < N_ACTIONS and not mask[a]:
            out.append(Violation(ID, t, robot, f"{robot} applied {_action_name(a)}, which its mask forbids"))
        original = coerced.get(robot, chosen.get(robot, a))
        if original != a:
            if a != IDLE:
                out.append(Violation(ID, t, robot, f"{robot}: chosen {original!r} was replaced by {_action_name(a)}, "
                                                   "not by idle"))
            if isinstance(original, int) and 0 <= original < N_ACTIONS and mask[original]:
                out.append(Violation(ID, t, robot, f"{robot}: legal action {_action_name(original)} was coerced to idle"))
        elif robot in coerced and isinstance(a, int) and 0 <= a < N_ACTIONS and mask[a] and a != IDLE:
            out.append(Violation(ID, t, robot, f"{robot}: legal action {_action_name(a)} is reported as coerced"))
    return out


# --------------------------------------------------------------------------- INV-ACCOUNTING


def inv_accounting(ctx: Context, prev: Json | None, rec: Json) -> list[Violation]:
    """INV-ACCOUNTING: released, delivered and lost releases never decrease; wip = released - delivered =
    number of undelivered products <= wip_cap; one opportunity per release epoch; releases follow the
    realization (R-RELEASE, R-DELIVERY, R-COMPLETION)."""
    ID = "INV-ACCOUNTING"
    out: list[Violation] = []
    state = rec["state"]
    s = ctx.view(state)
    tick = s.t
    ctx.count(ID)

    def bad(entity, msg):
        out.append(Violation(ID, tick, entity, msg))

    released, delivered = state.get("released"), state.get("delivered")
    wip, lost = state.get("wip"), state.get("lost_releases", 0)
    undelivered = sum(1 for p in s.products.values() if p.get("delivered_at") is None)
    n_delivered = sum(1 for p in s.products.values() if p.get("delivered_at") is not None)
    if not all(isinstance(x, int) for x in (released, delivered, wip, lost)):
        bad(None, f"counters released={released!r} delivered={delivered!r} wip={wip!r} lost={lost!r} are not integers")
        return out
    if wip != released - delivered:
        bad(None, f"wip {wip} != released {released} - delivered {delivered}")
    if wip != undelivered:
        bad(None, f"wip {wip} != {undelivered} released undelivered products")
    if released != len(s.products) or sorted(s.products) != list(range(len(s.products))):
        bad(None, f"released = {released} but the state lists products {sorted(s.products)}")
    if delivered != n_delivered:
        bad(None, f"delivered = {delivered} but {n_delivered} products are delivered")
    if not (0 <= delivered <= released) or lost < 0:
        bad(None, f"impossible counters released={released} delivered={delivered} lost={lost}")
    if wip > ctx.wip_cap:
        bad(None, f"wip {wip} exceeds the WIP cap {ctx.wip_cap}")
    for pid, prod in s.products.items():
        if pid < len(ctx.realization_products):
            spec = ctx.realization_products[pid]
            if prod.get("recipe") != spec.get("recipe") or prod.get("due") != prod.get("released_at", 0) + spec.get("due_offset", 0):
                bad(str(pid), f"product {pid} ({prod.get('recipe')}, due {prod.get('due')}) does not follow realization "
                              f"entry {pid} ({spec.get('recipe')}, due offset {spec.get('due_offset')})")
        else:
            bad(str(pid), f"product {pid} is not in the realization ({len(ctx.realization_products)} products)")
    if prev is None:
        forced = 0 if (ctx.mode == "batch" and not ctx.batch_size) else 1
        if released + lost != forced:
            bad(None, f"the initial state has released {released} + lost {lost} != {forced} opportunity at t=0")
        return out
    pstate = prev["state"]
    p = ctx.view(pstate)
    t = int(rec.get("t", p.t))
    for key in ("released", "delivered", "lost_releases"):
        if isinstance(pstate.get(key), int) and state.get(key, 0) < pstate[key]:
            bad(None, f"{key} decreased from {pstate[key]} to {state.get(key)}")
    opportunity = (t + 1) % ctx.interval == 0 and not (
        ctx.mode == "batch" and int(pstate.get("released", 0)) >= int(ctx.batch_size or 0))
    step = (released + lost) - (int(pstate.get("released", 0)) + int(pstate.get("lost_releases", 0)))
    if step != (1 if opportunity else 0):
        bad(None, f"released + lost grew by {step} at t={t + 1}, which is "
                  f"{'a' if opportunity else 'not a'} release opportunity (interval {ctx.interval})")
    for pid, prod in s.products.items():
        if pid in p.products:
            continue
        if prod.get("released_at") != t + 1 or pid != pstate.get("released"):
            bad(str(pid), f"new product {pid} released at {prod.get('released_at')}; expected id "
                          f"{pstate.get('released')} released at {t + 1}")
    tr = ctx.transition(prev, rec)
    delivering = {a.get("product") for a in tr.completing if a.get("kind") == "deliver"}
    for pid, prod in s.products.items():
        before = p.products.get(pid)
        if prod.get("delivered_at") is not None and (before is None or before.get("delivered_at") is None):
            if pid not in delivering or prod["delivered_at"] != t + 1:
                bad(str(pid), f"product {pid} became delivered (at {prod['delivered_at']}) without a delivery "
                              f"completing at {t + 1}")
    for pid in delivering:
        if (s.products.get(pid) or {}).get("delivered_at") is None:
            bad(str(pid), f"a delivery of product {pid} completed but the product is not delivered")
    return out


# --------------------------------------------------------------------------- the checker

Invariant = Callable[[Context, "Json | None", Json], list[Violation]]

INVARIANTS: tuple[tuple[str, Invariant], ...] = (
    ("INV-CONSERVATION", inv_conservation),
    ("INV-SUPPORT", inv_support),
    ("INV-PROGRESS", inv_progress),
    ("INV-RECIPE", inv_recipe),
    ("INV-LOCALITY", inv_locality),
    ("INV-LIFETIME", inv_lifetime),
    ("INV-ARITY", inv_arity),
    ("INV-EXCLUSIVITY", inv_exclusivity),
    ("INV-OBSERVATION", inv_observation),
    ("INV-MASKING", inv_masking),
    ("INV-ACCOUNTING", inv_accounting),
)


@dataclass
class Report:
    """The result of :func:`check_trace` (INV-TRACE vacuity guard).

    ``ticks``: tick records checked; ``agents``: robots of the instance; ``states``: state records
    checked; ``checks``: invariant ID -> objects evaluated (items, activities, robots, products, …);
    ``records``: invariant ID -> records on which it ran; ``skipped``: invariant ID -> why clauses
    were skipped (inputs absent from the trace); ``violations``: everything that failed.
    """

    ticks: int = 0
    agents: int = 0
    states: int = 0
    checks: dict[str, int] = field(default_factory=dict)
    records: dict[str, int] = field(default_factory=dict)
    skipped: dict[str, str] = field(default_factory=dict)
    violations: list[Violation] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not self.violations

    @property
    def total_checks(self) -> int:
        return sum(self.checks.values())

    def ids(self) -> set[str]:
        return {v.invariant for v in self.violations}

    def by_invariant(self, invariant: str) -> list[Violation]:
        return [v for v in self.violations if v.invariant == invariant]

    def summary(self) -> str:
        lines = [f"{self.ticks} ticks, {self.agents} agents, {self.states} states, {self.total_checks} checks: "
                 + ("ok" if self.ok else f"{len(self.violations)} violation(s)")]
        for inv in INVARIANT_IDS:
            note = f" (skipped: {self.skipped[inv]})" if inv in self.skipped else ""
            lines.append(f"  {inv:<18} {self.checks.get(inv, 0):>8} checks{note}")
        lines += [f"  {v}" for v in self.violations[:50]]
        if len(self.violations) > 50:
            lines.append(f"  … {len(self.violations) - 50} more")
        return "\n".join(lines)


def check_records(ctx: Context, prev: Json | None, rec: Json) -> list[Violation]:
    """All eleven invariants on one record (header: ``prev`` is None)."""
    out: list[Violation] = []
    for inv_id, fn in INVARIANTS:
        ctx.evaluated[inv_id] += 1
        out += fn(ctx, prev, rec)
    return out


def check_trace(records: Iterable[Json]) -> Report:
    """Check a whole trace (header, tick records, footer) against the eleven invariants.

    Vacuity guard (INV-TRACE): an empty trace or one without transitions is ``TRACE-EMPTY``; a missing
    footer, a footer that declares the run incomplete or a tick count different from the tick records
    read, or a gap in the epochs, is ``TRACE-TRUNCATED``; an invariant that evaluated nothing on a trace
    with transitions (without a reported skip) is ``TRACE-VACUOUS``.
    """
    records = list(records)
    report = Report()
    if not records or records[0].get("type") != "header":
        report.violations.append(Violation(TRACE_EMPTY, None, None, "the trace has no header record"
                                           if records else "the trace is empty"))
        return report
    header = records[0]
    ticks = [r for r in records[1:] if r.get("type") == "tick"]
    footers = [r for r in records[1:] if r.get("type") == "footer"]
    report.ticks = len(ticks)
    try:
        ctx = Context.from_instance(header["instance"])
    except (KeyError, TypeError, ValueError) as exc:
        report.violations.append(Violation(TRACE_EMPTY, None, None, f"the header carries no usable instance IR ({exc})"))
        return report
    report.agents = ctx.rows * ctx.cols
    if not ticks:
        report.violations.append(Violation(TRACE_EMPTY, None, None, "the trace has no tick records"))
    if not footers:
        report.violations.append(Violation(TRACE_TRUNCATED, None, None, f"the trace ends after {len(ticks)} tick "
                                                                        "record(s) without a footer"))
    else:
        footer = footers[-1]
        if records[-1] is not footer:
            report.violations.append(Violation(TRACE_TRUNCATED, None, None, "records follow the footer"))
        if footer.get("ticks") != len(ticks):
            report.violations.append(Violation(TRACE_TRUNCATED, None, None, f"the footer declares {footer.get('ticks')} "
                                                                            f"ticks, the trace has {len(ticks)}"))
        if footer.get("complete") is False:
            report.violations.append(Violation(TRACE_TRUNCATED, None, None, "the footer declares the execution "
                                                                            "incomplete"))
    prev: Json | None = None
    expected_t = int((header.get("state") or {}).get("t", 0))
    for rec in [header] + ticks:
        if "state" not in rec:
            report.violations.append(Violation(TRACE_TRUNCATED, rec.get("t"), None, "a record carries no state"))
            break
        if prev is not None:
            if rec.get("t") != expected_t or (rec["state"] or {}).get("t") != expected_t + 1:
                report.violations.append(Violation(
                    TRACE_TRUNCATED, rec.get("t"), None,
                    f"tick record t={rec.get('t')} (state t={(rec['state'] or {}).get('t')}) follows epoch "
                    f"{expected_t}: records are missing or out of order"))
                break
            expected_t += 1
        report.violations += check_records(ctx, prev, rec)
        report.states += 1
        prev = rec
    report.checks = {inv: int(ctx.counts.get(inv, 0)) for inv in INVARIANT_IDS}
    report.records = {inv: int(ctx.evaluated.get(inv, 0)) for inv in INVARIANT_IDS}
    report.skipped = dict(ctx.skipped)
    if ticks:
        for inv in INVARIANT_IDS:
            if report.records[inv] == 0 and inv not in report.skipped:
                report.violations.append(Violation(TRACE_VACUOUS, None, None, f"{inv} evaluated nothing"))
    return report


def read_trace(source: str | Path) -> list[Json]:
    """Read a JSON Lines trace file; an unparsable line ends the trace (checked as truncated)."""
    out = []
    with open(source, encoding="utf-8") as fh:
        for line in fh:
            if not line.strip():
                continue
            try:
                out.append(json.loads(line))
            except json.JSONDecodeError:
                break
    return out


def parse_trace_text(text: str) -> list[Json]:
    """Parse trace text (JSON Lines); stops at the first unparsable line."""
    out = []
    for line in text.splitlines():
        if not line.strip():
            continue
        try:
            out.append(json.loads(line))
        except json.JSONDecodeError:
            break
    return out


def check_trace_file(path: str | Path) -> Report:
    return check_trace(read_trace(path))


__all__ = [
    "Context", "Violation", "Report", "INVARIANTS", "INVARIANT_IDS",
    "inv_conservation", "inv_support", "inv_progress", "inv_recipe", "inv_locality", "inv_lifetime",
    "inv_arity", "inv_exclusivity", "inv_observation", "inv_masking", "inv_accounting",
    "check_trace", "check_records", "check_trace_file", "read_trace", "parse_trace_text", "canonical_roles",
    "expected_mask", "expected_pick_ids",
]
