"""Coverage of values, not only of rule IDs (F-CONFORM-COVERAGE), and the rules a run exercised.

A suite can cite every rule and still never show a simulator the values where ports go wrong: a
support fraction of 1/3, an XOR choice, a resource at its capacity, a record that expires at the
exact tick.  :func:`value_coverage` runs every case on the reference interpreter (its script or its
controller) and records, per *entry*, the cases whose run shows it:

* ``event:TYPE`` — every event type of F-TRACE-EVENTS;
* ``state:FIELD`` — every field of F-TRACE-STATE, covered when its value changes during a run;
* ``observation:FIELD`` — every field of O-OBSERVATION (and of its neighbour and option entries),
  covered when its value differs from the first one observed;
* ``mask:CLASS`` — every action class of O-ACTION-ENCODING, covered when some mask allows it;
* ``value:CLASS`` — the value classes of :data:`VALUE_CLASSES`.

:data:`EVENT_RULES` maps event types to the rules whose firing they witness, so a run without the
suite (``--no-suite``) can say which rules its episodes actually exercised.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any, Iterable, Mapping, Sequence

from agspec.controllers import make_controller
from agspec.interp.observe import DELIVER, HANDOFF0, IDLE, N_ACTIONS, OP0, PICK0, RECEIVE0
from agspec.interp.snapshot import global_state
from agspec.interp.tick import Simulator

# F-TRACE-EVENTS: the rule each event type witnesses
EVENT_RULES: dict[str, tuple[str, ...]] = {
    "release": ("R-RELEASE",), "release_lost": ("R-RELEASE",), "action_coerced": ("R-ACTION-VALIDATION",),
    "pick_started": ("R-PICK", "R-EXECUTION"), "handoff_started": ("R-HANDOFF", "R-EXECUTION"),
    "support": ("R-SUPPORT",), "support_switched": ("R-SUPPORT", "R-SWITCH-LOCK"),
    "proposal_created": ("R-SUPPORT-LIFECYCLE",), "admitted": ("R-ADMISSION", "R-EXECUTION"),
    "admission_failed": ("R-EXPIRY", "R-SUPPORT-LIFECYCLE"), "proposal_abandoned": ("R-EXPIRY",),
    "blocked": ("R-BLOCKING",), "delivery_started": ("R-DELIVERY", "R-EXECUTION"),
    "pick_completed": ("R-COMPLETION",), "handoff_completed": ("R-COMPLETION",),
    "operation_completed": ("R-COMPLETION",), "delivered": ("R-COMPLETION",),
}

# O-ACTION-ENCODING: action classes by integer range
MASK_CLASSES: dict[str, range] = {
    "idle": range(IDLE, IDLE + 1), "deliver": range(DELIVER, DELIVER + 1), "pick": range(PICK0, HANDOFF0),
    "handoff_send": range(HANDOFF0, RECEIVE0), "handoff_receive": range(RECEIVE0, OP0),
    "operation": range(OP0, N_ACTIONS),
}

VALUE_CLASSES: dict[str, str] = {
    "support_fraction_1/2": "an operation option shows support 1/2 (O-SUPPORT-FRACTION)",
    "support_fraction_1/3": "an operation option shows support 1/3",
    "support_fraction_2/3": "an operation option shows support 2/3",
    "support_fraction_1/4": "an operation option shows support 1/4",
    "support_fraction_3/4": "an operation option shows support 3/4",
    "xor_choice": "a product resolves an XOR group (R-XOR-CLOSURE)",
    "resource_at_capacity": "an activity is blocked because a finite resource is at capacity (R-BLOCKING)",
    "expiry_at_exact_tick": "a supported record open at its expires_at epoch expires in the transition into "
                            "expires_at + 1 (R-SUPPORT-LIFECYCLE, R-EXPIRY)",
}

STATE_FIELDS = ("t", "released", "delivered", "wip", "lost_releases", "robots/*/holding", "robots/*/incoming",
                "robots/*/supports", "robots/*/activity", "robots/*/busy_until", "robots/*/switch_lock",
                "robots/*/ee", "robots/*/q", "products", "products/*/completed", "products/*/in_progress",
                "products/*/xor", "products/*/raw_taken", "products/*/delivered_at", "items", "shelves",
                "proposals", "proposals/*/supporters", "activities")


def entries() -> list[str]:
    """Every entry the coverage is measured over, in a fixed order."""
    out = [f"event:{t}" for t in EVENT_RULES]
    out += [f"state:{f}" for f in STATE_FIELDS]
    out += [f"observation:{f}" for f in OBSERVATION_FIELDS]
    out += [f"mask:{c}" for c in MASK_CLASSES]
    out += [f"value:{v}" for v in VALUE_CLASSES]
    return out


OBSERVATION_FIELDS = ("t", "holding", "busy", "supports", "neighbours", "neighbours/*/holding",
                      "neighbours/*/busy", "neighbours/*/op", "neighbours/*/role", "pick_options",
                      "operation_options", "operation_options/*/support", "operation_options/*/members",
                      "operation_options/*/role", "mask")


def _field(doc: Any, path: str) -> Any:
    """The values at ``path`` (``*`` = every key / element), as one hashable summary."""
    parts = path.split("/")
    nodes = [doc]
    for part in parts:
        nxt = []
        for n in nodes:
            if part == "*":
                nxt += list(n.values()) if isinstance(n, dict) else list(n) if isinstance(n, list) else []
            elif isinstance(n, dict) and part in n:
                nxt.append(n[part])
        nodes = nxt
    return repr(nodes)


def observe_run(states: Sequence[Mapping[str, Any]], events: Iterable[Mapping[str, Any]],
                observations: Sequence[Mapping[str, Any]], masks: Sequence[Mapping[str, list]]) -> set[str]:
    """The entries one run shows (states s_0..s_T, all events, observations and masks per epoch)."""
    seen: set[str] = set()
    events = list(events)
    for ev in events:
        seen.add(f"event:{ev.get('type')}")
        if ev.get("type") == "blocked" and ev.get("cause") == "resource":
            seen.add("value:resource_at_capacity")
    for f in STATE_FIELDS:
        if len({_field(s, f) for s in states}) > 1:
            seen.add(f"state:{f}")
    for s in states:
        if any(p.get("xor") for p in s.get("products") or []):
            seen.add("value:xor_choice")
    # expiry on the clock (R-SUPPORT-LIFECYCLE): a supported record of s_t with expires_at = t (its last
    # eligible epoch) is gone in s_{t+1}, and an `admission_failed` with reason `expired` names it
    expired = {(ev.get("candidate")) for ev in events if ev.get("type") == "admission_failed"
               and ev.get("reason") == "expired"}
    for before, after in zip(states, states[1:]):
        for cid, rec in (before.get("proposals") or {}).items():
            if (cid in expired and rec.get("supporters") and rec.get("expires_at") == before.get("t")
                    and cid not in (after.get("proposals") or {})):
                seen.add("value:expiry_at_exact_tick")
    per_robot = [o for obs in observations for o in obs.values()]
    for f in OBSERVATION_FIELDS:
        if len({_field(o, f) for o in per_robot}) > 1:
            seen.add(f"observation:{f}")
    for o in per_robot:
        for opt in o.get("operation_options") or []:
            frac = opt.get("support")
            if isinstance(frac, (int, float)) and 0 < frac < 1:
                q = Fraction(frac).limit_denominator(8)
                if abs(float(q) - frac) < 1e-12:
                    seen.add(f"value:support_fraction_{q.numerator}/{q.denominator}")
    for m in masks:
        for mask in m.values():
            for name, span in MASK_CLASSES.items():
                if any(mask[a] for a in span):
                    seen.add(f"mask:{name}")
    return seen


def run_case(item: Any) -> set[str]:
    """Run one suite item on the reference and return the entries it shows."""
    sim = Simulator(item.instance)
    sim.reset(item.execution_seed)
    ctl = None
    if item.controller is not None:
        ctl = make_controller(item.controller["name"], item.controller.get("seed"), grid=item.instance["scenario"]["grid"])
        ctl.reset(item.controller.get("seed"))
    states, events = [global_state(sim.state)], list(sim.reset_events)
    observations, masks = [sim.observe()], [sim.masks()]
    for t in range(item.ticks):
        if ctl is not None:
            actions = {r: int(a) for r, a in ctl.act(observations[-1], sim if ctl.information == "global" else None)
                       .items() if int(a)}
        else:
            actions = dict(item.actions[t]) if t < len(item.actions) else {}
        events += sim.step(actions).events
        states.append(global_state(sim.state))
        observations.append(sim.observe())
        masks.append(sim.masks())
        if sim.done:
            break
    return observe_run(states, events, observations, masks)


def value_coverage(items: Sequence[Any]) -> dict[str, Any]:
    """``{"values": {entry: [case ids]}, "uncovered": [entries]}`` over :func:`entries`."""
    table: dict[str, list[str]] = {e: [] for e in entries()}
    for item in items:
        for entry in sorted(run_case(item)):
            if entry in table:
                table[entry].append(item.id)
    return {"values": table, "uncovered": [e for e, ids in table.items() if not ids]}


def rules_exercised(event_types: Iterable[str]) -> list[str]:
    """The rules whose firing the given event types witness (EVENT_RULES), sorted."""
    return sorted({r for t in event_types for r in EVENT_RULES.get(t, ())})


__all__ = ["EVENT_RULES", "MASK_CLASSES", "VALUE_CLASSES", "STATE_FIELDS", "OBSERVATION_FIELDS", "entries",
           "observe_run", "run_case", "value_coverage", "rules_exercised"]
