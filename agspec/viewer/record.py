"""Recording a trace (F-TRACE) from any implementation spoken to over the protocol (F-PROTOCOL).

``agspec run --trace`` records the reference interpreter only. A third-party simulator is recorded
here: it is started like ``agspec conform --impl`` starts it (agspec.conform.impl.make_impl: a
command line, ``python:pkg.mod:factory`` or ``reference``), loaded with an instance, reset, and
stepped with joint actions from a reference controller — or from a fixed action list (a
reproducer, F-REPRO). Every reply becomes a trace record built from the implementation's own
replies, as the harness builds them for the invariants (F-CONFORM step 3): header from ``reset``,
per tick the applied actions (the reply's ``applied``, else the sent actions minus the
``action_coerced`` ones), the events and the state, and I_t when asked for.

The controller acts on the implementation's own observations when it declares the
``observations`` capability, otherwise on a private reference interpreter stepped with the same
actions (as ``agspec conform`` drives its episodes); a ``global`` controller (centralized) always
reads the private reference.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping, Sequence

from agspec.conform.impl import make_impl
from agspec.conform.lockstep.actions import ControllerPolicy, ScriptPolicy
from agspec.conform.lockstep.driver import Pair, Step, applied_actions, lockstep
from agspec.formats.trace import TraceWriter
from agspec.ir.fingerprint import fingerprint


class RecordError(RuntimeError):
    """The implementation could not be driven (crash, timeout, protocol error): exit 3."""


@dataclass(frozen=True)
class Recorded:
    ticks: int
    implementation: dict[str, Any]
    capabilities: dict[str, bool]


def record(impl_spec: str, instance: Mapping[str, Any], writer: TraceWriter, *, ticks: int,
           execution_seed: int | None = None, controller: str | None = "greedy", controller_seed: int | None = None,
           actions: Sequence[Mapping[str, int]] | None = None, observations: bool = False,
           timeout: float = 5.0) -> Recorded:
    """Drive ``impl_spec`` on ``instance`` for up to ``ticks`` ticks and write its trace to ``writer``.

    Actions come from ``actions`` (a fixed list; the run stops at its end) or else from the reference
    ``controller``. Raises :class:`RecordError` when the implementation fails; the records written so
    far stay in the file (a truncated trace, AG604, that the viewer still renders).
    """
    seed = execution_seed if execution_seed is not None else (instance.get("seeds") or {}).get("execution")
    impl = make_impl(impl_spec, timeout=timeout)
    if actions is None:
        policy: Any = ControllerPolicy(controller or "greedy", controller_seed,
                                       reset_seed=controller_seed if controller_seed is not None else seed)
        ctl_record = {"name": policy._ctl.name, "information": policy.information}
    else:
        policy = ScriptPolicy([{r: int(a) for r, a in joint.items()} for joint in actions])
        policy.observes = policy.observes or observations  # I_t for the trace: from a shadow if need be
        ctl_record = {"name": "script"}
    limit = min(ticks, len(actions)) if actions is not None else ticks
    ev = (instance.get("scenario") or {}).get("evaluation") or {}
    cap = ev.get("timeout") if ev.get("mode") == "batch" else ev.get("horizon")
    if isinstance(cap, int):  # F-CLAIM-HORIZON: a run executes at most its instance's evaluation horizon
        limit = min(limit, cap)
    try:
        try:
            info = impl.start()
        except Exception as exc:
            raise RecordError(f"{impl_spec} failed at tick -1: {exc}") from None
        caps = dict(impl.capabilities)
        if not caps.get("privileged_state"):
            raise RecordError(f"{impl_spec}: the implementation does not declare privileged_state; "
                              "a trace needs its global states (F-TRACE)")
        robots: list[str] = []
        own = bool(caps.get("observations"))

        def events_of(reply: Mapping[str, Any]) -> list | None:
            """F-TRACE: null when the implementation reports no events (so nothing pairs them with states)."""
            return (reply.get("events") or []) if caps.get("events") else None
        previous: list[Any] = [None]  # the implementation's own I_t (the reply before the step)

        def write(step: Step) -> bool:
            t, reply = step.t, step.expected
            if t < 0:
                robots.extend(sorted((reply.get("state") or {}).get("robots") or {},
                                     key=lambda r: tuple(map(int, r.split(",")))))
                writer.header(instance=instance, fingerprint=fingerprint(instance), execution_seed=seed,
                              controller=ctl_record, initial_state=reply.get("state"),
                              initial_events=events_of(reply),
                              implementation=info.get("implementation") or {"name": impl_spec, "version": "?"},
                              horizon=limit)
            else:
                seen = previous[0] if own else step.observations
                writer.tick(t=t, actions=applied_actions(reply, step.joint, robots), events=events_of(reply),
                            state=reply.get("state"), observations=seen if observations else None)
            previous[0] = reply.get("observations")
            return False

        pair = Pair(impl, None, (impl_spec, ""), (impl_spec, ""))
        run = lockstep(pair, instance, seed, policy, limit, observer=write)
        if run.failure is not None:
            raise RecordError(f"{impl_spec} failed at tick {run.failure_tick}: {run.failure.__cause__ or run.failure}")
        writer.footer(metrics={})
        return Recorded(writer.ticks, dict(info.get("implementation") or {}), caps)
    finally:
        impl.close()


__all__ = ["record", "Recorded", "RecordError"]
