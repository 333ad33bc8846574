"""Traces that lie about their events: a mutator over valid reference traces (F-TRACE-PAIRING).

Each mutation keeps one side of a record consistent and breaks the other — an event dropped,
doubled, moved one record later or earlier, or one of its fields altered, while the states stay as
the run left them; or a state changed (a support, a shelf stock, a raw token taken) without its
event — and then rewrites the footer metrics so that they agree with the mutated events ("the
footer lowered to match"). Every mutant is a trace F-TRACE-EVENTS forbids, so ``agspec check``
must reject each one; ``judge`` runs exactly what ``agspec check`` runs on a trace it could read.

Used by tests/test_trace_pairing.py (a bounded run) and benchmarks/fuzz_trace_pairing.py (the
long run). Only mutations that the records can reveal are generated: a ``blocked`` event changes
no state, so dropping one or altering its cause cannot be seen from the trace (the suite and
``agspec diff`` compare those with the reference); it is only doubled here.
"""

from __future__ import annotations

import copy
import io
import json
import random
from dataclasses import dataclass
from typing import Any, Iterator, Mapping

from agspec.invariants import check_trace
from agspec.formats.trace import TraceWriter, read_records
from agspec.interp.observe import N_ACTIONS
from agspec.interp.snapshot import global_state
from agspec.interp.tick import Simulator
from agspec.ir.fingerprint import fingerprint
from agspec.trace.read import _diag
from agspec.trace.verify import recompute, verify

Json = dict[str, Any]

# F-TRACE-EMISSION, written out here independently of agspec/trace/: the order in which the steps
# of R-TICK-ORDER emit their events (a `blocked` event belongs to the step of its `kind`). Used to
# put a moved event where an honest writer would have put it, so that only its record is wrong.
PHASES: tuple[tuple[str, ...], ...] = (
    ("action_coerced",),
    ("pick_started", "blocked:pick"),
    ("handoff_started", "blocked:handoff"),
    ("support_switched", "proposal_created", "support"),
    ("admitted", "blocked:operation"),
    ("admission_failed", "proposal_abandoned"),
    ("delivery_started", "blocked:deliver"),
    ("pick_completed", "handoff_completed", "operation_completed", "delivered"),
    ("release", "release_lost"),
    ("admission_failed", "proposal_abandoned"),
)
SILENT = frozenset({"blocked"})  # events whose absence or cause no state shows
OPS = ("drop", "duplicate", "delay", "advance", "alter", "state")


@dataclass(frozen=True)
class Mutant:
    op: str  # one of OPS
    event: str  # the event type touched (or the state field for "state")
    record: int  # index of the record changed (0: the header)
    detail: str
    records: list[Json]

    @property
    def label(self) -> str:
        return f"{self.op}:{self.event}@{self.record} {self.detail}"


# --------------------------------------------------------------------------- valid traces


def reference_trace(instance: Mapping[str, Any], controller: str = "greedy", horizon: int | None = None,
                    *, illegal: float = 0.0, seed: int = 0) -> list[Json]:
    """The reference's trace of one episode: a reference controller, or (``controller="illegal"``) seeded
    random actions over the whole encoding, a fraction ``illegal`` of them masked or out of range."""
    buf = io.StringIO()
    writer = TraceWriter(buf)
    if controller != "illegal":
        from agspec.evaluate import run_episode

        run_episode(dict(instance), controller, horizon=horizon, trace=writer)
        return read_records(buf.getvalue().splitlines())
    rng = random.Random(seed)
    sim = Simulator(instance)
    limit = min(horizon or sim.model.horizon, sim.model.horizon)
    writer.header(instance=instance, fingerprint=fingerprint(instance), execution_seed=sim.execution_seed,
                  controller={"name": "illegal", "seed": seed}, initial_state=global_state(sim.state),
                  initial_events=sim.reset_events, horizon=limit)
    agents = sim.agents()
    while not sim.done and sim.t < limit:
        t = sim.t
        masks = sim.masks()
        joint = {}
        for a in agents:
            legal = [i for i, ok in enumerate(masks[a]) if ok]
            if rng.random() < illegal:
                joint[a] = rng.choice([-1, N_ACTIONS, 500] + [i for i, ok in enumerate(masks[a]) if not ok])
            else:
                joint[a] = rng.choice(legal)
        step = sim.step(joint)
        chosen = {a: joint[a] for a in agents if step.applied[a] != joint[a]}
        writer.tick(t=t, actions=step.applied, events=step.events, state=global_state(sim.state), chosen=chosen)
    writer.footer(metrics=sim.final_metrics())
    return read_records(buf.getvalue().splitlines())


