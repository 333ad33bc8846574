"""Running one item in lockstep with the reference interpreter (F-CONFORM).

For a case, an episode or a replay: ``load`` and ``reset`` the implementation and a private
reference :class:`~agspec.interp.tick.Simulator`; then, tick by tick, choose the joint action (the
script, or a controller acting on the *reference's* observations), step both, and after every step

1. compare the implementation's reply with the reference's (:func:`compare.compare_reply`: t, state,
   events, observations and masks as declared by the capabilities, applied actions, done);
2. evaluate the case's expectations on the implementation's reply (:func:`cases.mismatches`);
3. evaluate the eleven invariants on the implementation's own trace records
   (:func:`invariants.check_records`, INV-*), built from its replies alone.

The item stops at the first tick with a failure; the outcome is ``pass``, ``fail`` (divergence,
invariant or expectation), ``error`` (crash, timeout, protocol error, or a harness failure) or
``skip`` (a capability the item needs is missing).
"""

from __future__ import annotations

import time
import traceback
from collections import deque
from dataclasses import dataclass, field
from typing import Any, Mapping

from agspec.conform import compare, invariants
from agspec.conform.cases import mismatches
from agspec.conform.impl import Implementation
from agspec.conform.items import Item
from agspec.conform.protocol import ProtocolError, Unsupported

# F-CONFORM-LEVELS: the behavioural parts of a reply; what a run compared of them is the level it proved
LEVEL_PARTS = ("events", "state", "observations", "masks")


@dataclass(frozen=True)
class Options:
    """Per-item options (picklable)."""

    tolerance: float | None = None
    repro_dir: str | None = None
    context: int = 3  # preceding ticks shown with a divergence
    impl_spec: str = ""


@dataclass
class Result:
    """The raw result of one item (before the expected-failures file is applied)."""

    item: Item
    outcome: str = "pass"
    message: str | None = None
    failure: dict[str, Any] | None = None
    ticks: int = 0
    states: int = 0  # replies compared (any part)
    compared: dict[str, int] = field(default_factory=lambda: {p: 0 for p in LEVEL_PARTS})
    invariant_checks: int = 0
    event_types: set[str] = field(default_factory=set)  # of the reference's run: which rules fired
    expectations: int = 0
    duration_s: float = 0.0
    rendered: str | None = None  # the CommonMark-style text of a failure
    skip_reason: str | None = None  # the simulator's reason when it answered `unsupported`

    def record(self, outcome: str | None = None, expected: Mapping[str, Any] | None = None) -> dict[str, Any]:
        """The report line (F-REPORT) of this result."""
        it = self.item
        rec: dict[str, Any] = {
            "type": "case", "id": it.id, "kind": it.kind, "title": it.title, "location": it.location,
            "rules": list(it.rules), "invariants": list(it.invariants), "tags": [t for t in it.tags if t],
            "outcome": outcome or self.outcome, "raw_outcome": self.outcome, "message": self.message,
            "duration_s": round(self.duration_s, 6), "ticks": self.ticks,
            "checks": {"states": self.states, "invariant_checks": self.invariant_checks,
                       "expectations": self.expectations, "compared": dict(self.compared)},
        }
        if expected is not None:
            rec["expected"] = dict(expected)
        if self.failure is not None:
            rec["failure"] = self.failure
        return rec


def _parts(caps: Mapping[str, bool]) -> list[str]:
    parts = ["t", "done", "applied"]
    if caps.get("privileged_state"):
        parts.append("state")
    if caps.get("events"):
        parts.append("events")
    if caps.get("observations"):
        parts.append("observations")
    if caps.get("masks"):
        parts.append("masks")
    return parts


