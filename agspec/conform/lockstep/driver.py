"""The one lockstep driver (F-CONFORM): every episode agspec runs against an implementation.

A :class:`Pair` holds the *expected* side and the *actual* side, both
:class:`~agspec.conform.impl.Implementation` objects (the reference interpreter is
``ReferenceImpl``, one more implementation behind the same interface as a subprocess or a
``python:`` adapter); the actual side may be absent (recording one implementation).
:func:`lockstep` loads and resets both, then per tick asks the policy for the joint action (on the
expected side's observations — or, when it has none or the policy is ``global``, on a shadow
reference interpreter stepped with the same actions), steps both, compares the replies with :func:`compare_replies` (the one
comparison, :func:`agspec.formats.pointer.first_difference`) and hands every reply pair to the
caller's ``observer``.  It stops at the first divergence, when the observer asks to, at the end of
the execution (``done``) or after ``ticks`` steps, and returns a :class:`Run`.

Failures: an implementation that crashes, times out or breaks the protocol ends the run with
``Run.failure`` (an :class:`ImplementationFailure`, its cause chained) and a divergence of kind
``error`` — unless both sides refuse the same step the same way (``Run.both_failed``).  A script
action that cannot be resolved (F-SYMBOLIC-ACTIONS) ends it with ``Run.invalid``.

Callers: ``agspec conform`` items — suite cases, catalogue episodes, ``--replay``, the pytest
plugin — through :func:`agspec.conform.run_item.run_item`; ``agspec diff`` and its shrink replays
through :mod:`agspec.conform.explore.diff`; the viewer's recording (:mod:`agspec.viewer.record`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, Mapping, Protocol, Sequence

from agspec.conform.impl import history as history_mod
from agspec.conform.lockstep.compare import MISSING, Divergence, behavioural, compare_reply
from agspec.formats.actions import IDLE, N_ACTIONS, IllegalAction, option_ids, symbolic
from agspec.interp.tick import Simulator
from agspec.ir.fingerprint import fingerprint

Json = dict[str, Any]
JointAction = dict[str, Any]  # robot id -> int or symbolic action


@dataclass(frozen=True)
class Step:
    """What the observer sees after every reply: ``t`` (-1 for the reset replies), the joint action
    sent (None for reset), the observations it was chosen on (I_t of the driving side), both replies
    and the divergence the comparison found (None: equal, or nothing compared)."""

    t: int
    joint: Mapping[str, int] | None
    observations: Mapping[str, Any] | None
    expected: Mapping[str, Any]
    actual: Mapping[str, Any] | None
    divergence: Divergence | None


Observer = Callable[[Step], bool]  # True: stop the run


class Policy(Protocol):
    """Where the joint actions come from (:mod:`agspec.conform.lockstep.actions`)."""

    name: str
    information: str  # "local" or "global" (reads the reference simulator)
    observes: bool  # acts on observations (False: a script of integers)

    def reset(self, grid: Mapping[str, Any] | None = None) -> None:
        """A new episode on the instance's scenario ``grid`` (public information)."""

    def act(self, t: int, observations: Mapping[str, Any] | None, robots: Sequence[str],
            simulator: Simulator | None = None) -> dict[str, int]: ...


class ImplementationFailure(Exception):
    """One side failed (crash, timeout, protocol error); the underlying error is ``__cause__``."""

    def __init__(self, side: str, kind: str, message: str):
        super().__init__(message)
        self.side, self.kind, self.message = side, kind, message


def error_kind(exc: BaseException) -> str:
    """A stable kind for an implementation failure: ``category/code`` of a ProtocolError
    (F-PROTOCOL-ERRORS, e.g. ``crash/eof``, ``timeout/timeout``, ``protocol/wrong_seq``), else a
    classification of the exception."""
    kind, code = getattr(exc, "kind", None), getattr(exc, "code", None)
    if isinstance(kind, str) and kind:
        return f"{kind}/{code}" if isinstance(code, str) and code and code != kind else kind
    if isinstance(code, str) and code:
        return code
    if isinstance(exc, TimeoutError):
        return "timeout"
    if isinstance(exc, (EOFError, BrokenPipeError, ConnectionError)):
        return "crash"
    return type(exc).__name__


