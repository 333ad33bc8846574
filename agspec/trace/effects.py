"""The change each event stands for, and what must hold where it stands (F-TRACE-PAIRING's table).

A :class:`Replay` is one record being replayed: the state before it (its behavioural fields,
:func:`agspec.trace.projection.project`), the record's applied actions, ``chosen`` map and
observations, and the problems found. Each function applies one event type to it — checking the
event against the facts the record shows (the robot's applied action, what it holds, the record it
names) — or one change without an event (a completion whose event is missing, replenishment, the
release opportunity). :mod:`agspec.trace.pairing` walks a record's events through the steps of
F-TRACE-EMISSION and calls them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping

from agspec.formats.actions import DELIVER, HANDOFF0, N_ACTIONS, OP0, PICK0, PICK_SLOTS, RECEIVE0
from agspec.interp.model import DIRECTIONS, Model
from agspec.trace.emission import POST_ADVANCE_EXPIRY
from agspec.trace.projection import Json, candidate_op, cell_key, members_of


@dataclass(frozen=True)
class Problem:
    """One disagreement: ``record`` indexes the trace's records, ``pointer`` points into that record."""

    record: int
    pointer: str
    message: str


@dataclass
class Replay:
    """The replay of one record's events over the state before it (F-TRACE-PAIRING)."""

    model: Model
    index: int  # the record's index in the trace
    t: int  # the decision epoch of the record (the header: the reset's epoch)
    state: Json
    actions: Mapping[str, int]
    chosen: Mapping[str, int] | None
    options: Mapping[str, Json] | None  # robot -> its observation (I_t), when the trace records them
    problems: list[Problem] = field(default_factory=list)
    step: int = 0  # index into the steps being walked
    last_key: Any = None  # the order key of the last attempt of the current step
    clock: int = 0  # the epoch the state is at: t before the clock advance, t + 1 after it
    group: dict | None = None  # an open support group of step 5 (support_switched / proposal_created)
    in_c_t: set = field(default_factory=set)  # candidates this record shows to be in C_t
    coerced: set = field(default_factory=set)
    completing: list = field(default_factory=list)  # ids of the activities that end at t + 1, in creation order
    done: set = field(default_factory=set)
    released_event: Json | None = None  # the release or release_lost of this record

    def bad(self, at: int | None, message: str) -> None:
        self.problems.append(Problem(self.index, f"/events/{at}" if at is not None else "/events", message))

    def applied(self, robot: str) -> int:
        return int(self.actions.get(robot, 0))

    def robot(self, rid: Any) -> Json | None:
        return self.state["robots"].get(rid) if isinstance(rid, str) else None

    def free(self, rid: str) -> bool:
        r = self.robot(rid)
        return r is not None and r["activity"] is None and r["incoming"] is None

    def option(self, robot: str, kind: str, slot: int) -> str | None:
        obs = (self.options or {}).get(robot)
        opts = (obs or {}).get(f"{kind}_options") if isinstance(obs, dict) else None
        if not isinstance(opts, list) or not 0 <= slot < len(opts) or not isinstance(opts[slot], dict):
            return None
        return opts[slot].get("id")

    def c_t(self) -> set[str] | None:
        """C_t from the observations (O-EXPOSURE: the union of every robot's operation options)."""
        if not self.options:
            return None
        out: set[str] = set()
        for obs in self.options.values():
            for opt in (obs or {}).get("operation_options") or [] if isinstance(obs, dict) else []:
                if isinstance(opt, dict) and isinstance(opt.get("id"), str):
                    out.add(opt["id"])
        return out

    def terminal(self, pid: int) -> str | None:
        p = self.state["products"].get(pid)
        recipe = self.model.recipes.get(p["recipe"]) if p else None
        return f"{pid}:{recipe.terminal}" if recipe else None

    def activity(self, aid: Any) -> Json | None:
        return next((a for a in self.state["activities"] if a["id"] == aid), None)


