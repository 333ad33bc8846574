"""F-TRACE-PAIRING: every state change has its event in the same record, and every event its change.

``agspec check`` (F-TRACE-CHECK, code AG609) replays each record's events, in their order, over the
behavioural fields of the state before the record, the way F-TRACE-PAIRING defines each event's
change; the steps without events (the clock, replenishment, the end of every activity whose end has
come, the expiry of every record past its clock, the release opportunity) are applied where
R-TICK-ORDER puts them. The result must equal the state the record carries. Along the way each event
is held to F-TRACE-EMISSION (its step and its place in the step) and to the facts the records show
(the robot's applied action, what it holds, the record it names). A trace whose events were dropped,
doubled, moved to another record or altered, or whose states changed without an event, fails here
even when every invariant holds and its footer was rewritten to match.

Fields the events do not determine are not compared: ``busy_until``, ``switch_lock``, ``ee``, ``q``
(diagnostic, F-TRACE-STATE) and an activity's ``resources``, ``target``, ``roles`` and the phases of
its duration (the invariants and the reference comparison judge those). A ``blocked`` event changes
nothing, so only its step, its order and the attempt it names are checked.

Like the invariants, this module reads traces only: it uses the instance IR (through the read-only
:class:`~agspec.interp.model.Model` view) and never the interpreter's rules.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Iterator, Mapping, Sequence

from agspec.formats.actions import DELIVER, HANDOFF0, N_ACTIONS, OP0, PICK0, PICK_SLOTS, RECEIVE0
from agspec.interp.model import DIRECTIONS, Model
from agspec.trace.emission import (
    ADMISSION,
    COMPLETION,
    EMISSION,
    IN_EPOCH_EXPIRY,
    POST_ADVANCE_EXPIRY,
    RELEASE,
    RESET,
    SUPPORT,
    Step,
    event_key,
)

Json = dict[str, Any]
ROBOT_FIELDS = ("holding", "incoming", "supports", "activity")
ACTIVITY_FIELDS = ("id", "kind", "members", "product", "start", "end", "item", "operation", "candidate",
                   "first_proposed_at")
MAX_STATE_DIFFS = 6  # per record: the first differences say enough


@dataclass(frozen=True)
class Problem:
    """One disagreement: ``record`` indexes the trace's records, ``pointer`` points into that record."""

    record: int
    pointer: str
    message: str


def _cell(robot: Any) -> tuple[int, int]:
    i, j = str(robot).split(",")
    return int(i), int(j)


def _members(candidate: str) -> list[str]:
    """R-IDS: the members of ``op:{z}:{τ}:{i,j;…}``."""
    tail = candidate.rsplit(":", 1)[-1]
    return tail.split(";") if tail else []


def _candidate_op(candidate: str) -> tuple[int, str]:
    parts = candidate.split(":")
    return int(parts[1]), parts[2]


# --------------------------------------------------------------------------- projections


def project(state: Mapping[str, Any]) -> Json:
    """The behavioural fields of a state record that events determine (F-TRACE-PAIRING)."""
    return {
        "released": state["released"], "delivered": state["delivered"], "wip": state["wip"],
        "lost_releases": state["lost_releases"],
        "robots": {rid: {k: r.get(k) for k in ROBOT_FIELDS} for rid, r in state["robots"].items()},
        "products": {int(p["id"]): {"recipe": p["recipe"], "released_at": p["released_at"], "due": p["due"],
                                    "completed": set(p["completed"]), "in_progress": set(p["in_progress"]),
                                    "xor": dict(p["xor"]), "raw_taken": set(p["raw_taken"]),
                                    "delivered_at": p["delivered_at"]}
                     for p in state["products"]},
        "items": dict(state["items"]),
        "shelves": [dict(s) for s in state["shelves"]],
        "proposals": {cid: {"created_at": p["created_at"], "expires_at": p["expires_at"],
                            "supporters": set(p["supporters"])} for cid, p in state["proposals"].items()},
        "activities": [{**{k: a[k] for k in ACTIVITY_FIELDS if k in a}, "roles": a.get("roles")}
                       for a in state["activities"]],
    }


def _initial(instance: Mapping[str, Any], s0: Mapping[str, Any]) -> Json:
    """The state before the reset's events: nothing released, shelves as the realization stocks them."""
    shelves = [dict() for _ in s0["shelves"]]
    for entry in instance["realization"]["shelves"]:
        shelves[int(entry["row"])] = {tok: int(n) for tok, n in entry["stock"].items()}
    return {"released": 0, "delivered": 0, "wip": 0, "lost_releases": 0,
            "robots": {rid: dict.fromkeys(ROBOT_FIELDS) for rid in s0["robots"]}, "products": {}, "items": {},
            "shelves": shelves, "proposals": {}, "activities": []}


def _plain(value: Any) -> Any:
    return sorted(value) if isinstance(value, set) else value