def failure_message(exc: BaseException) -> str:
    """The failure's message, with the last lines of the simulator's stderr when it left any."""
    message = getattr(exc, "message", None)
    text = message if isinstance(message, str) and message else str(exc)
    stderr = getattr(exc, "stderr", None)
    if isinstance(stderr, str) and stderr.strip():
        tail = stderr.strip().splitlines()[-5:]
        text += "\n    stderr of the simulator:\n" + "\n".join(f"      | {line}" for line in tail)
    return text


def compare_replies(tick: int, exp: Mapping[str, Any], act: Mapping[str, Any], parts: Sequence[str],
                    tolerance: float | None = None) -> Divergence | None:
    """The first difference of two replies over ``parts`` (in :data:`~agspec.conform.lockstep.compare.COMPARED`
    order); the optional fields ``done`` and ``applied`` are compared when both replies carry them."""
    use = [p for p in parts if p not in ("done", "applied")]
    use += [p for p in ("done", "applied") if p in exp and p in act]
    d = compare_reply(tick, exp, act, use, tolerance)
    if d is None or d.pointer or not (d.expected is MISSING or d.actual is MISSING):
        return d
    return Divergence(d.tick, d.where, d.pointer, d.expected, d.actual, d.more,
                      message=f"{d.where} present on one side only")


def robot_order(robots) -> list[str]:
    return sorted(robots, key=lambda r: tuple(int(x) for x in r.split(",")))


def applied_actions(reply: Mapping[str, Any], sent: Mapping[str, int], robots: Sequence[str],
                    observations: Mapping[str, Any] | None = None) -> dict[str, int]:
    """The actions an implementation applied: its ``applied`` map, else the sent actions minus the
    ``action_coerced`` ones (F-TRACE ``actions``).  Without the events capability (``observations``
    given), R-ACTION-VALIDATION on its own previous masks: a masked or out-of-range action idles."""
    if isinstance(reply.get("applied"), dict):
        return {r: int(reply["applied"].get(r, 0)) for r in robots}
    if observations is not None:
        def legal(r: str, a: int) -> bool:
            mask = (observations.get(r) or {}).get("mask") if isinstance(observations.get(r), dict) else None
            if not isinstance(mask, list):  # no mask known: only an out-of-range action is surely coerced
                return 0 <= a < N_ACTIONS
            return 0 <= a < len(mask) and bool(mask[a])

        return {r: (int(sent.get(r, 0)) if legal(r, int(sent.get(r, 0))) else 0) for r in robots}
    coerced = {e.get("robot") for e in reply.get("events") or []
               if isinstance(e, dict) and e.get("type") == "action_coerced"}
    return {r: (0 if r in coerced else int(sent.get(r, 0))) for r in robots}


_CAPABILITY_OF = (("state", "privileged_state"), ("events", "events"), ("observations", "observations"),
                  ("masks", "masks"))