def action_coerced(rp: Replay, at: int, ev: Json) -> None:
    rid = ev.get("robot")
    if rp.robot(rid) is None:
        rp.bad(at, f"action_coerced names {rid!r}, which is no robot")
        return
    if rp.applied(rid) != 0:
        rp.bad(at, f"robot {rid}'s action was coerced to idle, but the record applies {rp.applied(rid)} "
               "(R-ACTION-VALIDATION)")
    if ev.get("action") == 0:
        rp.bad(at, "idle is always legal; it is never coerced (R-ACTION-VALIDATION)")
    if rp.chosen is not None and rp.chosen.get(rid) != ev.get("action"):
        rp.bad(at, f"robot {rid} submitted {rp.chosen.get(rid)!r} (`chosen`), not {ev.get('action')!r}")
    rp.coerced.add(rid)


def _start(rp: Replay, at: int, ev: Json, kind: str, members: list[str], expected_id: str, **fields: Any) -> None:
    if ev.get("activity") != expected_id:
        rp.bad(at, f"the activity is `{ev.get('activity')}`; R-IDS names it `{expected_id}`")
    end = ev.get("end")
    if not isinstance(end, int) or end <= rp.t:
        rp.bad(at, f"an activity started at {rp.t} cannot end at {end!r} (G-DURATION: D >= 1)")
        end = rp.t + 1
    act = {"id": ev.get("activity"), "kind": kind, "members": members, "start": rp.t, "end": end, **fields}
    rp.state["activities"].append(act)
    for m in members:
        if rp.robot(m) is not None:
            rp.robot(m)["activity"] = act["id"]


def pick_started(rp: Replay, at: int, ev: Json) -> None:
    rid, pid, tok, row = ev.get("robot"), ev.get("product"), ev.get("token"), ev.get("shelf_row")
    check_attempt(rp, at, ev)
    prod = rp.state["products"].get(pid)
    recipe = rp.model.recipes.get(prod["recipe"]) if prod else None
    shelf = rp.state["shelves"][row] if isinstance(row, int) and 0 <= row < len(rp.state["shelves"]) else None
    if prod is None or recipe is None or prod["delivered_at"] is not None:
        rp.bad(at, f"product {pid} is not released and undelivered (R-PICK)")
    elif tok not in recipe.raw or tok in prod["raw_taken"]:
        rp.bad(at, f"token {tok!r} is not a raw token of product {pid} still to pick (R-PICK)")
    if shelf is None or int(shelf.get(tok, 0)) < 1:
        rp.bad(at, f"shelf row {row!r} has no unit of {tok!r} (R-PICK)")
    else:
        shelf[tok] -= 1
    if prod is not None:
        prod["raw_taken"].add(tok)
    _start(rp, at, ev, "pick", [rid], f"pick@{rp.t}:{pid}:{tok}:{rid}", product=pid, item=f"{pid}:{tok}")


def handoff_started(rp: Replay, at: int, ev: Json) -> None:
    s, r, item = ev.get("sender"), ev.get("receiver"), ev.get("item")
    check_attempt(rp, at, ev)
    if rp.robot(r) is not None:
        rp.robot(r)["incoming"] = item
    pid = int(str(item).split(":")[0]) if str(item).split(":")[0].isdigit() else None
    _start(rp, at, ev, "handoff", [s, r], f"handoff@{rp.t}:{item}:{s}>{r}", product=pid, item=item)


