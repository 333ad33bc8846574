"""Small hand-made instances for rule and invariant tests (S-INSTANCE shapes of the IR contract).

``make_test_instance`` builds a complete, valid instance IR around one or more recipe IRs without
any random draw: shelf stock, shelf access and every product's source rows are given directly, so a
test can state its expectations from the spec alone.  The profile is ``abstract-v1`` (resolved, no
variant) with optional overrides, e.g. ``{"motion_planning": False, "durations": {"pick": 1}}``.
"""

from __future__ import annotations

import copy
import math
from typing import Any, Mapping, Sequence

from agspec.ir.instance import flow_time_lower_bound, raw_types, shelf_layout
from agspec.ir.schemas import validate_schema
from agspec.ir.validate import errors, validate_instance

from conftest_ir import abstract_v1

IR = "agspec-ir/1"

# A logic-only profile: no approach/retreat (D = max(1, d)), unit logistics durations, no geometric
# conflicts (rho_conf and clearance 0), so that timing follows from the rules by hand.
FLAT = {"motion_planning": False, "trajectory_conflicts": False, "rho_conf": 0.0, "clearance": 0.0,
        "durations": {"pick": 1, "handoff": 1, "deliver": 1}}


def _merge(base: dict[str, Any], over: Mapping[str, Any]) -> dict[str, Any]:
    out = dict(base)
    for k, v in over.items():
        if isinstance(v, Mapping) and isinstance(out.get(k), Mapping):
            out[k] = _merge(dict(out[k]), v)
        else:
            out[k] = copy.deepcopy(v)
    return out


def op(op_id: str, inputs: Sequence[str], output: str, *, after: Sequence[str] = (), arity=(1, 1),
       roles: Sequence[tuple[str, str | None]] | None = None, duration: int = 1, type: str | None = None,
       resources: Sequence[str] = (), weight: float = 1.0) -> dict[str, Any]:
    """An operation IR; default roles: one bound role per input, then unbound helpers up to k_max."""
    if roles is None:
        roles = [(f"holder_{tok}", tok) for tok in sorted(inputs)]
        roles += [(f"helper_{k}", None) for k in range(arity[1] - len(roles))]
    return {
        "id": op_id, "type": type or op_id, "inputs": sorted(inputs), "outputs": [output],
        "after": sorted(after), "arity": list(arity),
        "roles": [{"name": n, "binds": b} if b else {"name": n} for n, b in roles],
        "resources": sorted(resources), "duration": duration, "weight": weight,
    }


def recipe(recipe_id: str, raw: Sequence[str], ops: Sequence[dict[str, Any]], *, xor=(), resources=None,
           value: float = 1.0) -> dict[str, Any]:
    """A recipe IR in canonical order (operations and XOR groups sorted by id)."""
    return {
        "ir_version": IR, "kind": "recipe", "id": recipe_id, "value": value, "raw": list(raw),
        "resources": dict(resources or {}),
        "operations": sorted(ops, key=lambda o: o["id"]),
        "xor": sorted(({"id": g, "alternatives": sorted(alts)} for g, alts in xor), key=lambda g: g["id"]),
    }