@dataclass
class Pair:
    """The expected side and the actual side (None: drive one implementation, compare nothing).

    ``specs`` are the ``--impl`` values, ``labels`` their short forms for messages; sides are called
    ``expected_side`` / ``actual_side`` ("A" or "B") in failures.  ``cache_loads``: skip ``load``
    when the side already holds the instance (same fingerprint).
    """

    expected: Any
    actual: Any | None
    labels: tuple[str, str] = ("expected", "actual")
    specs: tuple[str, str] = ("", "")
    expected_side: str = "A"
    cache_loads: bool = True
    _loaded: dict[str, str] = field(default_factory=dict, repr=False)

    @property
    def actual_side(self) -> str:
        return "B" if self.expected_side == "A" else "A"

    def sides(self) -> list[tuple[str, Any]]:
        out = [(self.expected_side, self.expected)]
        if self.actual is not None:
            out.append((self.actual_side, self.actual))
        return out

    def label(self, side: str) -> str:
        return self.labels[0] if side == self.expected_side else self.labels[1]

    @property
    def expected_label(self) -> str:
        return self.labels[0]

    @property
    def actual_label(self) -> str:
        return self.labels[1]

    @property
    def other_spec(self) -> str:
        """The ``--impl`` value of the side whose values are compared against the expected ones."""
        return self.specs[1]

    def parts(self) -> list[str]:
        """What is compared: t and done always, the rest when both sides declare the capability."""
        if self.actual is None:
            return []
        ce, ca = self.expected.capabilities, self.actual.capabilities
        return ["t", "done"] + [part for part, cap in _CAPABILITY_OF if ce.get(cap, False) and ca.get(cap, False)]

    @property
    def diagnostic(self) -> bool:
        """F-TRACE-STATE: the state's diagnostic fields are compared only when both sides declare them."""
        return self.actual is not None and all(impl.capabilities.get("diagnostic_state", False)
                                               for _, impl in self.sides())

    def call(self, side: str, fn, *args):
        try:
            return fn(*args)
        except Exception as exc:  # crash, timeout, protocol error: a divergence of kind "error"
            self._loaded.pop(side, None)
            raise ImplementationFailure(side, error_kind(exc), f"implementation {side} ({self.label(side)}) "
                                        f"failed: {error_kind(exc)}: {failure_message(exc)}") from exc

    def load(self, instance: Mapping[str, Any]) -> None:
        fp = fingerprint(instance) if self.cache_loads else None
        for side, impl in self.sides():
            if fp is None or self._loaded.get(side) != fp:
                self.call(side, impl.load, instance)
                if fp is not None:
                    self._loaded[side] = fp

    def begin(self, instance: Mapping[str, Any], execution_seed: int | None) -> tuple[Any, Any]:
        """Each side's episode start (``load`` where the side does not hold the instance, then ``reset``,
        RES-STREAM-INPUT); the expected and the actual reset replies."""
        fp = fingerprint(instance) if self.cache_loads else None
        replies = {}
        for side, impl in self.sides():
            fresh = fp is None or self._loaded.get(side) != fp
            self._loaded.pop(side, None)
            replies[side] = self.call(side, impl.begin, instance if fresh else None, execution_seed)
            if fp is not None:
                self._loaded[side] = fp
        return replies[self.expected_side], replies.get(self.actual_side)

    def send_history(self, histories: Mapping[str, Any]) -> None:
        """F-CONFORM-HISTORY: send each side the requests its process had received before (``histories`` by
        side), as a fresh process must get them; the instance it last loaded counts as loaded."""
        for side, impl in self.sides():
            history = histories.get(side) or ()
            history_mod.send(impl, history)
            loads = [payload for cmd, payload in history if cmd == "load"]
            if loads and self.cache_loads:
                self._loaded[side] = fingerprint(loads[-1])

    def close(self) -> None:
        for _, impl in self.sides():
            try:
                impl.close()
            except Exception:
                pass


@dataclass
class Run:
    """One lockstep episode: the joint actions sent (integers and their symbolic form) and how it ended."""

    divergence: Divergence | None
    actions: list[dict[str, int]] = field(default_factory=list)
    script: list[JointAction] = field(default_factory=list)  # symbolic, against the driving options
    ticks: int = 0
    coerced: int = 0  # sent actions the driving side's mask forbids (R-ACTION-VALIDATION coerces them)
    states: int = 0  # replies compared
    both_failed: str = ""  # both sides refused the same step the same way (e.g. slot_overflow)
    failure: ImplementationFailure | None = None
    failure_tick: int = -1
    invalid: str = ""  # F-SYMBOLIC-ACTIONS: the script cannot be resolved at tick len(actions)
    stopped: bool = False  # the observer asked to stop
    replies: tuple[Any, Any] = (None, None)  # the last (expected, actual) replies


class _Shadow:
    """An in-process reference interpreter stepped with the sent actions: observations (and, for a
    global policy, the state) when the expected side does not provide them."""

    def __init__(self, instance: Mapping[str, Any], seed: int | None):
        self.sim = Simulator(instance)
        self.sim.reset(seed)

    def step(self, joint: Mapping[str, int]) -> None:
        self.sim.step(joint)


