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

from typing import Any, Sequence

from agspec.interp.model import Model
from agspec.trace.effects import HANDLERS, Problem, Replay, complete, drop_proposal, release, replenish
from agspec.trace.emission import COMPLETION, EMISSION, IN_EPOCH_EXPIRY, POST_ADVANCE_EXPIRY, RELEASE, RESET, SUPPORT
from agspec.trace.emission import Step, event_key
from agspec.trace.projection import Json, cell_key, differences, initial, project

MAX_STATE_DIFFS = 6  # per record: the first differences say enough
RESET_STEPS = (RESET,)


# --------------------------------------------------------------------------- walking a record's steps


def walk(rp: Replay, events: Sequence[Json], steps: Sequence[Step]) -> None:
    """Place each event in its step (F-TRACE-EMISSION), closing the steps it passes, and apply it."""
    for at, ev in enumerate(events):
        if not isinstance(ev, dict):
            continue
        key = event_key(ev)
        target = place(rp, steps, ev, key)
        if target is None:
            later = [s for s in range(len(steps)) if steps[s].emits(key)]
            rp.bad(at, f"{key} comes after the events of step {steps[rp.step].step} "
                   f"({', '.join(steps[rp.step].rules)}); F-TRACE-EMISSION emits it "
                   + (f"in step {', '.join(str(steps[s].step) for s in later)}" if later else "never"))
            continue
        while rp.step < target:
            leave(rp, steps, at)
        if steps is not EMISSION:
            release(rp, at, ev)
            continue
        apply(rp, at, ev)
    while rp.step < len(steps):
        leave(rp, steps, None)


def place(rp: Replay, steps: Sequence[Step], ev: Json, key: str) -> int | None:
    """The step this event belongs to: the first one at or after the current step that emits it
    and where it may stand (its order key after the step's last one; an expiry it can explain)."""
    first = None
    for s in range(rp.step, len(steps)):
        if not steps[s].emits(key):
            continue
        if steps is EMISSION and s in (IN_EPOCH_EXPIRY, POST_ADVANCE_EXPIRY) and not may_expire(rp, s, ev):
            first = s if first is None else first
            continue
        if s > rp.step or in_order(rp, steps[s], ev):
            return s
        first = s if first is None else first
    return first


def in_order(rp: Replay, step: Step, ev: Json) -> bool:
    key = order_key(rp, step, ev)
    return key is None or rp.last_key is None or key > rp.last_key


def order_key(rp: Replay, step: Step, ev: Json) -> Any:
    """The event's attempt key in the order of its step (None: not ordered by itself)."""
    try:
        if step.order in ("robot", "sender"):
            who = ev.get("sender") if step.order == "sender" else ev.get("robot")
            if step is EMISSION[SUPPORT] and ev.get("type") != "support_switched":
                return None  # keyed by the group's robot when the group closes (its support)
            return cell_key(who)
        if step.order == "candidate":
            return str(ev.get("candidate"))
        if step.order == "creation":  # a completion doubled is reported as such, not as out of order
            aid = ev.get("activity")
            return rp.completing.index(aid) if aid in rp.completing and aid not in rp.done else None
    except (ValueError, AttributeError):
        return None
    return None


def may_expire(rp: Replay, s: int, ev: Json) -> bool:
    """Whether a removal event can stand in expiry step ``s`` (in-epoch or post-advance, R-EXPIRY)."""
    prop = rp.state["proposals"].get(ev.get("candidate"))
    if prop is None:
        return True  # reported where it is applied
    epoch = rp.t if s == IN_EPOCH_EXPIRY else rp.t + 1
    if ev.get("type") == "admission_failed" and ev.get("reason") == "expired":
        return epoch > prop["expires_at"]
    if s == POST_ADVANCE_EXPIRY:
        return ev.get("type") == "proposal_abandoned" and epoch > prop["expires_at"]
    # in-epoch and not expired: the candidate left C_t (RES-INVALID-EXPIRY)
    c_t = rp.c_t()
    return ev.get("candidate") not in rp.in_c_t and (c_t is None or ev.get("candidate") not in c_t)