def differences(expected: Json, actual: Json) -> Iterator[tuple[str, Any, Any]]:
    """(pointer into the state, what the events give, what the state has), in a stable order."""
    for key in ("released", "delivered", "wip", "lost_releases"):
        if expected[key] != actual[key]:
            yield f"/state/{key}", expected[key], actual[key]
    for rid in sorted(set(expected["robots"]) | set(actual["robots"]), key=_cell):
        e, a = expected["robots"].get(rid) or {}, actual["robots"].get(rid) or {}
        for k in ROBOT_FIELDS:
            if e.get(k) != a.get(k):
                yield f"/state/robots/{rid}/{k}", e.get(k), a.get(k)
    pids = sorted(set(expected["products"]) | set(actual["products"]))
    for n, pid in enumerate(pids):
        e, a = expected["products"].get(pid), actual["products"].get(pid)
        if e is None or a is None:
            yield f"/state/products/{n}", "absent" if e is None else f"product {pid}", \
                "absent" if a is None else f"product {pid}"
            continue
        for k in e:
            if e[k] != a[k]:
                yield f"/state/products/{n}/{k}", _plain(e[k]), _plain(a[k])
    if expected["items"] != actual["items"]:
        for item in sorted(set(expected["items"]) | set(actual["items"])):
            if expected["items"].get(item) != actual["items"].get(item):
                yield f"/state/items/{item}", expected["items"].get(item), actual["items"].get(item)
    for row, (e, a) in enumerate(zip(expected["shelves"], actual["shelves"])):
        for tok in sorted(set(e) | set(a)):
            if e.get(tok) != a.get(tok):
                yield f"/state/shelves/{row}/{tok}", e.get(tok), a.get(tok)
    for cid in sorted(set(expected["proposals"]) | set(actual["proposals"])):
        e, a = expected["proposals"].get(cid), actual["proposals"].get(cid)
        if e is None or a is None:
            yield f"/state/proposals/{cid}", "absent" if e is None else "open", "absent" if a is None else "open"
            continue
        for k in e:
            if e[k] != a[k]:
                yield f"/state/proposals/{cid}/{k}", _plain(e[k]), _plain(a[k])
    e_ids = [x["id"] for x in expected["activities"]]
    a_ids = [x["id"] for x in actual["activities"]]
    if e_ids != a_ids:
        yield "/state/activities", e_ids, a_ids
        return
    for n, (e, a) in enumerate(zip(expected["activities"], actual["activities"])):
        for k in ACTIVITY_FIELDS:
            if k in e and e.get(k) != a.get(k):
                yield f"/state/activities/{n}/{k}", e.get(k), a.get(k)


# --------------------------------------------------------------------------- one record


