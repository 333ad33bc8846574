"""Running one item in lockstep with the reference interpreter (F-CONFORM).

For a case, an episode or a replay, the one lockstep driver (:func:`agspec.conform.lockstep.driver.lockstep`)
runs the implementation against a private in-process reference (``ReferenceImpl``): tick by tick
it chooses the joint action (the script, or a controller acting on the *reference's*
observations), steps both, and after every step

1. compares the implementation's reply with the reference's (t, state, events, observations and
   masks as declared by the capabilities, applied actions, done);
and this module's observer (``_Checker``) goes on:

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
from pathlib import Path
from typing import Any, Mapping

from agspec import invariants
from agspec.conform import golden, known, repro
from agspec.conform.cases.expectations import available_parts, mismatches, tally
from agspec.conform.impl import Implementation, ReferenceImpl
from agspec.conform.impl import history as history_mod
from agspec.conform.items import Item
from agspec.conform.lockstep import compare, driver
from agspec.conform.lockstep.actions import ControllerPolicy, ScriptPolicy
from agspec.conform.lockstep.driver import Pair
from agspec.formats.divergences import expect_entry
from agspec.formats.output import OutputError
from agspec.formats.protocol import ProtocolError, Unsupported

# F-CONFORM-LEVELS: the behavioural parts of a reply; what a run compared of them is the level it proved
LEVEL_PARTS = ("events", "state", "observations", "masks")
ASSERTED_PARTS = LEVEL_PARTS + ("done",)  # what suite assertions read (RES-ASSERTION-LEVEL)


@dataclass(frozen=True)
class Options:
    """Per-item options (picklable)."""

    tolerance: float | None = None
    repro_dir: str | None = None
    context: int = 3  # preceding ticks shown with a divergence
    impl_spec: str = ""
    golden_dir: str | None = None  # F-GOLDEN cache directory (None: every item runs live)


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
    expectations: int = 0
    duration_s: float = 0.0
    rendered: str | None = None  # the CommonMark-style text of a failure
    skip_reason: str | None = None  # the simulator's reason when it answered `unsupported`
    event_types: set[str] = field(default_factory=set)  # of the reference's run: which rules fired
    reference: str = "live"  # F-GOLDEN: "golden" when the replies were matched against a golden trace
    # F-REPRO: of a failing item, the requests its implementation's process had received before it
    # (None: not kept, the session was too long); what a history reproducer sends first
    history: tuple[tuple[str, Any], ...] | None = field(default=None, repr=False)
    actions_sent: list[dict[str, int]] = field(default_factory=list, repr=False)  # of a failing item (F-REPRO)
    # RES-ASSERTION-LEVEL: the case's assertions evaluated, and those skipped by the part they need
    assertions_checked: int = 0
    assertions_skipped: dict[str, int] = field(default_factory=dict)

    @property
    def assertions(self) -> dict[str, Any]:
        return {"checked": self.assertions_checked, "skipped": sum(self.assertions_skipped.values()),
                "skipped_by_part": dict(sorted(self.assertions_skipped.items()))}

    def record(self, outcome: str | None = None, expected: Mapping[str, Any] | None = None) -> dict[str, Any]:
        """The report line (F-REPORT) of this result."""
        it = self.item
        rec: dict[str, Any] = {
            "type": "case", "id": it.id, "kind": it.kind, "title": it.title, "location": it.location,
            "rules": list(it.rules), "invariants": list(it.invariants), "tags": [t for t in it.tags if t],
            "outcome": outcome or self.outcome, "raw_outcome": self.outcome, "message": self.message,
            "duration_s": round(self.duration_s, 6), "ticks": self.ticks,
            "checks": {"states": self.states, "invariant_checks": self.invariant_checks,
                       "expectations": self.expectations, "compared": dict(self.compared),
                       "reference": self.reference, "assertions": self.assertions},
        }
        if expected is not None:
            rec["expected"] = dict(expected)
        if self.failure is not None:
            rec["failure"] = self.failure
        return rec


def declared_parts(caps: Mapping[str, bool]) -> set[str]:
    """RES-ASSERTION-LEVEL: the reply parts a simulator with ``caps`` sends, as assertions read them."""
    parts = {"done"} | {part for part, cap in (("state", "privileged_state"), ("events", "events"),
                                               ("observations", "observations"), ("masks", "masks"))
                        if caps.get(cap)}
    return parts


def _skip_reason(item: Item, caps: Mapping[str, bool]) -> str | None:
    if not caps.get("privileged_state") and not caps.get("events"):
        return "the implementation declares neither privileged_state nor events: nothing to compare"
    case = item.case
    if case is not None and case.expectations:
        # RES-ASSERTION-LEVEL: run what the level allows; a case none of whose assertions it allows
        # would check nothing of what it is for (vacuity guard), so it is skipped
        available = declared_parts(caps)
        checked, skipped = 0, {}
        for t in sorted({e["after_tick"] for e in case.expectations}):
            n, by_part = tally(case, t, available, caps.get("diagnostic_state", False))
            checked += n
            for part, k in by_part.items():
                skipped[part] = skipped.get(part, 0) + k
        if not checked:
            need = ", ".join(sorted(skipped))
            return (f"every assertion of the case reads a part the implementation does not declare ({need}): "
                    "nothing of what it asserts could be checked")
    return None


def run_item(item: Item, impl: Implementation, opts: Options) -> Result:
    """Run ``item`` against ``impl`` in lockstep with the reference (:func:`driver.lockstep`); never raises."""
    res = Result(item)
    t0 = time.monotonic()
    reference = None
    before: tuple[tuple[str, Any], ...] | None = None
    try:
        impl.start()
        caps = impl.capabilities
        reason = _skip_reason(item, caps)
        if reason:
            res.outcome, res.message = "skip", reason
            return res
        before = impl.requests.snapshot()  # this process's history so far (F-CONFORM-HISTORY)
        if item.history:
            history_mod.send(impl, item.history)
        directory = Path(opts.golden_dir) if opts.golden_dir and golden.eligible(item, impl, opts.tolerance) \
            and not item.history else None
        recorded = golden.lookup(directory, item) if directory is not None else None
        resume = _run_golden(res, item, impl, recorded) if recorded is not None else None
        if resume is True:
            return res
        if item.controller is not None:
            policy: Any = ControllerPolicy(item.controller["name"], item.controller.get("seed"))
        else:
            policy = ScriptPolicy(item.actions)
        # the reference computes observations and masks only when compared or acted on
        reference = ReferenceImpl(observations=bool(caps.get("observations")) or policy.observes,
                                  masks=bool(caps.get("masks")))
        reference.start()
        actual = impl if not resume else golden.Resumed(impl, *resume, mirror=reference, actions=recorded.actions)
        pair = Pair(reference, actual, ("reference", impl.spec), ("reference", opts.impl_spec or impl.spec),
                    cache_loads=False)
        checker = _Checker(item, impl, opts, res, caps.get("privileged_state", False), pair.parts(),
                           known=resume[0] if resume else 0, summary=recorded.summary if resume else None)
        observe = checker.observe
        recorder = golden.Recorder(item, checked=not impl.trusted) if directory is not None else None
        if recorder is not None:
            def observe(step: driver.Step) -> bool:
                stop = checker.observe(step)
                recorder.observe(step, res.invariant_checks, res.expectations)
                return stop

        run = driver.lockstep(pair, item.instance, item.execution_seed, policy, item.ticks,
                              tolerance=opts.tolerance, observer=observe)
        res.ticks = run.ticks
        if run.failure is not None and isinstance(run.failure.__cause__, Unsupported):
            # F-PROTOCOL-UNSUPPORTED: skipped with the simulator's reason
            res.outcome, res.message = "skip", f"unsupported: {run.failure.__cause__.reason}"
            res.skip_reason = run.failure.__cause__.reason
        elif run.failure is not None:
            cause = run.failure.__cause__
            if run.failure.side != pair.actual_side or not isinstance(cause, ProtocolError):
                raise RuntimeError(run.failure.message) from cause  # the reference failed: a harness error
            _protocol_error(res, item, cause, run.failure_tick)
        elif run.both_failed:
            raise RuntimeError(f"the reference refused step {run.ticks - 1} too: {run.both_failed}")
        elif run.invalid:
            raise RuntimeError(f"the item's script is invalid at {run.invalid}")
        elif recorder is not None and res.outcome == "pass":
            recorded = recorder.golden(res)
            if recorded is not None:
                golden.store(directory, recorded)
        if res.outcome == "pass" and item.case is not None and item.case.expectations and not res.assertions_checked:
            # vacuity guard (RES-ASSERTION-LEVEL): a case that checked none of its assertions did not pass
            res.outcome = "skip"
            res.message = ("none of the case's assertions could be checked (they read parts the replies did not "
                           f"carry: {', '.join(sorted(res.assertions_skipped)) or 'none'})")
        return res
    except Unsupported as exc:
        res.outcome, res.message, res.skip_reason = "skip", f"unsupported: {exc.reason}", exc.reason
        return res
    except ProtocolError as exc:
        _protocol_error(res, item, exc, -1)
        return res
    except OutputError:  # F-OUTPUT-FAILURES: a golden trace or reproducer that cannot be written ends the run
        raise
    except Exception as exc:  # a failure of the harness or of the reference itself
        tick = res.ticks - 1
        res.outcome = "error"
        res.message = f"harness error: {type(exc).__name__}: {exc}"
        res.failure = {"type": "harness", "code": type(exc).__name__, "message": res.message, "tick": tick,
                       "stderr": traceback.format_exc()}
        res.rendered = f"{item.heading}\n  harness error at tick {tick}: {type(exc).__name__}: {exc}\n" \
                       "  (a bug of agspec or of the suite — please file an issue)"
        return res
    finally:
        if reference is not None:
            reference.close()
        if res.outcome == "fail":
            res.history = before
        res.duration_s = time.monotonic() - t0


def _run_golden(res: Result, item: Item, impl: Implementation, recorded) -> bool | tuple | None:
    """F-GOLDEN: replay ``recorded`` against ``impl``.  True when that decided the item — every reply
    had the golden digest (pass, with the recorded counts), or the implementation failed a request
    (the error a live run reports at that request).  Otherwise the item goes on live: from the
    reply that differed (``(index, replies)``, for :class:`golden.Resumed`), or from the start (None,
    after an unexpected failure of the replay)."""
    res.reference = "golden"
    try:
        differed = golden.replay(item, impl, recorded)
    except (Unsupported, ProtocolError) as exc:
        tick = getattr(exc, "failure_tick", -1)
        counts = golden.counts_at(recorded, tick + 1)
        res.ticks = tick + 1
        if isinstance(exc, Unsupported):
            res.outcome, res.message, res.skip_reason = "skip", f"unsupported: {exc.reason}", exc.reason
        else:
            _protocol_error(res, item, exc, tick)
    except Exception:
        res.reference = "live"
        return None
    else:
        if differed is not None:
            res.reference = "live"
            return differed
        counts = golden.counts_at(recorded, len(recorded.replies))
        res.ticks = recorded.summary["ticks"]
        # RES-GOLDEN-IDENTITY: the reference's replies, every part declared: every assertion evaluated
        for t in range(res.ticks):
            _count_assertions(res, item, t, None, {"diagnostic_state": True})
    res.states, res.compared = counts["states"], dict(counts["compared"])
    res.invariant_checks, res.event_types = counts["invariant_checks"], set(counts["event_types"])
    res.expectations = counts["expectations"]
    return True


# F-PROTOCOL-UNSUPPORTED: what a refusal of load or reset should have been, when it declines the instance
DECLINE_HINT = ("a simulator that cannot represent an instance declines it with the error code `unsupported` "
                "(F-PROTOCOL-UNSUPPORTED): the item is then skipped with its reason, not an error")


def _protocol_error(res: Result, item: Item, exc: ProtocolError, tick: int) -> None:
    declined = any(f"refused `{cmd}`" in exc.message for cmd in ("load", "reset"))
    if exc.code == "error_reply" and declined and DECLINE_HINT not in exc.message:
        exc.message += f" (hint: {DECLINE_HINT})"
    res.outcome = "error"
    res.message = str(exc)
    res.failure = {"type": exc.kind, "code": exc.code, "message": exc.message, "tick": tick,
                   "pointer": getattr(exc, "pointer", None), "stderr": exc.stderr or None}
    res.rendered = _render_error(item, exc, tick)


class _Checker:
    """The observer of a conformance item: after every reply, the driver's divergence, the case's
    expectations and the invariants on the implementation's own trace records (F-CONFORM)."""

    def __init__(self, item: Item, impl: Implementation, opts: Options, res: Result, use_state: bool,
                 parts: list[str], known: int = 0, summary: Mapping[str, Any] | None = None):
        self.item, self.impl, self.opts, self.res = item, impl, opts, res
        # F-GOLDEN: the first `known` replies had the golden digests — their checks held in the
        # recorded run (RES-GOLDEN-IDENTITY): only the invariants' memory is brought up to date
        self.known, self.summary = known, summary
        self.parts = [p for p in LEVEL_PARTS if p in parts]
        # events the simulator did not declare are null, never [] (INV-* then derive them from the states)
        self.events = bool(impl.capabilities.get("events"))
        self.ctx = invariants.Context.from_instance(item.instance) if use_state else None
        self.sent: list[dict[str, int]] = []
        # F-REPORT `context`: the last ticks up to and including the step whose reply is checked
        self.history: deque = deque(maxlen=max(0, opts.context) + 1)
        self.pair_parts = list(parts)
        self.prev_rec: dict[str, Any] | None = None
        self.prev_obs: Any = None
        self.robots: list[str] = []

    def observe(self, step: driver.Step) -> bool:
        t, joint, exp, reply, div = step.t, step.joint, step.expected, step.actual, step.divergence
        rec = None
        events = (reply.get("events") or []) if self.events else None
        self.res.event_types.update(e.get("type") for e in exp.get("events") or [] if isinstance(e, dict))
        for part in self.parts:
            self.res.compared[part] += 1
        if t < 0:
            self.robots = driver.robot_order((exp.get("state") or {}).get("robots") or {})
            if self.ctx is not None:
                self.prev_rec = {"type": "header", "instance": self.item.instance,
                                 "execution_seed": self.item.execution_seed, "state": reply.get("state"),
                                 "events": events}
        else:
            self.sent.append(dict(joint))
            if self.ctx is not None:
                rec = {"type": "tick", "t": t,
                       "actions": driver.applied_actions(reply, joint, self.robots,
                                                         None if self.events else self.prev_obs or {}),
                       "chosen": {r: int(joint.get(r, 0)) for r in self.robots},
                       "events": events, "state": reply.get("state")}
                if self.prev_obs is not None:
                    rec["observations"] = self.prev_obs
        target = rec if t >= 0 else self.prev_rec
        if t >= 0:
            self.history.append({"t": t, "actions": dict(joint), "events": list(reply.get("events") or [])})
        if t + 1 < self.known:
            self.res.states += 1
            if self.ctx is not None:
                invariants.remember_records(self.ctx, self.prev_rec if t >= 0 else None, target)
            self.res.invariant_checks = self.summary["invariant_checks_by_reply"][t + 1]
            self.res.expectations = self.summary["expectations_by_reply"][t + 1]
            _count_assertions(self.res, self.item, t, reply, self.impl.capabilities)
        elif _check(self.res, self.item, t, div, reply, self.ctx, self.prev_rec if t >= 0 else None, target,
                    self.opts, self.sent, self.history, self.impl, exp, self.pair_parts):
            return True
        if t >= 0:
            self.prev_rec = rec
        self.prev_obs = reply.get("observations")
        return False