def check_attempt(rp: Replay, at: int, ev: Json) -> None:
    """A start or a blocked attempt: the robots applied the matching action and could attempt it."""
    kind = ev.get("kind")
    if kind == "pick":
        rid = ev.get("robot")
        a = rp.applied(rid)
        if not PICK0 <= a < PICK0 + PICK_SLOTS:
            rp.bad(at, f"robot {rid} applied action {a}, not a pick (R-PICK)")
        else:
            offered = rp.option(rid, "pick", a - PICK0)
            want = f"pick:{ev.get('product')}:{ev.get('token')}:"
            if offered is not None and not (offered.startswith(want) and (
                    "shelf_row" not in ev or offered == f"{want}{ev.get('shelf_row')}")):
                rp.bad(at, f"robot {rid}'s pick slot {a - PICK0} is `{offered}`, not product {ev.get('product')} "
                       f"token {ev.get('token')} (O-PICK-OPTIONS)")
        check_holding(rp, at, rid, None, "pick")
    elif kind == "handoff":
        s, r = ev.get("sender"), ev.get("receiver")
        try:
            d = DIRECTIONS.index((cell_key(r)[0] - cell_key(s)[0], cell_key(r)[1] - cell_key(s)[1]))
        except (ValueError, AttributeError):
            rp.bad(at, f"{r} is not a direction neighbour of {s} (R-HANDOFF)")
            return
        back = DIRECTIONS.index((-DIRECTIONS[d][0], -DIRECTIONS[d][1]))
        if rp.applied(s) != HANDOFF0 + d or rp.applied(r) != RECEIVE0 + back:
            rp.bad(at, f"a handoff from {s} to {r} needs handoff({d}) and receive({back}); the record applies "
                   f"{rp.applied(s)} and {rp.applied(r)} (R-HANDOFF)")
        check_holding(rp, at, s, ev.get("item"), "handoff")
        check_holding(rp, at, r, None, "handoff")
    elif kind == "deliver":
        rid, pid = ev.get("robot"), ev.get("product")
        if rp.applied(rid) != DELIVER:
            rp.bad(at, f"robot {rid} applied action {rp.applied(rid)}, not deliver (R-DELIVERY)")
        prod = rp.state["products"].get(pid)
        if prod is None or prod["delivered_at"] is not None:
            rp.bad(at, f"product {pid} is not released and undelivered (R-DELIVERY)")
        check_holding(rp, at, rid, rp.terminal(pid) if prod else None, "deliver", must_hold=True)
        if isinstance(rid, str) and cell_key(rid)[1] != rp.model.cols - 1:
            rp.bad(at, f"robot {rid} is not in the output column {rp.model.cols - 1} (R-DELIVERY)")


def check_holding(rp: Replay, at: int, rid: Any, item: str | None, what: str, must_hold: bool = False) -> None:
    r = rp.robot(rid)
    if r is None:
        rp.bad(at, f"{rid!r} is no robot")
        return
    if not rp.free(rid):
        rp.bad(at, f"robot {rid} is not free (member of {r['activity']}, incoming {r['incoming']}); "
               f"a {what} needs free robots")
    if r["holding"] != item and (item is not None or not must_hold):
        rp.bad(at, f"robot {rid} holds {r['holding']!r}; the {what} needs it to hold {item!r}")


def blocked(rp: Replay, at: int, ev: Json) -> None:
    if ev.get("kind") == "operation":
        cid = ev.get("candidate")
        check_supported(rp, at, cid, "blocked")
        rp.in_c_t.add(cid)
    else:
        check_attempt(rp, at, ev)


def support_switched(rp: Replay, at: int, ev: Json) -> None:
    rid, old, new = ev.get("robot"), ev.get("from"), ev.get("to")
    open_group(rp, at, ev, rid, new, "support_switched")
    r = rp.robot(rid)
    if r is None:
        return
    if r["supports"] != old or old == new:
        rp.bad(at, f"robot {rid} supports {r['supports']!r}; it cannot switch from {old!r} to {new!r} "
               "(R-SUPPORT)")
    if old in rp.state["proposals"]:
        rp.state["proposals"][old]["supporters"].discard(rid)
    r["supports"] = None


def proposal_created(rp: Replay, at: int, ev: Json) -> None:
    cid = ev.get("candidate")
    if rp.group is None:
        open_group(rp, at, ev, None, cid, "proposal_created")
    elif rp.group["candidate"] != cid:
        rp.bad(at, f"proposal_created for {cid} follows a switch to {rp.group['candidate']} (F-TRACE-EMISSION)")
    rp.group["created"] = True
    if cid in rp.state["proposals"]:
        rp.bad(at, f"support record {cid} already exists (R-SUPPORT-LIFECYCLE: one record per candidate)")
    if ev.get("expires_at") != rp.t + rp.model.support_timeout:
        rp.bad(at, f"a record created at {rp.t} expires at {rp.t + rp.model.support_timeout} "
               f"(R-SUPPORT-LIFECYCLE), not {ev.get('expires_at')!r}")
    rp.state["proposals"][cid] = {"created_at": rp.t, "expires_at": ev.get("expires_at"), "supporters": set()}