def make_test_instance(
    rows: int,
    cols: int,
    recipe_ir: Mapping[str, Any] | Sequence[Mapping[str, Any]],
    *,
    profile_overrides: Mapping[str, Any] | None = None,
    wip_cap: int = 1,
    interval: int = 100,
    horizon: int = 40,
    mode: str = "batch",
    shelves: Sequence[Mapping[str, int]] | None = None,
    shelf_access: Mapping[int, Sequence[int]] | None = None,
    products: Sequence[Mapping[str, Any]] | None = None,
    topology: str = "moore",
    coordination: Mapping[str, Any] | None = None,
    resources: Mapping[str, int] | None = None,
    shelf_capacity: int = 6,
    replenish_interval: int = 100,
    instance_id: str = "test",
    validate: bool = True,
) -> dict[str, Any]:
    """A valid instance IR.

    * ``recipe_ir``: one recipe IR or a list (the product mix, in order).
    * ``shelves``: initial stock per row, e.g. ``[{"A": 6}, {"B": 6}]`` (default: S-SHELF-LAYOUT).
    * ``shelf_access``: shelf row -> left-column robot rows allowed to pick there (default: own row).
    * ``products``: per product ``{"source_rows": {...}}`` (plus optional ``"recipe"``), or just the
      source-row dict; batch mode releases exactly these (``batch_size = len(products)``), continuing
      mode cycles them to ``1 + horizon // interval`` entries.  Default: one product sourcing every raw
      token from the first row stocking it.
    * ``horizon``: the horizon (continuing) or the timeout (batch).
    """
    recipes = [dict(recipe_ir)] if isinstance(recipe_ir, Mapping) else [dict(r) for r in recipe_ir]
    by_id = {r["id"]: copy.deepcopy(r) for r in recipes}
    mix = [r["id"] for r in recipes]
    profile = _merge({k: v for k, v in abstract_v1().items() if k != "variants"}, profile_overrides or {})
    profile["variant"] = None
    raws = raw_types(mix, by_id)
    if shelves is None:
        layout = shelf_layout(rows, raws, shelf_capacity)
    else:
        layout = [{"row": r, "stock": dict(stock)} for r, stock in enumerate(shelves)]
    access = shelf_access if shelf_access is not None else {r: [r] for r in range(rows)}
    stocking = {tok: [s["row"] for s in layout if tok in s["stock"]] for tok in raws}

    if products is None:
        products = [{"source_rows": {tok: stocking[tok][0] for tok in by_id[mix[0]]["raw"]}}]
    entries = [dict(p) if "source_rows" in p else {"source_rows": dict(p)} for p in products]
    if mode == "batch":
        count = len(entries)
        evaluation = {"mode": "batch", "batch_size": count, "timeout": horizon}
    else:
        count = 1 + horizon // interval
        evaluation = {"mode": "continuing", "horizon": horizon}
    slack = 2.2
    realized = []
    for k in range(count):
        e = entries[k % len(entries)]
        rid = e.get("recipe", mix[0])
        lb = flow_time_lower_bound(by_id[rid], profile, cols)
        realized.append({"id": k, "recipe": rid, "source_rows": dict(e["source_rows"]), "mass": 1.0,
                         "slack": slack, "due_offset": math.ceil(slack * lb)})
    scenario = {
        "ir_version": IR, "kind": "scenario", "id": instance_id,
        "family": "test", "level": "unit",
        "grid": {"rows": rows, "cols": cols, "topology": topology, "radius": 1},
        "recipes": mix,
        "profile": {"id": profile["id"], "variant": None},
        "release": {"interval": interval, "wip_cap": wip_cap},
        "evaluation": evaluation,
        "shelves": {"capacity": shelf_capacity, "replenish_interval": replenish_interval,
                    "extra_access_probability": 0.0},
        "coordination": _merge({"support_timeout": 3, "switch_lock": 1, "support_visible": True,
                                "bilateral_handoff": True}, coordination or {}),
        "products": {"mass": [0.5, 2.0], "due_slack": 2.2, "due_slack_jitter": 0.5},
        "resources": dict(resources or {}),
    }
    instance = {
        "ir_version": IR, "kind": "instance", "id": f"{instance_id}-g0",
        "scenario": scenario,
        "recipes": by_id,
        "profile": profile,
        "seeds": {"index": None, "generation": 0, "execution": 0},
        "realization": {
            "method": "hand-made",
            "raw_types": raws,
            "shelves": layout,
            "shelf_access": [{"shelf_row": r, "robot_rows": sorted(access.get(r, []))} for r in range(rows)],
            "products": realized,
        },
    }
    if validate:
        problems = errors(validate_schema(instance)) or errors(validate_instance(instance))
        assert not problems, "builder produced an invalid instance:\n" + "\n".join(
            f"  {i.code} {i.pointer}: {i.message}" for i in problems)
    return instance


# --------------------------------------------------------------------------- scripted episodes

import io  # noqa: E402

from agspec.invariants import Report, check_trace, parse_trace_text  # noqa: E402
from agspec.interp.model import DIRECTIONS  # noqa: E402
from agspec.interp.observe import DELIVER, HANDOFF0, IDLE, OP0, PICK0, RECEIVE0  # noqa: E402
from agspec.interp.snapshot import global_state  # noqa: E402
from agspec.interp.tick import Simulator, StepResult  # noqa: E402
from agspec.ir.fingerprint import fingerprint  # noqa: E402
from agspec.formats.trace import TraceWriter  # noqa: E402