@dataclass
class _Replay:
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

    # ---- facts of the record

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

    # ---- walking the steps

    def walk(self, events: Sequence[Json], steps: Sequence[Step]) -> None:
        for at, ev in enumerate(events):
            if not isinstance(ev, dict):
                continue
            key = event_key(ev)
            target = self.place(steps, ev, key)
            if target is None:
                later = [s for s in range(len(steps)) if steps[s].emits(key)]
                self.bad(at, f"{key} comes after the events of step {steps[self.step].step} "
                             f"({', '.join(steps[self.step].rules)}); F-TRACE-EMISSION emits it "
                             + (f"in step {', '.join(str(steps[s].step) for s in later)}" if later else "never"))
                continue
            while self.step < target:
                self.leave(steps, at)
            if steps is not EMISSION:
                self.release(at, ev)
                continue
            self.apply(at, ev, key)
        while self.step < len(steps):
            self.leave(steps, None)

    def place(self, steps: Sequence[Step], ev: Json, key: str) -> int | None:
        """The step this event belongs to: the first one at or after the current step that emits it
        and where it may stand (its order key after the step's last one; an expiry it can explain)."""
        first = None
        for s in range(self.step, len(steps)):
            if not steps[s].emits(key):
                continue
            if steps is EMISSION and s in (IN_EPOCH_EXPIRY, POST_ADVANCE_EXPIRY) and not self.may_expire(s, ev):
                first = s if first is None else first
                continue
            if s > self.step or self.in_order(steps[s], ev):
                return s
            first = s if first is None else first
        return first

    def in_order(self, step: Step, ev: Json) -> bool:
        key = self.order_key(step, ev)
        return key is None or self.last_key is None or key > self.last_key

    def order_key(self, step: Step, ev: Json) -> Any:
        try:
            if step.order in ("robot", "sender"):
                who = ev.get("sender") if step.order == "sender" else ev.get("robot")
                if step is EMISSION[SUPPORT] and ev.get("type") != "support_switched":
                    return None  # keyed by the group's robot when the group closes (its support)
                return _cell(who)
            if step.order == "candidate":
                return str(ev.get("candidate"))
            if step.order == "creation":  # a completion doubled is reported as such, not as out of order
                aid = ev.get("activity")
                return self.completing.index(aid) if aid in self.completing and aid not in self.done else None
        except (ValueError, AttributeError):
            return None
        return None

    def may_expire(self, s: int, ev: Json) -> bool:
        prop = self.state["proposals"].get(ev.get("candidate"))
        if prop is None:
            return True  # reported where it is applied
        epoch = self.t if s == IN_EPOCH_EXPIRY else self.t + 1
        if ev.get("type") == "admission_failed" and ev.get("reason") == "expired":
            return epoch > prop["expires_at"]
        if s == POST_ADVANCE_EXPIRY:
            return ev.get("type") == "proposal_abandoned" and epoch > prop["expires_at"]
        # in-epoch and not expired: the candidate left C_t (RES-INVALID-EXPIRY)
        c_t = self.c_t()
        return ev.get("candidate") not in self.in_c_t and (c_t is None or ev.get("candidate") not in c_t)

    def leave(self, steps: Sequence[Step], at: int | None) -> None:
        """Close the current step (what it owes) and enter the next one."""
        s = self.step
        if steps is RESET_STEPS:
            self.release(at, None)
            self.step += 1
            return
        if s == SUPPORT and self.group is not None:
            self.bad(at, f"{self.group['opened_by']} is not followed by the support that completes it (F-TRACE-EMISSION)")
            self.group = None
        if s == IN_EPOCH_EXPIRY:
            c_t = self.c_t()
            if c_t is not None:
                for cid in sorted(self.state["proposals"]):
                    if cid not in c_t:
                        self.bad(at, f"support record {cid} is not in C_t (no robot is offered it) but is not removed "
                                     "in this epoch (R-EXPIRY)")
                        self.drop_proposal(cid)
        if s == COMPLETION - 1:  # after the deliveries: step 8, R-CLOCK
            self.clock = self.t + 1
            self.completing = [a["id"] for a in self.state["activities"] if int(a["end"]) <= self.clock]
        if s == COMPLETION:
            for aid in self.completing:
                if aid not in self.done:
                    act = self.activity(aid)
                    self.bad(at, f"activity {aid} ends at {self.clock} but the record has no completion event for it "
                                 "(R-COMPLETION)")
                    if act is not None:
                        self.complete(act)
            self.replenish()
        if s == RELEASE:
            self.release(at, None)
        if s == POST_ADVANCE_EXPIRY:
            for cid in sorted(self.state["proposals"]):
                if self.clock > self.state["proposals"][cid]["expires_at"]:
                    self.bad(at, f"support record {cid} expires at {self.state['proposals'][cid]['expires_at']} but "
                                 f"is not removed at {self.clock} (R-SUPPORT-LIFECYCLE, R-EXPIRY)")
                    self.drop_proposal(cid)
        self.step += 1
        self.last_key = None

    def note_order(self, at: int, ev: Json) -> None:
        step = EMISSION[self.step]
        key = self.order_key(step, ev)
        if key is None:
            return
        if self.last_key is not None and not key > self.last_key:
            self.bad(at, f"{event_key(ev)} is out of order in step {step.step}: F-TRACE-EMISSION orders its attempts "
                         f"by {step.order} ({', '.join(step.rules)})")
        self.last_key = key

    # ---- the events

    def apply(self, at: int, ev: Json, key: str) -> None:
        if self.step != SUPPORT or ev.get("type") == "support_switched":
            self.note_order(at, ev)
        handler = HANDLERS.get(ev.get("type"))
        if handler is not None:
            handler(self, at, ev)

    def action_coerced(self, at: int, ev: Json) -> None:
        rid = ev.get("robot")
        if self.robot(rid) is None:
            self.bad(at, f"action_coerced names {rid!r}, which is no robot")
            return
        if self.applied(rid) != 0:
            self.bad(at, f"robot {rid}'s action was coerced to idle, but the record applies {self.applied(rid)} "
                         "(R-ACTION-VALIDATION)")
        if ev.get("action") == 0:
            self.bad(at, "idle is always legal; it is never coerced (R-ACTION-VALIDATION)")
        if self.chosen is not None and self.chosen.get(rid) != ev.get("action"):
            self.bad(at, f"robot {rid} submitted {self.chosen.get(rid)!r} (`chosen`), not {ev.get('action')!r}")
        self.coerced.add(rid)

    def _start(self, at: int, ev: Json, kind: str, members: list[str], expected_id: str, **fields: Any) -> None:
        if ev.get("activity") != expected_id:
            self.bad(at, f"the activity is `{ev.get('activity')}`; R-IDS names it `{expected_id}`")
        end = ev.get("end")
        if not isinstance(end, int) or end <= self.t:
            self.bad(at, f"an activity started at {self.t} cannot end at {end!r} (G-DURATION: D >= 1)")
            end = self.t + 1
        act = {"id": ev.get("activity"), "kind": kind, "members": members, "start": self.t, "end": end, **fields}
        self.state["activities"].append(act)
        for m in members:
            if self.robot(m) is not None:
                self.robot(m)["activity"] = act["id"]

    def pick_started(self, at: int, ev: Json) -> None:
        rid, pid, tok, row = ev.get("robot"), ev.get("product"), ev.get("token"), ev.get("shelf_row")
        self.check_attempt(at, ev)
        prod = self.state["products"].get(pid)
        recipe = self.model.recipes.get(prod["recipe"]) if prod else None
        shelf = self.state["shelves"][row] if isinstance(row, int) and 0 <= row < len(self.state["shelves"]) else None
        if prod is None or recipe is None or prod["delivered_at"] is not None:
            self.bad(at, f"product {pid} is not released and undelivered (R-PICK)")
        elif tok not in recipe.raw or tok in prod["raw_taken"]:
            self.bad(at, f"token {tok!r} is not a raw token of product {pid} still to pick (R-PICK)")
        if shelf is None or int(shelf.get(tok, 0)) < 1:
            self.bad(at, f"shelf row {row!r} has no unit of {tok!r} (R-PICK)")
        else:
            shelf[tok] -= 1
        if prod is not None:
            prod["raw_taken"].add(tok)
        self._start(at, ev, "pick", [rid], f"pick@{self.t}:{pid}:{tok}:{rid}", product=pid, item=f"{pid}:{tok}")

    def handoff_started(self, at: int, ev: Json) -> None:
        s, r, item = ev.get("sender"), ev.get("receiver"), ev.get("item")
        self.check_attempt(at, ev)
        if self.robot(r) is not None:
            self.robot(r)["incoming"] = item
        pid = int(str(item).split(":")[0]) if str(item).split(":")[0].isdigit() else None
        self._start(at, ev, "handoff", [s, r], f"handoff@{self.t}:{item}:{s}>{r}", product=pid, item=item)

    def check_attempt(self, at: int, ev: Json) -> None:
        """A start or a blocked attempt: the robots applied the matching action and could attempt it."""
        kind = ev.get("kind")
        if kind == "pick":
            rid = ev.get("robot")
            a = self.applied(rid)
            if not PICK0 <= a < PICK0 + PICK_SLOTS:
                self.bad(at, f"robot {rid} applied action {a}, not a pick (R-PICK)")
            else:
                offered = self.option(rid, "pick", a - PICK0)
                want = f"pick:{ev.get('product')}:{ev.get('token')}:"
                if offered is not None and not (offered.startswith(want) and (
                        "shelf_row" not in ev or offered == f"{want}{ev.get('shelf_row')}")):
                    self.bad(at, f"robot {rid}'s pick slot {a - PICK0} is `{offered}`, not product {ev.get('product')} "
                                 f"token {ev.get('token')} (O-PICK-OPTIONS)")
            self.check_holding(at, rid, None, "pick")
        elif kind == "handoff":
            s, r = ev.get("sender"), ev.get("receiver")
            try:
                d = DIRECTIONS.index((_cell(r)[0] - _cell(s)[0], _cell(r)[1] - _cell(s)[1]))
            except (ValueError, AttributeError):
                self.bad(at, f"{r} is not a direction neighbour of {s} (R-HANDOFF)")
                return
            back = DIRECTIONS.index((-DIRECTIONS[d][0], -DIRECTIONS[d][1]))
            if self.applied(s) != HANDOFF0 + d or self.applied(r) != RECEIVE0 + back:
                self.bad(at, f"a handoff from {s} to {r} needs handoff({d}) and receive({back}); the record applies "
                             f"{self.applied(s)} and {self.applied(r)} (R-HANDOFF)")
            self.check_holding(at, s, ev.get("item"), "handoff")
            self.check_holding(at, r, None, "handoff")
        elif kind == "deliver":
            rid, pid = ev.get("robot"), ev.get("product")
            if self.applied(rid) != DELIVER:
                self.bad(at, f"robot {rid} applied action {self.applied(rid)}, not deliver (R-DELIVERY)")
            prod = self.state["products"].get(pid)
            if prod is None or prod["delivered_at"] is not None:
                self.bad(at, f"product {pid} is not released and undelivered (R-DELIVERY)")
            self.check_holding(at, rid, self.terminal(pid) if prod else None, "deliver", must_hold=True)
            if isinstance(rid, str) and _cell(rid)[1] != self.model.cols - 1:
                self.bad(at, f"robot {rid} is not in the output column {self.model.cols - 1} (R-DELIVERY)")

    def check_holding(self, at: int, rid: Any, item: str | None, what: str, must_hold: bool = False) -> None:
        r = self.robot(rid)
        if r is None:
            self.bad(at, f"{rid!r} is no robot")
            return
        if not self.free(rid):
            self.bad(at, f"robot {rid} is not free (member of {r['activity']}, incoming {r['incoming']}); "
                         f"a {what} needs free robots")
        if r["holding"] != item and (item is not None or not must_hold):
            self.bad(at, f"robot {rid} holds {r['holding']!r}; the {what} needs it to hold {item!r}")

    def blocked(self, at: int, ev: Json) -> None:
        if ev.get("kind") == "operation":
            cid = ev.get("candidate")
            self.check_supported(at, cid, "blocked")
            self.in_c_t.add(cid)
        else:
            self.check_attempt(at, ev)

    def support_switched(self, at: int, ev: Json) -> None:
        rid, old, new = ev.get("robot"), ev.get("from"), ev.get("to")
        self.open_group(at, ev, rid, new, "support_switched")
        r = self.robot(rid)
        if r is None:
            return
        if r["supports"] != old or old == new:
            self.bad(at, f"robot {rid} supports {r['supports']!r}; it cannot switch from {old!r} to {new!r} "
                         "(R-SUPPORT)")
        if old in self.state["proposals"]:
            self.state["proposals"][old]["supporters"].discard(rid)
        r["supports"] = None

    def proposal_created(self, at: int, ev: Json) -> None:
        cid = ev.get("candidate")
        if self.group is None:
            self.open_group(at, ev, None, cid, "proposal_created")
        elif self.group["candidate"] != cid:
            self.bad(at, f"proposal_created for {cid} follows a switch to {self.group['candidate']} (F-TRACE-EMISSION)")
        self.group["created"] = True
        if cid in self.state["proposals"]:
            self.bad(at, f"support record {cid} already exists (R-SUPPORT-LIFECYCLE: one record per candidate)")
        if ev.get("expires_at") != self.t + self.model.support_timeout:
            self.bad(at, f"a record created at {self.t} expires at {self.t + self.model.support_timeout} "
                         f"(R-SUPPORT-LIFECYCLE), not {ev.get('expires_at')!r}")
        self.state["proposals"][cid] = {"created_at": self.t, "expires_at": ev.get("expires_at"), "supporters": set()}

    def open_group(self, at: int, ev: Json, rid: Any, cid: Any, opened_by: str) -> None:
        if self.group is not None:
            self.bad(at, f"{self.group['opened_by']} is not followed by the support that completes it (F-TRACE-EMISSION)")
        self.group = {"robot": rid, "candidate": cid, "opened_by": opened_by, "created": False}

    def support(self, at: int, ev: Json) -> None:
        rid, cid = ev.get("robot"), ev.get("candidate")
        group, self.group = self.group, None
        if group is not None and (group["robot"] not in (None, rid) or group["candidate"] != cid):
            self.bad(at, f"support of {cid} by {rid} does not complete the {group['opened_by']} before it "
                         f"({group['robot']} -> {group['candidate']}) (F-TRACE-EMISSION)")
        key = None
        try:
            key = _cell(rid)
        except (ValueError, AttributeError):
            pass
        if group is None or group["robot"] is None:  # the group's order key is its support's robot
            if key is not None and self.last_key is not None and not key > self.last_key:
                self.bad(at, "support is out of order in step 5: F-TRACE-EMISSION orders the supports by robot "
                             "(R-SUPPORT)")
            self.last_key = key if key is not None else self.last_key
        self.in_c_t.add(cid)
        r = self.robot(rid)
        if r is None:
            self.bad(at, f"support names {rid!r}, which is no robot")
            return
        a = self.applied(rid)
        if not OP0 <= a < N_ACTIONS:
            self.bad(at, f"robot {rid} applied action {a}, not an operation slot (R-SUPPORT)")
        elif self.option(rid, "operation", a - OP0) not in (None, cid):
            self.bad(at, f"robot {rid}'s operation slot {a - OP0} is `{self.option(rid, 'operation', a - OP0)}`, "
                         f"not {cid} (O-OPERATION-OPTIONS)")
        if r["supports"] == cid:
            self.bad(at, f"robot {rid} already supports {cid}: re-selecting it changes nothing and emits nothing "
                         "(R-SUPPORT)")
        elif r["supports"] is not None:
            self.bad(at, f"robot {rid} supports {r['supports']}; a switch emits support_switched first (R-SUPPORT)")
        if not isinstance(cid, str) or rid not in _members(cid):
            self.bad(at, f"robot {rid} is not a member of {cid} (R-SUPPORT)")
        prop = self.state["proposals"].get(cid)
        if prop is None:
            self.bad(at, f"no support record of {cid} exists; its first supporter creates it with proposal_created "
                         "(R-SUPPORT-LIFECYCLE)")
            prop = self.state["proposals"][cid] = {"created_at": self.t, "expires_at": self.t + self.model.support_timeout,
                                                   "supporters": set()}
        prop["supporters"].add(rid)
        r["supports"] = cid

    def check_supported(self, at: int, cid: Any, what: str) -> Json | None:
        prop = self.state["proposals"].get(cid)
        if prop is None:
            self.bad(at, f"{what} names {cid}, which has no open support record (R-ADMISSION)")
            return None
        members = _members(cid)
        if prop["supporters"] != set(members) or any((self.robot(m) or {}).get("supports") != cid for m in members):
            self.bad(at, f"{what} names {cid}, which is not fully supported: supporters "
                         f"{sorted(prop['supporters'])}, members {members} (R-ADMISSION)")
        return prop

    def admitted(self, at: int, ev: Json) -> None:
        cid = ev.get("candidate")
        prop = self.check_supported(at, cid, "admitted")
        self.in_c_t.add(cid)
        members = _members(cid) if isinstance(cid, str) else []
        try:
            pid, op = _candidate_op(cid)
        except (ValueError, IndexError, AttributeError):
            self.bad(at, f"{cid!r} is not a candidate id (R-IDS)")
            return
        for m in members:
            if not self.free(m):
                self.bad(at, f"member {m} of {cid} is not free (R-ADMISSION)")
        prod = self.state["products"].get(pid)
        recipe = self.model.recipes.get(prod["recipe"]) if prod else None
        spec = next((o for o in recipe.operations if o.id == op), None) if recipe else None
        if prod is None or spec is None:
            self.bad(at, f"{cid} names no operation of a released product (R-ADMISSION)")
        else:
            if op in prod["completed"] or op in prod["in_progress"]:
                self.bad(at, f"operation {op} of product {pid} is already {'completed' if op in prod['completed'] else 'in progress'}")
            if spec.xor_group is not None and prod["xor"].get(spec.xor_group) not in (None, op):
                self.bad(at, f"XOR group {spec.xor_group} of product {pid} chose {prod['xor'][spec.xor_group]} (R-XOR-CLOSURE)")
            prod["in_progress"].add(op)
            if spec.xor_group is not None:
                prod["xor"][spec.xor_group] = op
        created = prop["created_at"] if prop else self.t
        if ev.get("latency") != self.t - created:
            self.bad(at, f"latency {ev.get('latency')!r}: the record of {cid} was created at {created}, so it is "
                         f"{self.t - created} (M-ADMISSION-LATENCY)")
        self.state["proposals"].pop(cid, None)
        for m in members:
            if self.robot(m) is not None:
                self.robot(m)["supports"] = None
        self._start(at, ev, "operation", members, f"op@{self.t}:{cid}", product=pid, operation=op, candidate=cid,
                    first_proposed_at=created, roles=None)

    def expiry(self, at: int, ev: Json) -> None:
        cid = ev.get("candidate")
        prop = self.state["proposals"].get(cid)
        if prop is None:
            self.bad(at, f"{ev.get('type')} names {cid}, which has no open support record (R-EXPIRY)")
            return
        failed = ev.get("type") == "admission_failed"
        if failed != bool(prop["supporters"]):
            self.bad(at, f"support record {cid} has supporters {sorted(prop['supporters'])}: its removal is "
                         f"{'admission_failed' if prop['supporters'] else 'proposal_abandoned'} (R-EXPIRY)")
        if self.step == POST_ADVANCE_EXPIRY:
            if self.clock <= prop["expires_at"]:
                self.bad(at, f"support record {cid} expires at {prop['expires_at']}; it is not removed at "
                             f"{self.clock} (R-SUPPORT-LIFECYCLE)")
            if failed and ev.get("reason") != "expired":
                self.bad(at, "a record removed after the clock advance has expired (R-EXPIRY): reason `expired`")
        elif failed and ev.get("reason") == "expired" and self.t <= prop["expires_at"]:
            self.bad(at, f"support record {cid} is eligible until {prop['expires_at']}; it has not expired at "
                         f"{self.t} (R-SUPPORT-LIFECYCLE)")
        elif self.t <= prop["expires_at"] and cid in self.in_c_t:
            self.bad(at, f"{cid} was supported or attempted in this epoch, so it is in C_t: its record is not "
                         "invalid (RES-INVALID-EXPIRY)")
        self.drop_proposal(cid)

    def drop_proposal(self, cid: str) -> None:
        prop = self.state["proposals"].pop(cid)
        for rid in prop["supporters"]:
            r = self.robot(rid)
            if r is not None and r["supports"] == cid:
                r["supports"] = None

    def delivery_started(self, at: int, ev: Json) -> None:
        rid, pid = ev.get("robot"), ev.get("product")
        self.check_attempt(at, ev)
        self._start(at, ev, "deliver", [rid], f"deliver@{self.t}:{pid}:{rid}", product=pid, item=self.terminal(pid))

    # ---- completions (step 9)

    def activity(self, aid: Any) -> Json | None:
        return next((a for a in self.state["activities"] if a["id"] == aid), None)

    def completion(self, at: int, ev: Json) -> None:
        aid = ev.get("activity")
        act = self.activity(aid)
        kind = {"pick_completed": "pick", "handoff_completed": "handoff", "operation_completed": "operation",
                "delivered": "deliver"}[ev["type"]]
        if act is None or aid not in self.completing or aid in self.done:
            why = ("completed already in this record" if aid in self.done else "is not running" if act is None
                   else f"ends at {act['end']}")
            self.bad(at, f"{ev['type']} of {aid}, which {why}: a completion is emitted in the transition into its "
                         f"end epoch, once (R-COMPLETION)")
            return
        if act["kind"] != kind:
            self.bad(at, f"{ev['type']} completes {aid}, a {act['kind']} activity")
            return
        expected = self.expected_completion(act)
        for k, v in expected.items():
            if ev.get(k) != v:
                self.bad(at, f"{ev['type']} of {aid}: `{k}` is {ev.get(k)!r}; the activity gives {v!r} (R-COMPLETION)")
        if kind == "operation" and act.get("roles") is None and ev.get("holder") not in act["members"]:
            self.bad(at, f"{ev.get('holder')!r} is no member of {aid} (RES-OUTPUT-HOLDER)")
        self.complete(act, ev.get("holder") if kind == "operation" and "holder" not in expected else None, at)

    def expected_completion(self, act: Json) -> Json:
        members, pid = act["members"], act.get("product")
        if act["kind"] == "pick":
            return {"robot": members[0], "item": act.get("item")}
        if act["kind"] == "handoff":
            return {"sender": members[0], "receiver": members[1] if len(members) > 1 else None, "item": act.get("item")}
        if act["kind"] == "deliver":
            return {"product": pid, "robot": members[0]}
        prod = self.state["products"].get(pid)
        recipe = self.model.recipes.get(prod["recipe"]) if prod else None
        op = next((o for o in recipe.operations if o.id == act.get("operation")), None) if recipe else None
        if op is None:
            return {"product": pid, "operation": act.get("operation")}
        out = {"product": pid, "operation": op.id, "consumed": [f"{pid}:{tok}" for tok in op.inputs],
               "produced": f"{pid}:{op.output}"}
        if isinstance(act.get("roles"), dict):  # RES-OUTPUT-HOLDER: rightmost, then topmost input-bound member
            bound = {name for name, binds in op.roles if binds is not None}
            pool = [m for m in members if act["roles"].get(m) in bound] or list(members)
            out["holder"] = min(pool, key=lambda c: (-_cell(c)[1], _cell(c)[0]))
        return out

    def complete(self, act: Json, holder: str | None = None, at: int | None = None) -> None:
        """Apply an activity's effect (R-COMPLETION) and remove it."""
        robots, items = self.state["robots"], self.state["items"]
        members, pid = act["members"], act.get("product")
        kind = act["kind"]
        if kind == "pick":
            item, rid = act.get("item"), members[0]
            if robots.get(rid, {}).get("holding") is not None and at is not None:
                self.bad(at, f"robot {rid} already holds {robots[rid]['holding']} when its pick completes")
            robots[rid]["holding"] = item
            items[item] = rid
        elif kind == "handoff" and len(members) == 2:
            s, r = members
            item = act.get("item")
            if robots[s]["holding"] != item and at is not None:
                self.bad(at, f"sender {s} holds {robots[s]['holding']!r}, not {item} (R-HANDOFF)")
            robots[s]["holding"] = None
            robots[r]["holding"], robots[r]["incoming"] = item, None
            items[item] = r
        elif kind == "deliver":
            rid = members[0]
            items.pop(act.get("item"), None)
            robots[rid]["holding"] = None
            prod = self.state["products"].get(pid)
            if prod is not None:
                prod["delivered_at"] = self.clock
            self.state["delivered"] += 1
            self.state["wip"] -= 1
        elif kind == "operation":
            expected = self.expected_completion(act)
            for item in expected.get("consumed", []):
                where = items.pop(item, None)
                if where in robots:
                    robots[where]["holding"] = None
            out = expected.get("produced")
            who = expected.get("holder", holder)
            if out is not None and who in robots:
                robots[who]["holding"] = out
                items[out] = who
            prod = self.state["products"].get(pid)
            if prod is not None:
                prod["in_progress"].discard(act.get("operation"))
                prod["completed"].add(act.get("operation"))
        self.done.add(act["id"])
        self.state["activities"] = [a for a in self.state["activities"] if a["id"] != act["id"]]
        for m in members:
            if robots.get(m, {}).get("activity") == act["id"]:
                robots[m]["activity"] = None

    # ---- steps 10, 12

    def replenish(self) -> None:
        """R-REPLENISH: no event; one unit per stocked token, capped at the capacity."""
        m = self.model
        if self.clock >= 1 and self.clock % m.replenish_interval == 0:
            for shelf in self.state["shelves"]:
                for tok in shelf:
                    shelf[tok] = min(m.shelf_capacity, int(shelf[tok]) + 1)

    def release(self, at: int | None, ev: Json | None) -> None:
        """R-RELEASE at ``clock``: one event per opportunity; ``ev`` None closes the step."""
        m, st = self.model, self.state
        opportunity = (self.clock == 0 or self.clock % m.release_interval == 0) and not (
            m.mode == "batch" and st["released"] >= (m.batch_size or 0))
        seen = self.released_event
        if ev is None:
            if opportunity and seen is None:
                self.bad(at, f"epoch {self.clock} is a release opportunity but the record has no release or "
                             "release_lost event (R-RELEASE)")
            return
        if not opportunity or seen is not None:
            self.bad(at, f"{ev.get('type')} at epoch {self.clock}, which is "
                         + ("not a release opportunity" if not opportunity else "already released or lost")
                         + " (R-RELEASE)")
        self.released_event = ev
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
                self.bad(at, f"release_lost gives reason {ev.get('reason')!r}; the state gives "
                             + (f"{reason!r}" if reason else "a release") + " (R-RELEASE, RES-RELEASE-LOST-REASON)")
            st["lost_releases"] += 1
            return
        pid = st["released"]
        if reason is not None:
            self.bad(at, f"release of product {ev.get('product')} although the opportunity is lost ({reason}, R-RELEASE)")
        if ev.get("product") != pid or pid >= len(products) or ev.get("recipe") != products[pid]["recipe"]:
            want = f"product {pid} ({products[pid]['recipe']})" if pid < len(products) else "none"
            self.bad(at, f"release of product {ev.get('product')} ({ev.get('recipe')}); the realization's next is {want}")
        if pid < len(products):
            st["products"][pid] = {"recipe": products[pid]["recipe"], "released_at": self.clock,
                                   "due": self.clock + int(products[pid]["due_offset"]), "completed": set(),
                                   "in_progress": set(), "xor": {}, "raw_taken": set(), "delivered_at": None}
        st["released"] += 1
        st["wip"] += 1