def leave(rp: Replay, steps: Sequence[Step], at: int | None) -> None:
    """Close the current step (what it owes) and enter the next one."""
    s = rp.step
    if steps is RESET_STEPS:
        release(rp, at, None)
        rp.step += 1
        return
    if s == SUPPORT and rp.group is not None:
        rp.bad(at, f"{rp.group['opened_by']} is not followed by the support that completes it (F-TRACE-EMISSION)")
        rp.group = None
    if s == IN_EPOCH_EXPIRY:
        c_t = rp.c_t()
        if c_t is not None:
            for cid in sorted(rp.state["proposals"]):
                if cid not in c_t:
                    rp.bad(at, f"support record {cid} is not in C_t (no robot is offered it) but is not removed "
                           "in this epoch (R-EXPIRY)")
                    drop_proposal(rp, cid)
    if s == COMPLETION - 1:  # after the deliveries: step 8, R-CLOCK
        rp.clock = rp.t + 1
        rp.completing = [a["id"] for a in rp.state["activities"] if int(a["end"]) <= rp.clock]
    if s == COMPLETION:
        for aid in rp.completing:
            if aid not in rp.done:
                act = rp.activity(aid)
                rp.bad(at, f"activity {aid} ends at {rp.clock} but the record has no completion event for it "
                       "(R-COMPLETION)")
                if act is not None:
                    complete(rp, act)
        replenish(rp)
    if s == RELEASE:
        release(rp, at, None)
    if s == POST_ADVANCE_EXPIRY:
        for cid in sorted(rp.state["proposals"]):
            if rp.clock > rp.state["proposals"][cid]["expires_at"]:
                rp.bad(at, f"support record {cid} expires at {rp.state['proposals'][cid]['expires_at']} but "
                       f"is not removed at {rp.clock} (R-SUPPORT-LIFECYCLE, R-EXPIRY)")
                drop_proposal(rp, cid)
    rp.step += 1
    rp.last_key = None


def note_order(rp: Replay, at: int, ev: Json) -> None:
    step = EMISSION[rp.step]
    key = order_key(rp, step, ev)
    if key is None:
        return
    if rp.last_key is not None and not key > rp.last_key:
        rp.bad(at, f"{event_key(ev)} is out of order in step {step.step}: F-TRACE-EMISSION orders its attempts "
               f"by {step.order} ({', '.join(step.rules)})")
    rp.last_key = key


def apply(rp: Replay, at: int, ev: Json) -> None:
    """Note the event's order in its step and apply its change (:data:`agspec.trace.effects.HANDLERS`)."""
    if rp.step != SUPPORT or ev.get("type") == "support_switched":
        note_order(rp, at, ev)
    handler = HANDLERS.get(ev.get("type"))
    if handler is not None:
        handler(rp, at, ev)


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
        before = initial(header["instance"], header["state"])
        after = project(header["state"])
    except (KeyError, TypeError, ValueError, AttributeError, IndexError):
        return [], 0
    problems: list[Problem] = []
    paired = 0
    if header.get("events") is not None:  # null: the implementation reports no events (F-TRACE)
        replay = Replay(model, 0, int(header["state"].get("t", 0)), before, {}, None, None)
        replay.clock = replay.t
        walk(replay, header["events"], RESET_STEPS)
        problems += replay.problems + _compare(0, replay.state, after)
        paired += 1
    previous = header["state"]
    for index, rec in enumerate(records[1:], start=1):
        if rec.get("type") != "tick":
            continue
        if rec.get("events") is None:
            previous = rec.get("state", previous)
            continue
        try:
            state, previous = previous, rec["state"]
            before, after = project(state), project(previous)  # two projections: the replay changes `before`
            obs = rec.get("observations") if isinstance(rec.get("observations"), dict) else None
            chosen = rec.get("chosen") if isinstance(rec.get("chosen"), dict) else None
            replay = Replay(model, index, int(rec["t"]), before, dict(rec.get("actions") or {}), chosen, obs)
            replay.clock = replay.t
            walk(replay, rec.get("events") or [], EMISSION)
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


__all__ = ["Problem", "pair_records", "project", "differences", "MAX_STATE_DIFFS"]