def lockstep(pair: Pair, instance: Mapping[str, Any], execution_seed: int | None, policy: Policy, ticks: int, *,
             stop_at_done: bool = True, tolerance: float | None = None, observer: Observer | None = None) -> Run:
    """Run the pair for up to ``ticks`` steps (see the module docstring); never raises for a failing
    implementation, a failing observer or policy is the caller's bug and propagates."""
    parts = pair.parts()
    run = Run(None)
    diagnostic = pair.diagnostic

    def compare(t: int, exp: Mapping[str, Any], act: Mapping[str, Any]) -> Divergence | None:
        if act is exp:  # F-GOLDEN: a resumed run's prefix, where the implementation sent this very reply
            return None
        if not diagnostic and "state" in parts:  # F-TRACE-STATE: behaviour, not bookkeeping
            exp = {**exp, "state": behavioural(exp.get("state"))}
            act = {**act, "state": behavioural(act.get("state"))}
        return compare_replies(t, exp, act, parts, tolerance)

    es, as_ = pair.expected_side, pair.actual_side
    exp_impl, act_impl = pair.expected, pair.actual

    def fail(t: int, failure: ImplementationFailure) -> Run:
        run.failure, run.failure_tick = failure, t
        run.divergence = Divergence(t, "error", failure.kind, None, None, message=failure.message, side=failure.side)
        return run

    try:
        exp, act = pair.begin(instance, execution_seed)
    except ImplementationFailure as failure:
        return fail(-1, failure)
    run.replies = (exp, act)
    simulator = getattr(exp_impl, "simulator", None)
    shadow = None
    if (policy.observes and exp.get("observations") is None) or (policy.information == "global" and simulator is None):
        shadow = _Shadow(instance, execution_seed)
        simulator = shadow.sim
    if act is not None:
        run.divergence = compare(-1, exp, act)
        run.states = 1
    if observer is not None and observer(Step(-1, None, None, exp, act, run.divergence)):
        run.stopped = True
    if run.divergence is not None or run.stopped:
        return run
    policy.reset((instance.get("scenario") or {}).get("grid"))
    robots = robot_order((exp.get("state") or {}).get("robots") or (simulator.agents() if simulator else {}))
    for t in range(ticks):
        if stop_at_done and exp.get("done"):
            break
        observations = exp.get("observations")
        if shadow is not None and (observations is None or policy.information == "global"):
            observations = shadow.sim.observe()
        try:
            joint = policy.act(t, observations, robots, simulator)
        except IllegalAction as exc:
            run.invalid = f"tick {t}: {exc}"
            return run
        joint = {r: int(a) for r, a in joint.items() if int(a) != IDLE}
        run.actions.append(joint)
        run.script.append({r: symbolic(a, *option_ids((observations or {}).get(r))) for r, a in joint.items()})
        try:
            exp = pair.call(es, exp_impl.step, joint)
        except ImplementationFailure as failure:
            run.ticks = t + 1
            if act_impl is None:
                return fail(t, failure)
            try:  # a divergence only if the other side does not fail the same way
                pair.call(as_, act_impl.step, joint)
                same = False
            except ImplementationFailure as other:
                same = other.kind == failure.kind
            if same:
                run.both_failed = failure.message
                return run
            return fail(t, failure)
        if act_impl is not None:
            try:
                act = pair.call(as_, act_impl.step, joint)
            except ImplementationFailure as failure:
                run.ticks = t + 1
                return fail(t, failure)
        if shadow is not None:
            shadow.step(joint)
        for robot, a in joint.items():
            mask = ((observations or {}).get(robot) or {}).get("mask")
            if mask is not None and not (0 <= a < len(mask) and mask[a]):
                run.coerced += 1
        run.ticks = t + 1
        run.replies = (exp, act)
        if act is not None:
            run.states += 1
            run.divergence = compare(t, exp, act)
        if observer is not None and observer(Step(t, joint, observations, exp, act, run.divergence)):
            run.stopped = True
        if run.divergence is not None or run.stopped:
            return run
    return run


__all__ = ["Pair", "Run", "Policy", "Observer", "ImplementationFailure", "lockstep", "compare_replies",
           "applied_actions", "robot_order", "error_kind", "failure_message", "JointAction", "Step"]