def open_group(rp: Replay, at: int, ev: Json, rid: Any, cid: Any, opened_by: str) -> None:
    if rp.group is not None:
        rp.bad(at, f"{rp.group['opened_by']} is not followed by the support that completes it (F-TRACE-EMISSION)")
    rp.group = {"robot": rid, "candidate": cid, "opened_by": opened_by, "created": False}


def support(rp: Replay, at: int, ev: Json) -> None:
    rid, cid = ev.get("robot"), ev.get("candidate")
    group, rp.group = rp.group, None
    if group is not None and (group["robot"] not in (None, rid) or group["candidate"] != cid):
        rp.bad(at, f"support of {cid} by {rid} does not complete the {group['opened_by']} before it "
               f"({group['robot']} -> {group['candidate']}) (F-TRACE-EMISSION)")
    key = None
    try:
        key = cell_key(rid)
    except (ValueError, AttributeError):
        pass
    if group is None or group["robot"] is None:  # the group's order key is its support's robot
        if key is not None and rp.last_key is not None and not key > rp.last_key:
            rp.bad(at, "support is out of order in step 5: F-TRACE-EMISSION orders the supports by robot "
                   "(R-SUPPORT)")
        rp.last_key = key if key is not None else rp.last_key
    rp.in_c_t.add(cid)
    r = rp.robot(rid)
    if r is None:
        rp.bad(at, f"support names {rid!r}, which is no robot")
        return
    a = rp.applied(rid)
    if not OP0 <= a < N_ACTIONS:
        rp.bad(at, f"robot {rid} applied action {a}, not an operation slot (R-SUPPORT)")
    elif rp.option(rid, "operation", a - OP0) not in (None, cid):
        rp.bad(at, f"robot {rid}'s operation slot {a - OP0} is `{rp.option(rid, 'operation', a - OP0)}`, "
               f"not {cid} (O-OPERATION-OPTIONS)")
    if r["supports"] == cid:
        rp.bad(at, f"robot {rid} already supports {cid}: re-selecting it changes nothing and emits nothing "
               "(R-SUPPORT)")
    elif r["supports"] is not None:
        rp.bad(at, f"robot {rid} supports {r['supports']}; a switch emits support_switched first (R-SUPPORT)")
    if not isinstance(cid, str) or rid not in members_of(cid):
        rp.bad(at, f"robot {rid} is not a member of {cid} (R-SUPPORT)")
    prop = rp.state["proposals"].get(cid)
    if prop is None:
        rp.bad(at, f"no support record of {cid} exists; its first supporter creates it with proposal_created "
               "(R-SUPPORT-LIFECYCLE)")
        prop = rp.state["proposals"][cid] = {"created_at": rp.t, "expires_at": rp.t + rp.model.support_timeout,
                                             "supporters": set()}
    prop["supporters"].add(rid)
    r["supports"] = cid


def check_supported(rp: Replay, at: int, cid: Any, what: str) -> Json | None:
    prop = rp.state["proposals"].get(cid)
    if prop is None:
        rp.bad(at, f"{what} names {cid}, which has no open support record (R-ADMISSION)")
        return None
    members = members_of(cid)
    if prop["supporters"] != set(members) or any((rp.robot(m) or {}).get("supports") != cid for m in members):
        rp.bad(at, f"{what} names {cid}, which is not fully supported: supporters "
               f"{sorted(prop['supporters'])}, members {members} (R-ADMISSION)")
    return prop