def _given(reply: Mapping[str, Any], caps: Mapping[str, bool]) -> dict[str, Any]:
    """RES-ASSERTION-LEVEL: the parts of ``reply`` that assertions may read (None: not declared)."""
    given = {part: reply.get(part) if caps.get(cap) else None for part, cap in
             (("state", "privileged_state"), ("events", "events"), ("observations", "observations"),
              ("masks", "masks"))}
    if given["events"] is None and caps.get("events"):
        given["events"] = []
    return given


def _count_assertions(res: Result, item: Item, t: int, reply: Mapping[str, Any] | None,
                      caps: Mapping[str, bool]) -> None:
    """Count the assertions after tick ``t`` that the reply lets the harness evaluate, and the rest
    (``reply`` None: a reply of the reference, which carries every part)."""
    if item.case is None or t < 0:
        return
    available = set(ASSERTED_PARTS) if reply is None else \
        available_parts(*_given(reply, caps).values(), reply.get("done"))
    checked, skipped = tally(item.case, t, available, caps.get("diagnostic_state", False))
    res.assertions_checked += checked
    for part, n in skipped.items():
        res.assertions_skipped[part] = res.assertions_skipped.get(part, 0) + n


def _check(res: Result, item: Item, t: int, div, reply: Mapping[str, Any], ctx, prev_rec, target, opts: Options,
           sent, history, impl, expected: Mapping[str, Any], parts) -> bool:
    """Expectations and invariants after one reply, with the driver's divergence; True if the item failed."""
    res.states += 1
    violations: list[invariants.Violation] = []
    if ctx is not None:
        before = sum(ctx.counts.values())
        violations = invariants.check_records(ctx, prev_rec, target)
        res.invariant_checks += sum(ctx.counts.values()) - before
    failed_expectations: list[str] = []
    caps = impl.capabilities
    if item.case is not None and t >= 0:
        exps = item.case.expectations_at(t)
        if exps:
            res.expectations += len(exps)
            # RES-ASSERTION-LEVEL: the assertions on the parts the simulator declares; the rest counted as skipped
            given = _given(reply, caps)
            found = mismatches(item.case, t, given["state"], given["events"], observations=given["observations"],
                               masks=given["masks"], done=reply.get("done"), diagnostic=caps.get("diagnostic_state", False))
            _count_assertions(res, item, t, reply, caps)
            failed_expectations = [str(m) for m in found]
    if div is None and not violations and not failed_expectations:
        return False
    res.outcome = "fail"
    kind = "divergence" if div is not None else ("invariant" if violations else "expectation")
    failure: dict[str, Any] = {"type": kind, "tick": t, "reply": compare.reply_name(t),
                               "ids": sorted({v.invariant for v in violations})}
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
    # what the implementation sent in the failing reply (`agspec render --diff` draws it)
    failure["observed"] = {part: reply[part] for part in ("state", "events") if part in reply}
    named = known.match(div, expected, reply, parts)  # F-CONFORM-KNOWN
    if named is not None:
        failure["known_divergence"] = {**named, "expect": expect_entry(item.id, named["id"])}
    reproducer = item.location if item.kind == "replay" else None  # a replay is its own reproducer
    if opts.repro_dir and item.kind != "replay":
        expectations = [e for e in item.case.expectations if e["after_tick"] <= t] if item.case is not None else []
        data = repro.make_reproducer(ident=item.id, title=item.title, instance=item.instance,
                                       execution_seed=item.execution_seed, actions=sent,
                                       impl=opts.impl_spec or impl.spec, failure=failure, tolerance=opts.tolerance,
                                       expectations=expectations)
        reproducer = str(repro.save_reproducer(opts.repro_dir, data))  # F-OUTPUT-FAILURES
    failure["reproducer"] = reproducer
    res.actions_sent = [dict(a) for a in sent]
    res.failure = failure
    res.message = msg
    res.rendered = _render_fail(item, div, violations, failed_expectations, history, reproducer,
                                opts.impl_spec or impl.spec, t, named)
    return True