class _Reference:
    """The reference side of the lockstep: a Simulator and what the implementation is compared with."""

    def __init__(self, item: Item, caps: Mapping[str, bool]):
        from agspec.interp.tick import Simulator

        self.sim = Simulator(item.instance)
        self.sim.reset(item.execution_seed)
        self.caps = caps
        self.robots = self.sim.agents()
        self._obs: tuple[int, Any] | None = None
        self.ctl = None
        if item.controller is not None:
            from agspec.controllers import make_controller

            self.ctl = make_controller(item.controller["name"], item.controller.get("seed"))
            self.ctl.reset(item.controller.get("seed"))

    def observations(self) -> dict[str, Any]:
        if self._obs is None or self._obs[0] != self.sim.t:
            self._obs = (self.sim.t, self.sim.observe())
        return self._obs[1]

    def expected(self, events: list, applied: Mapping[str, int] | None = None) -> dict[str, Any]:
        from agspec.interp.snapshot import global_state

        sim = self.sim
        out: dict[str, Any] = {"t": sim.t, "done": sim.done, "events": list(events)}
        if self.caps.get("privileged_state"):
            out["state"] = global_state(sim.state)
        if self.caps.get("observations"):
            out["observations"] = self.observations()
        if self.caps.get("masks"):
            out["masks"] = sim.masks()
        if applied is not None:
            out["applied"] = {r: int(applied.get(r, 0)) for r in self.robots}
        return out

    def actions(self, item: Item, t: int) -> dict[str, int]:
        if self.ctl is not None:
            sim = self.sim
            chosen = self.ctl.act(self.observations(), sim if self.ctl.information == "global" else None)
            return {r: int(a) for r, a in chosen.items() if int(a) != 0}
        return dict(item.actions[t]) if t < len(item.actions) else {}


def _applied(reply: Mapping[str, Any], sent: Mapping[str, int], robots: list[str],
             observations: Mapping[str, Any] | None = None) -> dict[str, int]:
    """Applied actions of the implementation: its ``applied`` map, else the sent actions minus coercions.

    Coercions are its ``action_coerced`` events; without the events capability (``observations``
    given), R-ACTION-VALIDATION applied to its own previous masks: a masked or out-of-range action idles.
    """
    if isinstance(reply.get("applied"), dict):
        return {r: int(reply["applied"].get(r, 0)) for r in robots}
    if observations is not None:
        def legal(r: str, a: int) -> bool:
            mask = (observations.get(r) or {}).get("mask") if isinstance(observations.get(r), dict) else None
            return not isinstance(mask, list) or (0 <= a < len(mask) and bool(mask[a]))

        return {r: (int(sent.get(r, 0)) if legal(r, int(sent.get(r, 0))) else 0) for r in robots}
    coerced = {e.get("robot") for e in reply.get("events") or [] if isinstance(e, dict) and e.get("type") == "action_coerced"}
    return {r: (0 if r in coerced else int(sent.get(r, 0))) for r in robots}


def _skip_reason(item: Item, caps: Mapping[str, bool]) -> str | None:
    if item.needs_observations and not caps.get("observations"):
        return "the case asserts observations; the implementation does not declare the observations capability"
    if item.needs_state and not caps.get("privileged_state"):
        return "the case asserts the global state; the implementation does not declare privileged_state"
    if not caps.get("privileged_state") and not caps.get("events"):
        return "the implementation declares neither privileged_state nor events: nothing to compare"
    return None