def admitted(rp: Replay, at: int, ev: Json) -> None:
    cid = ev.get("candidate")
    prop = check_supported(rp, at, cid, "admitted")
    rp.in_c_t.add(cid)
    members = members_of(cid) if isinstance(cid, str) else []
    try:
        pid, op = candidate_op(cid)
    except (ValueError, IndexError, AttributeError):
        rp.bad(at, f"{cid!r} is not a candidate id (R-IDS)")
        return
    for m in members:
        if not rp.free(m):
            rp.bad(at, f"member {m} of {cid} is not free (R-ADMISSION)")
    prod = rp.state["products"].get(pid)
    recipe = rp.model.recipes.get(prod["recipe"]) if prod else None
    spec = next((o for o in recipe.operations if o.id == op), None) if recipe else None
    if prod is None or spec is None:
        rp.bad(at, f"{cid} names no operation of a released product (R-ADMISSION)")
    else:
        if op in prod["completed"] or op in prod["in_progress"]:
            where = "completed" if op in prod["completed"] else "in progress"
            rp.bad(at, f"operation {op} of product {pid} is already {where} (R-ADMISSION)")
        if spec.xor_group is not None and prod["xor"].get(spec.xor_group) not in (None, op):
            rp.bad(at, f"XOR group {spec.xor_group} of product {pid} chose {prod['xor'][spec.xor_group]} "
                       "(R-XOR-CLOSURE)")
        prod["in_progress"].add(op)
        if spec.xor_group is not None:
            prod["xor"][spec.xor_group] = op
    created = prop["created_at"] if prop else rp.t
    if ev.get("latency") != rp.t - created:
        rp.bad(at, f"latency {ev.get('latency')!r}: the record of {cid} was created at {created}, so it is "
               f"{rp.t - created} (M-ADMISSION-LATENCY)")
    rp.state["proposals"].pop(cid, None)
    for m in members:
        if rp.robot(m) is not None:
            rp.robot(m)["supports"] = None
    _start(rp, at, ev, "operation", members, f"op@{rp.t}:{cid}", product=pid, operation=op, candidate=cid,
           first_proposed_at=created, roles=None)


def expiry(rp: Replay, at: int, ev: Json) -> None:
    cid = ev.get("candidate")
    prop = rp.state["proposals"].get(cid)
    if prop is None:
        rp.bad(at, f"{ev.get('type')} names {cid}, which has no open support record (R-EXPIRY)")
        return
    failed = ev.get("type") == "admission_failed"
    if failed != bool(prop["supporters"]):
        rp.bad(at, f"support record {cid} has supporters {sorted(prop['supporters'])}: its removal is "
               f"{'admission_failed' if prop['supporters'] else 'proposal_abandoned'} (R-EXPIRY)")
    if rp.step == POST_ADVANCE_EXPIRY:
        if rp.clock <= prop["expires_at"]:
            rp.bad(at, f"support record {cid} expires at {prop['expires_at']}; it is not removed at "
                   f"{rp.clock} (R-SUPPORT-LIFECYCLE)")
        if failed and ev.get("reason") != "expired":
            rp.bad(at, "a record removed after the clock advance has expired (R-EXPIRY): reason `expired`")
    elif failed and ev.get("reason") == "expired" and rp.t <= prop["expires_at"]:
        rp.bad(at, f"support record {cid} is eligible until {prop['expires_at']}; it has not expired at "
               f"{rp.t} (R-SUPPORT-LIFECYCLE)")
    elif rp.t <= prop["expires_at"] and cid in rp.in_c_t:
        rp.bad(at, f"{cid} was supported or attempted in this epoch, so it is in C_t: its record is not "
               "invalid (RES-INVALID-EXPIRY)")
    drop_proposal(rp, cid)


def drop_proposal(rp: Replay, cid: str) -> None:
    prop = rp.state["proposals"].pop(cid)
    for rid in prop["supporters"]:
        r = rp.robot(rid)
        if r is not None and r["supports"] == cid:
            r["supports"] = None


def delivery_started(rp: Replay, at: int, ev: Json) -> None:
    rid, pid = ev.get("robot"), ev.get("product")
    check_attempt(rp, at, ev)
    _start(rp, at, ev, "deliver", [rid], f"deliver@{rp.t}:{pid}:{rid}", product=pid, item=rp.terminal(pid))


