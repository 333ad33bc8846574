"""What the invariants share: the record views, the per-trace :class:`Context` and the constants
of the formats they read (F-TRACE, O-OBSERVATION)."""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping

from agspec.ir import topology, variants

Json = dict[str, Any]

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


def reporter(invariant: str, tick: int) -> tuple[list[Violation], Callable[[Any, str], None]]:
    """The violations of one invariant on one record, and the function that adds one (entity, message)."""
    out: list[Violation] = []

    def bad(entity: Any, msg: str) -> None:
        out.append(Violation(invariant, tick, entity, msg))

    return out, bad


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
    # the grid's locality relations (agspec.ir.topology), built once per trace: relation -> graph / slots
    _graphs: dict[str, Any] = field(default_factory=dict)
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
            support_visible=variants.enabled("support_visible", sc),
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

    # ---- grid relations (D-TOPOLOGY), all three from agspec.ir.topology

    def _graph(self, relation: str) -> Any:
        graph = self._graphs.get(relation)
        if graph is None:
            build = {"manip": topology.manipulation_graph, "handoff": topology.handoff_graph,
                     "obs": topology.observation_graph}[relation]
            graph = self._graphs[relation] = build(self.rows, self.cols, self.topology, self.radius)
        return graph

    def _slots(self, relation: str) -> dict[str, list[tuple[int, str]]]:
        key = f"{relation}-slots"
        slots = self._graphs.get(key)
        if slots is None:
            slots = self._graphs[key] = {cell_id(c): [(d, cell_id(n)) for d, n in around]
                                         for c, around in topology.direction_slots(self._graph(relation)).items()}
        return slots

    def manip_adjacent(self, a: str, b: str) -> bool:
        """G_manip adjacency of two robot ids."""
        return self._graph("manip").has_edge(parse_cell(a), parse_cell(b))

    def manip_neighbours(self, robot: str) -> list[str]:
        """u's G_manip neighbours (robot ids, row-major); none for a robot outside the grid."""
        graph, c = self._graph("manip"), parse_cell(robot)
        return [cell_id(n) for n in sorted(graph[c])] if c in graph else []

    def handoff_adjacent(self, a: str, b: str) -> bool:
        """G_handoff adjacency of two robot ids (RES-RADIUS: within the eight direction cells)."""
        return self._graph("handoff").has_edge(parse_cell(a), parse_cell(b))

    def in_grid(self, cell: tuple[int, int]) -> bool:
        return 0 <= cell[0] < self.rows and 0 <= cell[1] < self.cols

    def handoff_neighbours(self, robot: str) -> list[tuple[int, str]]:
        """(direction index, robot id) of u's G_handoff neighbours in direction order (O-MASK)."""
        return self._slots("handoff").get(robot, [])

    def observation_neighbours(self, robot: str) -> list[tuple[int, str]]:
        """(direction index, robot id) of u's G_obs neighbours in direction order (O-OBSERVATION)."""
        return self._slots("obs").get(robot, [])

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