def run_item(item: Item, impl: Implementation, opts: Options) -> Result:
    """Run ``item`` against ``impl`` in lockstep with the reference; never raises."""
    res = Result(item)
    t0 = time.monotonic()
    sent: list[dict[str, int]] = []
    history: deque = deque(maxlen=max(0, opts.context))
    tick = -1
    try:
        impl.start()
        caps = impl.capabilities
        reason = _skip_reason(item, caps)
        if reason:
            res.outcome, res.message = "skip", reason
            return res
        parts = _parts(caps)
        ref = _Reference(item, caps)
        impl.load(item.instance)
        reply = impl.reset(item.execution_seed)
        use_state = caps.get("privileged_state", False)
        ctx = invariants.Context.from_instance(item.instance) if use_state else None
        prev_rec: dict[str, Any] | None = None
        prev_obs = reply.get("observations")
        # events the simulator did not declare are null, never [] (INV-* then derive them from the states)
        events_of = (lambda r: r.get("events") or []) if caps.get("events") else (lambda r: None)
        if ctx is not None:
            prev_rec = {"type": "header", "instance": item.instance, "execution_seed": item.execution_seed,
                        "state": reply.get("state"), "events": events_of(reply)}
        res.event_types.update(e["type"] for e in ref.sim.reset_events)
        if _check(res, item, ref, -1, ref.expected(ref.sim.reset_events), reply, parts, ctx, None, prev_rec, opts,
                  sent, history, impl):
            return res
        for t in range(item.ticks):
            tick = t
            actions = ref.actions(item, t)
            sent.append(actions)
            step = ref.sim.step(actions)
            res.event_types.update(e["type"] for e in step.events)
            reply = impl.step(actions)
            res.ticks += 1
            rec = None
            if ctx is not None:
                rec = {"type": "tick", "t": t,
                       "actions": _applied(reply, actions, ref.robots, None if caps.get("events") else prev_obs or {}),
                       "chosen": {r: int(actions.get(r, 0)) for r in ref.robots},
                       "events": events_of(reply), "state": reply.get("state")}
                if prev_obs is not None:
                    rec["observations"] = prev_obs
            expected = ref.expected(step.events, step.applied if "applied" in reply else None)
            if _check(res, item, ref, t, expected, reply, parts, ctx, prev_rec, rec, opts, sent, history, impl):
                return res
            history.append({"t": t, "actions": dict(actions), "events": list(reply.get("events") or [])})
            prev_rec, prev_obs = rec, reply.get("observations")
            if ref.sim.done:
                break
        return res
    except Unsupported as exc:  # F-PROTOCOL-UNSUPPORTED: skipped with the simulator's reason
        res.outcome, res.message = "skip", f"unsupported: {exc.reason}"
        res.skip_reason = exc.reason
        return res
    except ProtocolError as exc:
        res.outcome = "error"
        res.message = str(exc)
        res.failure = {"type": exc.kind, "code": exc.code, "message": exc.message, "tick": tick,
                       "stderr": exc.stderr or None}
        res.rendered = _render_error(item, exc, tick)
        return res
    except Exception as exc:  # a failure of the harness or of the reference itself
        res.outcome = "error"
        res.message = f"harness error: {type(exc).__name__}: {exc}"
        res.failure = {"type": "harness", "code": type(exc).__name__, "message": res.message, "tick": tick,
                       "stderr": traceback.format_exc()}
        res.rendered = f"{item.id} {item.title}\n  harness error at tick {tick}: {type(exc).__name__}: {exc}\n" \
                       "  (a bug of agspec or of the suite — please file an issue)"
        return res
    finally:
        res.duration_s = time.monotonic() - t0