def completion(rp: Replay, at: int, ev: Json) -> None:
    aid = ev.get("activity")
    act = rp.activity(aid)
    kind = {"pick_completed": "pick", "handoff_completed": "handoff", "operation_completed": "operation",
            "delivered": "deliver"}[ev["type"]]
    if act is None or aid not in rp.completing or aid in rp.done:
        why = ("completed already in this record" if aid in rp.done else "is not running" if act is None
               else f"ends at {act['end']}")
        rp.bad(at, f"{ev['type']} of {aid}, which {why}: a completion is emitted in the transition into its "
               f"end epoch, once (R-COMPLETION)")
        return
    if act["kind"] != kind:
        rp.bad(at, f"{ev['type']} completes {aid}, a {act['kind']} activity")
        return
    expected = expected_completion(rp, act)
    for k, v in expected.items():
        if ev.get(k) != v:
            rp.bad(at, f"{ev['type']} of {aid}: `{k}` is {ev.get(k)!r}; the activity gives {v!r} (R-COMPLETION)")
    if kind == "operation" and act.get("roles") is None and ev.get("holder") not in act["members"]:
        rp.bad(at, f"{ev.get('holder')!r} is no member of {aid} (RES-OUTPUT-HOLDER)")
    complete(rp, act, ev.get("holder") if kind == "operation" and "holder" not in expected else None, at)


def expected_completion(rp: Replay, act: Json) -> Json:
    members, pid = act["members"], act.get("product")
    if act["kind"] == "pick":
        return {"robot": members[0], "item": act.get("item")}
    if act["kind"] == "handoff":
        return {"sender": members[0], "receiver": members[1] if len(members) > 1 else None, "item": act.get("item")}
    if act["kind"] == "deliver":
        return {"product": pid, "robot": members[0]}
    prod = rp.state["products"].get(pid)
    recipe = rp.model.recipes.get(prod["recipe"]) if prod else None
    op = next((o for o in recipe.operations if o.id == act.get("operation")), None) if recipe else None
    if op is None:
        return {"product": pid, "operation": act.get("operation")}
    out = {"product": pid, "operation": op.id, "consumed": [f"{pid}:{tok}" for tok in op.inputs],
           "produced": f"{pid}:{op.output}"}
    if isinstance(act.get("roles"), dict):  # RES-OUTPUT-HOLDER: rightmost, then topmost input-bound member
        bound = {name for name, binds in op.roles if binds is not None}
        pool = [m for m in members if act["roles"].get(m) in bound] or list(members)
        out["holder"] = min(pool, key=lambda c: (-cell_key(c)[1], cell_key(c)[0]))
    return out


def complete(rp: Replay, act: Json, holder: str | None = None, at: int | None = None) -> None:
    """Apply an activity's effect (R-COMPLETION) and remove it."""
    robots, items = rp.state["robots"], rp.state["items"]
    members, pid = act["members"], act.get("product")
    kind = act["kind"]
    if kind == "pick":
        item, rid = act.get("item"), members[0]
        if robots.get(rid, {}).get("holding") is not None and at is not None:
            rp.bad(at, f"robot {rid} already holds {robots[rid]['holding']} when its pick completes")
        robots[rid]["holding"] = item
        items[item] = rid
    elif kind == "handoff" and len(members) == 2:
        s, r = members
        item = act.get("item")
        if robots[s]["holding"] != item and at is not None:
            rp.bad(at, f"sender {s} holds {robots[s]['holding']!r}, not {item} (R-HANDOFF)")
        robots[s]["holding"] = None
        robots[r]["holding"], robots[r]["incoming"] = item, None
        items[item] = r
    elif kind == "deliver":
        rid = members[0]
        items.pop(act.get("item"), None)
        robots[rid]["holding"] = None
        prod = rp.state["products"].get(pid)
        if prod is not None:
            prod["delivered_at"] = rp.clock
        rp.state["delivered"] += 1
        rp.state["wip"] -= 1
    elif kind == "operation":
        expected = expected_completion(rp, act)
        for item in expected.get("consumed", []):
            where = items.pop(item, None)
            if where in robots:
                robots[where]["holding"] = None
        out = expected.get("produced")
        who = expected.get("holder", holder)
        if out is not None and who in robots:
            robots[who]["holding"] = out
            items[out] = who
        prod = rp.state["products"].get(pid)
        if prod is not None:
            prod["in_progress"].discard(act.get("operation"))
            prod["completed"].add(act.get("operation"))
    rp.done.add(act["id"])
    rp.state["activities"] = [a for a in rp.state["activities"] if a["id"] != act["id"]]
    for m in members:
        if robots.get(m, {}).get("activity") == act["id"]:
            robots[m]["activity"] = None