# --------------------------------------------------------------------------- judging


def judge(records: list[Json]) -> list[str]:
    """What ``agspec check`` reports on a readable trace: invariant violations and whole-trace problems
    (F-TRACE-CHECK); an empty list is a pass."""
    report = check_trace(records)
    whole = verify(records, "<mutant>", _diag)
    return [str(v) for v in report.violations] + [f"{d.code} {d.message}" for d in whole]


def fix_footer(records: list[Json]) -> None:
    """Rewrite the footer metrics that the records determine so that the footer agrees with them."""
    footer = records[-1]
    if footer.get("type") != "footer" or not isinstance(footer.get("metrics"), dict):
        return
    try:
        again = recompute(records)
    except (KeyError, TypeError, ValueError, IndexError):
        return
    for key, value in again.items():
        if key in footer["metrics"]:
            footer["metrics"][key] = value


# --------------------------------------------------------------------------- mutations


def _phase(ev: Json) -> int:
    key = f"blocked:{ev.get('kind')}" if ev.get("type") == "blocked" else ev.get("type")
    return next(i for i, types in enumerate(PHASES) if key in types)


def _insert_in_phase(events: list[Json], ev: Json) -> None:
    """Insert ``ev`` after the last event of ``events`` whose step comes no later than its own."""
    phase = _phase(ev)
    at = 0
    for i, other in enumerate(events):
        if _phase(other) <= phase:
            at = i + 1
    events.insert(at, ev)


def _robots(records: list[Json]) -> list[str]:
    return list(records[0]["state"]["robots"])


def _alternatives(records: list[Json], r: int, ev: Json, key: str, rng: random.Random) -> list[Any]:
    """Plausible other values for field ``key`` of ``ev`` (same type, different value)."""
    value = ev[key]
    state = records[r]["state"]
    if key in ("robot", "sender", "receiver", "holder"):
        return [x for x in _robots(records) if x != value]
    if key in ("item", "produced"):
        pid, _, tok = value.partition(":")
        tokens = {i.partition(":")[2] for i in state["items"]} | {tok, "A", "B", "FINAL"}
        return [f"{pid}:{k}" for k in sorted(tokens) if k != tok] + [f"{int(pid) + 1}:{tok}"]
    if key in ("product", "end", "latency", "expires_at", "shelf_row", "action"):
        return [v for v in (value - 1, value + 1, value + 2) if v >= 0 and v != value]
    if key in ("candidate", "from", "to"):
        pool = set(state.get("proposals") or {}) | set(records[max(0, r - 1)]["state"].get("proposals") or {})
        pool |= {e[k] for rec in records[max(0, r - 3):r + 3] for e in rec.get("events") or []
                 for k in ("candidate", "from", "to") if isinstance(e.get(k), str)}
        return sorted(pool - {value})
    if key == "activity":
        kind, _, rest = value.partition("@")
        t, _, tail = rest.partition(":")
        return [f"{kind}@{int(t) + 1}:{tail}", f"{kind}@{max(0, int(t) - 1)}:{tail}"] if t.isdigit() else []
    if key == "reason" and ev["type"] == "admission_failed" and not records[r].get("observations"):
        # `invalid` (removed at t, its candidate left C_t) and `expired` (removed at t + 1, its clock
        # ran out) of a record whose clock ends at t leave the same states; only the event's place
        # among the record's other events, or the observations' C_t, tells them apart
        prop = (records[r - 1]["state"].get("proposals") or {}).get(ev["candidate"]) if r > 0 else None
        if prop is not None and prop["expires_at"] == records[r].get("t"):
            return []
    if key == "reason":
        return [x for x in ("wip_cap", "realization_exhausted", "raw_material", "expired", "invalid")
                if x != value and (x in ("expired", "invalid")) == (value in ("expired", "invalid"))]
    if key == "recipe":
        return [x for x in records[0]["instance"]["recipes"] if x != value] + [value + "_x"]
    if key == "token":
        return [x for x in ("A", "B", "C") if x != value]
    if key == "operation":
        recipes = records[0]["instance"]["recipes"].values()
        return sorted({op["id"] for rc in recipes for op in rc["operations"]} - {value})
    if key == "consumed":
        out = [value[:-1]] if value else []
        if len(value) > 1:
            out.append(list(reversed(value)))
        return out
    return []