def _render_fail(item: Item, div, violations, failed_expectations, history, reproducer, impl_spec, t,
                 named=None) -> str:
    if div is not None:
        text = compare.render_divergence(item.title, item.id, div, list(history), reproducer, impl_spec,
                                        heading=item.heading)
    else:
        lines = [item.heading, f"  first failure {compare.reply_name(t)}"]
        lines += compare.render_context(list(history), t)
        if reproducer:
            lines.append(f"  reproducer: {reproducer}")
        text = "\n".join(lines)
    for v in violations[:5]:
        text += f"\n  violated {v}"
    for m in failed_expectations[:5]:
        text += f"\n  expectation {m}"
    if named is not None:
        text += "\n" + "\n".join(known.render(named, item.id))
    if item.location:
        text += f"\n  case at {item.location}"
    return text


def _render_error(item: Item, exc: ProtocolError, tick: int) -> str:
    at = "during start/load/reset" if tick < 0 else f"at tick {tick}"
    what = exc.kind if exc.kind == exc.code else f"{exc.kind} ({exc.code})"
    text = f"{item.heading}\n  {what} {at}: {exc.message}"
    if exc.stderr:
        tail = exc.stderr.strip().splitlines()[-8:]
        text += "\n  stderr of the simulator (last lines):\n" + "\n".join(f"    | {line}" for line in tail)
    return text


__all__ = ["Options", "Result", "run_item", "LEVEL_PARTS"]