def replenish(rp: Replay) -> None:
    """R-REPLENISH: no event; one unit per stocked token, capped at the capacity."""
    m = rp.model
    if rp.clock >= 1 and rp.clock % m.replenish_interval == 0:
        for shelf in rp.state["shelves"]:
            for tok in shelf:
                shelf[tok] = min(m.shelf_capacity, int(shelf[tok]) + 1)


def release(rp: Replay, at: int | None, ev: Json | None) -> None:
    """R-RELEASE at ``clock``: one event per opportunity; ``ev`` None closes the step."""
    m, st = rp.model, rp.state
    opportunity = (rp.clock == 0 or rp.clock % m.release_interval == 0) and not (
        m.mode == "batch" and st["released"] >= (m.batch_size or 0))
    seen = rp.released_event
    if ev is None:
        if opportunity and seen is None:
            rp.bad(at, f"epoch {rp.clock} is a release opportunity but the record has no release or "
                   "release_lost event (R-RELEASE)")
        return
    if not opportunity or seen is not None:
        rp.bad(at, f"{ev.get('type')} at epoch {rp.clock}, which is "
               + ("not a release opportunity" if not opportunity else "already released or lost")
               + " (R-RELEASE)")
    rp.released_event = ev
    products = m.instance["realization"]["products"]
    if st["wip"] >= m.wip_cap:
        reason = "wip_cap"
    elif st["released"] >= len(products):
        reason = "realization_exhausted"
    else:
        spec = products[st["released"]]
        ok = all(int(st["shelves"][int(row)].get(tok, 0)) >= 1 for tok, row in spec["source_rows"].items())
        reason = None if ok else "raw_material"
    if ev.get("type") == "release_lost":
        if ev.get("reason") != reason:
            rp.bad(at, f"release_lost gives reason {ev.get('reason')!r}; the state gives "
                   + (f"{reason!r}" if reason else "a release") + " (R-RELEASE, RES-RELEASE-LOST-REASON)")
        st["lost_releases"] += 1
        return
    pid = st["released"]
    if reason is not None:
        rp.bad(at, f"release of product {ev.get('product')} although the opportunity is lost ({reason}, R-RELEASE)")
    if ev.get("product") != pid or pid >= len(products) or ev.get("recipe") != products[pid]["recipe"]:
        want = f"product {pid} ({products[pid]['recipe']})" if pid < len(products) else "none"
        rp.bad(at, f"release of product {ev.get('product')} ({ev.get('recipe')}); the realization's next is {want}")
    if pid < len(products):
        st["products"][pid] = {"recipe": products[pid]["recipe"], "released_at": rp.clock,
                               "due": rp.clock + int(products[pid]["due_offset"]), "completed": set(),
                               "in_progress": set(), "xor": {}, "raw_taken": set(), "delivered_at": None}
    st["released"] += 1
    st["wip"] += 1


HANDLERS = {
    "action_coerced": action_coerced, "pick_started": pick_started,
    "handoff_started": handoff_started, "blocked": blocked,
    "support_switched": support_switched, "proposal_created": proposal_created,
    "support": support, "admitted": admitted, "admission_failed": expiry,
    "proposal_abandoned": expiry, "delivery_started": delivery_started,
    "pick_completed": completion, "handoff_completed": completion,
    "operation_completed": completion, "delivered": completion,
    "release": release, "release_lost": release,
}


__all__ = ["Problem", "Replay", "HANDLERS", "complete", "drop_proposal", "release", "replenish"]