HANDLERS = {
    "action_coerced": _Replay.action_coerced, "pick_started": _Replay.pick_started,
    "handoff_started": _Replay.handoff_started, "blocked": _Replay.blocked,
    "support_switched": _Replay.support_switched, "proposal_created": _Replay.proposal_created,
    "support": _Replay.support, "admitted": _Replay.admitted, "admission_failed": _Replay.expiry,
    "proposal_abandoned": _Replay.expiry, "delivery_started": _Replay.delivery_started,
    "pick_completed": _Replay.completion, "handoff_completed": _Replay.completion,
    "operation_completed": _Replay.completion, "delivered": _Replay.completion,
    "release": _Replay.release, "release_lost": _Replay.release,
}
RESET_STEPS = (RESET,)


# --------------------------------------------------------------------------- the trace


def pair_records(records: Sequence[Json]) -> tuple[list[Problem], int]:
    """F-TRACE-PAIRING over a trace (header first): the problems, and the number of records paired.

    Records whose fields are not of the trace schema's types are skipped (the schema reports them).
    """
    if not records or records[0].get("type") != "header":
        return [], 0
    header = records[0]
    try:
        model = Model.from_instance(dict(header["instance"]))
        before = _initial(header["instance"], header["state"])
        after = project(header["state"])
    except (KeyError, TypeError, ValueError, AttributeError, IndexError):
        return [], 0
    problems: list[Problem] = []
    paired = 0
    replay = _Replay(model, 0, int(header["state"].get("t", 0)), before, {}, None, None)
    replay.clock = replay.t
    replay.walk(header.get("events") or [], RESET_STEPS)
    problems += replay.problems + _compare(0, replay.state, after)
    paired += 1
    previous = header["state"]
    for index, rec in enumerate(records[1:], start=1):
        if rec.get("type") != "tick":
            continue
        try:
            state, previous = previous, rec["state"]
            before, after = project(state), project(previous)  # two projections: the replay changes `before`
            obs = rec.get("observations") if isinstance(rec.get("observations"), dict) else None
            chosen = rec.get("chosen") if isinstance(rec.get("chosen"), dict) else None
            replay = _Replay(model, index, int(rec["t"]), before, dict(rec.get("actions") or {}), chosen, obs)
            replay.clock = replay.t
            replay.walk(rec.get("events") or [], EMISSION)
            if chosen is not None:
                for rid in sorted(set(chosen) - replay.coerced):
                    replay.bad(None, f"robot {rid} submitted {chosen[rid]} (`chosen`) and applied "
                                     f"{replay.applied(rid)}, but the record has no action_coerced for it")
        except (KeyError, TypeError, ValueError, AttributeError, IndexError):
            continue
        problems += replay.problems + _compare(index, replay.state, after)
        paired += 1
    return problems, paired


def _compare(index: int, expected: Json, actual: Json) -> list[Problem]:
    out = []
    for pointer, want, have in differences(expected, actual):
        out.append(Problem(index, pointer, f"the record's events give {want!r}, the state has {have!r} "
                                           "(a state change without its event, or an event without its change)"))
        if len(out) >= MAX_STATE_DIFFS:
            break
    return out


__all__ = ["Problem", "pair_records", "project", "differences"]
