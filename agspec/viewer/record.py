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

from agspec.trace.write import TraceWriter


class RecordError(RuntimeError):
    """The implementation could not be driven (crash, timeout, protocol error): exit 3."""


@dataclass(frozen=True)
class Recorded:
    ticks: int
    implementation: dict[str, Any]
    capabilities: dict[str, bool]


def _applied(reply: Mapping[str, Any], sent: Mapping[str, int], robots: Sequence[str]) -> dict[str, int]:
    if isinstance(reply.get("applied"), dict):
        return {r: int(reply["applied"].get(r, 0)) for r in robots}
    coerced = {e.get("robot") for e in reply.get("events") or []
               if isinstance(e, dict) and e.get("type") == "action_coerced"}
    return {r: (0 if r in coerced else int(sent.get(r, 0))) for r in robots}


def record(impl_spec: str, instance: Mapping[str, Any], writer: TraceWriter, *, ticks: int,
           execution_seed: int | None = None, controller: str | None = "greedy", controller_seed: int | None = None,
           actions: Sequence[Mapping[str, int]] | None = None, observations: bool = False,
           timeout: float = 5.0) -> Recorded:
    """Drive ``impl_spec`` on ``instance`` for up to ``ticks`` ticks and write its trace to ``writer``.

    Actions come from ``actions`` (a fixed list; the run stops at its end) or else from the reference
    ``controller``. Raises :class:`RecordError` when the implementation fails; the records written so
    far stay in the file (a truncated trace, AG604, that the viewer still renders).
    """
    from agspec.conform.impl import make_impl
    from agspec.conform.protocol import ProtocolError
    from agspec.controllers import make_controller
    from agspec.interp.tick import Simulator
    from agspec.ir.fingerprint import fingerprint

    seed = execution_seed if execution_seed is not None else (instance.get("seeds") or {}).get("execution")
    impl = make_impl(impl_spec, timeout=timeout)
    ctl = None
    if actions is None:
        ctl = make_controller(controller or "greedy", controller_seed)
        ctl.reset(controller_seed if controller_seed is not None else seed)
    t = -1
    try:
        info = impl.start()
        caps = dict(impl.capabilities)
        if not caps.get("privileged_state"):
            raise RecordError(f"{impl_spec}: the implementation does not declare privileged_state; "
                              "a trace needs its global states (F-TRACE)")
        impl.load(instance)
        reply = impl.reset(seed)
        own_obs = bool(caps.get("observations"))
        ref = None
        if ctl is not None and (not own_obs or ctl.information == "global") or observations and not own_obs:
            ref = Simulator(instance)
            ref.reset(seed)
        robots = sorted((reply.get("state") or {}).get("robots") or {}, key=lambda r: tuple(map(int, r.split(","))))
        ctl_record = {"name": ctl.name, "information": ctl.information} if ctl is not None else {"name": "script"}
        writer.header(instance=instance, fingerprint=fingerprint(instance), execution_seed=seed,
                      controller=ctl_record, initial_state=reply.get("state"), initial_events=reply.get("events") or [],
                      implementation=info.get("implementation") or {"name": impl_spec, "version": "?"},
                      horizon=min(ticks, len(actions)) if actions is not None else ticks)
        obs = reply.get("observations") if own_obs else (ref.observe() if ref is not None else None)
        limit = min(ticks, len(actions)) if actions is not None else ticks
        for t in range(limit):
            if reply.get("done"):
                break
            if actions is not None:
                sent = {r: int(a) for r, a in actions[t].items()}
            else:
                view = obs if own_obs and ctl.information != "global" else ref.observe()
                sent = {r: int(a) for r, a in ctl.act(view, ref if ctl.information == "global" else None).items()
                        if int(a) != 0}
            reply = impl.step(sent)
            if ref is not None:
                ref.step(sent)
            writer.tick(t=t, actions=_applied(reply, sent, robots), events=reply.get("events") or [],
                        state=reply.get("state"), observations=obs if observations else None)
            obs = reply.get("observations") if own_obs else (ref.observe() if ref is not None else None)
        writer.footer(metrics={})
        return Recorded(writer.ticks, dict(info.get("implementation") or {}), caps)
    except ProtocolError as exc:
        raise RecordError(f"{impl_spec} failed at tick {t}: {exc}") from None
    finally:
        impl.close()


__all__ = ["record", "Recorded", "RecordError"]