def _check(res: Result, item: Item, ref: _Reference, t: int, expected: dict[str, Any], reply: Mapping[str, Any],
           parts: list[str], ctx, prev_rec, rec, opts: Options, sent, history, impl) -> bool:
    """Compare, check expectations and invariants after one reply; True if the item failed."""
    # `done` (in a reset reply) and `applied` are optional fields: compared when the implementation sends them
    parts = [p for p in parts if p not in ("done", "applied") or p in reply]
    compared_reply = reply
    if "state" in parts and not impl.capabilities.get("diagnostic_state"):  # F-TRACE-STATE: behaviour only
        expected = {**expected, "state": compare.behavioural(expected.get("state"))}
        compared_reply = {**reply, "state": compare.behavioural(reply.get("state"))}
    div = compare.compare_reply(t, expected, compared_reply, parts, opts.tolerance)
    res.states += 1
    for part in LEVEL_PARTS:
        res.compared[part] += part in parts
    violations: list[invariants.Violation] = []
    if ctx is not None:
        before = sum(ctx.counts.values())
        target = rec if rec is not None else prev_rec
        violations = invariants.check_records(ctx, None if rec is None else prev_rec, target)
        res.invariant_checks += sum(ctx.counts.values()) - before
    failed_expectations: list[str] = []
    if item.case is not None and t >= 0:
        exps = item.case.expectations_at(t)
        if exps:
            res.expectations += len(exps)
            found = mismatches(item.case, t, reply.get("state") or {},
                               (reply.get("events") or []) if impl.capabilities.get("events") else None,
                               observations=reply.get("observations") if impl.capabilities.get("observations") else None,
                               done=reply.get("done"), diagnostic=impl.capabilities.get("diagnostic_state", False))
            failed_expectations = [str(m) for m in found]
    if div is None and not violations and not failed_expectations:
        return False
    res.outcome = "fail"
    kind = "divergence" if div is not None else ("invariant" if violations else "expectation")
    failure: dict[str, Any] = {"type": kind, "tick": t, "ids": sorted({v.invariant for v in violations})}
    if div is not None:
        failure.update(div.to_json())
        failure["tick"] = t
        msg = f"{div.headline()}: expected {compare.show(div.expected, 60)}, got {compare.show(div.actual, 60)}"
    elif violations:
        msg = str(violations[0])
    else:
        msg = failed_expectations[0]
    failure["message"] = msg
    failure["violations"] = [{"invariant": v.invariant, "tick": v.tick, "entity": v.entity, "message": v.message}
                             for v in violations[:20]]
    failure["expectations"] = failed_expectations[:20]
    failure["context"] = [dict(h) for h in history]
    reproducer = item.location if item.kind == "replay" else None  # a replay is its own reproducer
    if opts.repro_dir and item.kind != "replay":
        data = compare.make_reproducer(ident=item.id, title=item.title, instance=item.instance,
                                       execution_seed=item.execution_seed, actions=sent,
                                       impl=opts.impl_spec or impl.spec, failure=failure, tolerance=opts.tolerance)
        try:
            reproducer = str(compare.save_reproducer(opts.repro_dir, data))
        except OSError as exc:
            failure["message"] += f" (reproducer not saved: {exc})"
    failure["reproducer"] = reproducer
    res.failure = failure
    res.message = msg
    res.rendered = _render_fail(item, div, violations, failed_expectations, history, reproducer,
                                opts.impl_spec or impl.spec, t)
    return True


def _render_fail(item: Item, div, violations, failed_expectations, history, reproducer, impl_spec, t) -> str:
    if div is not None:
        text = compare.render_divergence(item.title, item.id, div, list(history), reproducer, impl_spec)
    else:
        at = "after reset" if t < 0 else f"after tick {t}"
        text = f"{item.id} {item.title}\n  first failure {at}"
        if history:
            text += "\n  preceding ticks:"
            for entry in history:
                text += f"\n    t={entry['t']:<4} actions {compare.action_summary(entry['actions'])}"
        if reproducer:
            text += f"\n  reproducer: {reproducer}"
    for v in violations[:5]:
        text += f"\n  violated {v}"
    for m in failed_expectations[:5]:
        text += f"\n  expectation {m}"
    if item.location:
        text += f"\n  case at {item.location}"
    return text


def _render_error(item: Item, exc: ProtocolError, tick: int) -> str:
    at = "during start/load/reset" if tick < 0 else f"at tick {tick}"
    what = exc.kind if exc.kind == exc.code else f"{exc.kind} ({exc.code})"
    text = f"{item.id} {item.title}\n  {what} {at}: {exc.message}"
    if exc.stderr:
        tail = exc.stderr.strip().splitlines()[-8:]
        text += "\n  stderr of the simulator (last lines):\n" + "\n".join(f"    | {line}" for line in tail)
    return text


__all__ = ["Options", "Result", "run_item", "LEVEL_PARTS"]