def cell(robot: str) -> tuple[int, int]:
    i, j = robot.split(",")
    return int(i), int(j)


def rid(c: tuple[int, int]) -> str:
    return f"{c[0]},{c[1]}"


def direction(src: str, dst: str) -> int:
    """O-ACTION-ENCODING: index d of the direction from robot ``src`` to neighbour ``dst``."""
    a, b = cell(src), cell(dst)
    return DIRECTIONS.index((b[0] - a[0], b[1] - a[1]))


def candidate_id(pid: int, op_id: str, members: Sequence[str]) -> str:
    """R-IDS: op:{pid}:{op}:{members row-major}."""
    return f"op:{pid}:{op_id}:" + ";".join(sorted(members, key=cell))


class Driver:
    """Drives the reference Simulator with scripted joint actions and records an in-memory trace
    (with observations) that :meth:`check` runs through the eleven invariants."""

    def __init__(self, instance: dict[str, Any]):
        self.instance = instance
        self.sim = Simulator(instance)
        self.buf = io.StringIO()
        self.trace = TraceWriter(self.buf)
        self.trace.header(instance=instance, fingerprint=fingerprint(instance), execution_seed=0,
                          controller={"name": "script", "information": "local"},
                          initial_state=global_state(self.sim.state), initial_events=self.sim.reset_events)
        self.results: list[StepResult] = []

    # ---- reading
    @property
    def t(self) -> int:
        return self.sim.t

    def obs(self, robot: str) -> dict[str, Any]:
        return self.sim.observe(robot)

    def state(self) -> dict[str, Any]:
        return global_state(self.sim.state)

    def holding(self, robot: str) -> str | None:
        return self.state()["robots"][robot]["holding"]

    def options(self, robot: str) -> list[str]:
        return [o["id"] for o in self.obs(robot)["operation_options"]]

    def events(self, kind: str | None = None) -> list[dict[str, Any]]:
        """All events so far (with the epoch ``t`` of their transition), optionally of one type."""
        out = []
        for r in self.results:
            out += [{**e, "t": r.t} for e in r.events if kind is None or e["type"] == kind]
        return out

    # ---- action ints (O-ACTION-ENCODING) from the robot's current option lists
    def pick(self, robot: str, option: str | None = None) -> int:
        picks = [p["id"] for p in self.obs(robot)["pick_options"]]
        k = 0 if option is None else picks.index(option)
        assert k < len(picks), f"{robot} has no pick option ({picks})"
        return PICK0 + k

    def support(self, robot: str, cid: str) -> int:
        return OP0 + self.options(robot).index(cid)

    @staticmethod
    def handoff(sender: str, receiver: str) -> int:
        return HANDOFF0 + direction(sender, receiver)

    @staticmethod
    def receive(receiver: str, sender: str) -> int:
        return RECEIVE0 + direction(receiver, sender)

    # ---- acting
    def step(self, actions: Mapping[str, int] | None = None) -> StepResult:
        obs = self.sim.observe()
        t = self.sim.t
        res = self.sim.step(dict(actions or {}))
        self.trace.tick(t=t, actions=res.applied, events=res.events, state=global_state(self.sim.state),
                        observations=obs)
        self.results.append(res)
        return res

    def idle(self, n: int = 1) -> None:
        for _ in range(n):
            self.step({})

    def until(self, t: int) -> None:
        while self.sim.t < t:
            self.step({})

    def transfer(self, sender: str, receiver: str) -> StepResult:
        """A matched bilateral handoff (R-HANDOFF) started now; steps until it has completed."""
        res = self.step({sender: self.handoff(sender, receiver), receiver: self.receive(receiver, sender)})
        started = [e for e in res.events if e["type"] == "handoff_started"]
        assert started, f"handoff {sender} -> {receiver} did not start: {res.events}"
        self.until(started[0]["end"])
        return res

    def carry(self, path: Sequence[str]) -> None:
        """Move the item held by path[0] along neighbouring robots to path[-1]."""
        for a, b in zip(path, path[1:]):
            self.transfer(a, b)

    def check(self) -> Report:
        """Close the trace and run the invariant checker over it."""
        self.trace.footer(metrics={})
        return check_trace(parse_trace_text(self.buf.getvalue()))