def _state_mutant(records: list[Json], r: int, rng: random.Random) -> tuple[str, str] | None:
    """Change record ``r``'s state (in place) where only an event may change it: a shelf stock, a raw
    token taken, a support. Returns (field, detail), or None when the state offers nothing to change."""
    state = records[r]["state"]
    cap = int(records[0]["instance"]["scenario"]["shelves"]["capacity"])
    choices: list[tuple[str, Any]] = []
    stocked = [(i, k) for i, shelf in enumerate(state["shelves"]) for k, n in shelf.items() if n < cap]
    if stocked:
        choices.append(("shelves", rng.choice(stocked)))
    taken = [(p, k) for p in state["products"] for k in p["raw_taken"]]
    if taken:
        choices.append(("raw_taken", rng.choice(taken)))
    free = {rid for rid, rob in state["robots"].items() if rob["supports"] is None and rob["activity"] is None}
    joins = [(cid, m) for cid, prop in sorted((state.get("proposals") or {}).items())
             for m in cid.rsplit(":", 1)[1].split(";") if m in free and m not in prop["supporters"]]
    if joins:
        choices.append(("supports", rng.choice(joins)))
    if not choices:
        return None
    what, arg = rng.choice(choices)
    if what == "shelves":
        i, k = arg
        state["shelves"][i][k] += 1
        return what, f"row {i} {k} +1"
    if what == "raw_taken":
        p, k = arg
        p["raw_taken"].remove(k)
        return what, f"product {p['id']} forgets {k}"
    cid, m = arg
    prop = state["proposals"][cid]
    prop["supporters"] = sorted(prop["supporters"] + [m], key=lambda x: tuple(map(int, x.split(","))))
    state["robots"][m]["supports"] = cid
    return what, f"{m} joins {cid}"


def mutants(records: list[Json], rng: random.Random, limit: int) -> Iterator[Mutant]:
    """Up to ``limit`` mutants of ``records`` (a valid trace), drawn with ``rng``; each with its footer fixed."""
    ticks = [i for i, rec in enumerate(records) if rec.get("type") in ("header", "tick")]
    sites = [(r, e) for r in ticks for e in range(len(records[r].get("events") or []))]
    made = 0
    attempts = 0
    while made < limit and attempts < limit * 20 and (sites or len(ticks) > 1):
        attempts += 1
        op = rng.choice(OPS)
        if op == "state":
            if len(ticks) < 2:
                continue
            r = rng.choice(ticks[1:])
            out = copy.deepcopy(records)
            changed = _state_mutant(out, r, rng)
            if changed is None:
                continue
            fix_footer(out)
            made += 1
            yield Mutant(op, changed[0], r, changed[1], out)
            continue
        if not sites:
            continue
        r, e = rng.choice(sites)
        ev = records[r]["events"][e]
        kind = ev["type"]
        if kind in SILENT and op != "duplicate":
            continue
        out = copy.deepcopy(records)
        events = out[r]["events"]
        if op == "drop":
            del events[e]
            detail = json.dumps(ev, sort_keys=True)
        elif op == "duplicate":
            events.insert(e + 1, copy.deepcopy(ev))
            detail = json.dumps(ev, sort_keys=True)
        elif op in ("delay", "advance"):
            to = r + 1 if op == "delay" else r - 1
            if to not in ticks:
                continue
            del events[e]
            _insert_in_phase(out[to]["events"], copy.deepcopy(ev))
            detail = f"to record {to}: {json.dumps(ev, sort_keys=True)}"
        else:  # alter
            keys = [k for k in ev if k not in ("type", "kind")]
            if not keys:
                continue
            key = rng.choice(keys)
            options = [o for o in _alternatives(records, r, ev, key, rng) if o != ev[key]]  # a real change
            if not options:
                continue
            new = rng.choice(options)
            events[e] = {**ev, key: new}
            detail = f"{key}: {ev[key]!r} -> {new!r} in {json.dumps(ev, sort_keys=True)}"
        fix_footer(out)
        made += 1
        yield Mutant(op, kind, r, detail, out)


__all__ = ["Mutant", "PHASES", "OPS", "SILENT", "reference_trace", "judge", "fix_footer", "mutants"]
