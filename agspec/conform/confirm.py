"""Does a failure reproduce the way its reproducer will be run? (F-CONFORM-NONDETERMINISM, F-CONFORM-HISTORY)

A reproducer (F-REPRO) is replayed by ``agspec conform --replay FILE``: a new process of the simulator,
``load``, ``reset`` and the action prefix, in lockstep with the reference.  So the first failure of a
run is confirmed exactly that way — never in the process that failed, whose earlier episodes may have
left state behind:

1. its reproducer is replayed against a *fresh* implementation (a new simulator process; for an
   in-process ``python:`` adapter, a new Python process), ``replays`` times.  If every replay fails the
   same way (outcome, tick, kind, JSON Pointer, invariant IDs), the failure is reproduced;
2. otherwise the fresh replays are compared with each other (a second one is run if needed).  If they
   disagree, the simulator gives different answers to the same requests in fresh processes:
   **nondeterministic** (exit 5);
3. if they agree with each other but not with the run, the failure depends on what the process had
   done before: the reproducer is extended with that **history** — every ``load``, ``reset`` and
   ``step`` request the process had received before the failing episode — and replayed fresh.  If
   that reproduces the failure it is **history-dependent** (still a failure, exit 1; the history
   reproducer is written in place of the plain one, so the printed replay command reproduces it);
   if not, nondeterministic.

The next failures, up to :data:`CONFIRM_MAX` in all, are replayed alone once (and with their history
when alone does not reproduce them), so that their reproducers reproduce too (:func:`confirm_failures`).
"""

from __future__ import annotations

import dataclasses
import multiprocessing
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, TypeVar

from agspec.conform import repro
from agspec.conform.impl import ImplSpecError, make_impl
from agspec.conform.items import from_reproducer
from agspec.conform.run_item import Options, Result, run_item

NONDETERMINISTIC, HISTORY_DEPENDENT, REPRODUCED = "nondeterministic", "history_dependent", "reproduced"
UNCONFIRMED = "unconfirmed"  # no fresh implementation could be started from the spec: nothing is claimed


R = TypeVar("R")


@dataclass(frozen=True)
class Confirmation:
    kind: str  # REPRODUCED, HISTORY_DEPENDENT or NONDETERMINISTIC
    evidence: dict[str, Any] | None = None
    reproducer: dict[str, Any] | None = None  # the history reproducer (HISTORY_DEPENDENT)


def signature(result: Result) -> tuple[Any, ...]:
    """What must recur for a failure to count as reproduced: outcome, tick, kind, place and invariant IDs."""
    f = result.failure or {}
    return (result.outcome, f.get("tick"), f.get("type"), f.get("path"), tuple(f.get("ids") or ()))


def _seen(result: Result) -> dict[str, Any]:
    f = result.failure or {}
    return {"outcome": result.outcome, "tick": f.get("tick"), "path": f.get("path"), "message": result.message}


def reproducer_of(first: Result, impl_spec: str, opts: Options, history: bool = False) -> dict[str, Any]:
    """The reproducer of ``first`` (F-REPRO), with its process's history when ``history``."""
    item = first.item
    tick = (first.failure or {}).get("tick")
    tick = tick if isinstance(tick, int) else len(first.actions_sent) - 1
    expectations = [e for e in item.case.expectations if e["after_tick"] <= tick] if item.case is not None else []
    return repro.make_reproducer(ident=item.id, title=item.title, instance=item.instance,
                                   execution_seed=item.execution_seed, actions=first.actions_sent,
                                   impl=opts.impl_spec or impl_spec, failure=first.failure,
                                   tolerance=opts.tolerance, expectations=expectations,
                                   history=(first.history or ()) if history else ())


class CannotStart(Exception):
    """A fresh implementation cannot be made or started from the spec (an API caller's own object)."""


def _fresh(data: dict[str, Any], impl_spec: str, timeout: float, validate: bool, opts: Options) -> Result:
    """``agspec conform --replay`` of ``data`` against a new implementation (closed afterwards)."""
    item = from_reproducer(data, str(data.get("id") or "reproducer"))
    try:
        impl = make_impl(impl_spec, timeout=timeout, validate=validate)
    except ImplSpecError as exc:
        raise CannotStart(str(exc)) from None
    try:
        result = run_item(item, impl, opts)
    finally:
        impl.close()
    if result.outcome == "error" and (result.failure or {}).get("code") == "spawn":
        raise CannotStart(result.message or "")
    return result


def fresh_run(data: dict[str, Any], impl_spec: str, timeout: float, validate: bool, opts: Options) -> Result:
    """Replay a reproducer as ``--replay`` will: a simulator process is new with every implementation
    made; an in-process adapter keeps module state in this process, so it is replayed in a new one."""
    quiet = dataclasses.replace(opts, repro_dir=None, golden_dir=None)
    return in_fresh_process(impl_spec.startswith("python:"), _fresh, data, impl_spec, timeout, validate, quiet)


def judge(want: Any, replay: Callable[[bool], R], sig: Callable[[R], Any], *, replays: int = 1,
          has_history: bool = False) -> tuple[str, list[R], list[R]]:
    """THE judgement of a failure (F-CONFORM-NONDETERMINISM, F-CONFORM-HISTORY), for ``agspec conform``
    and ``agspec diff`` alike: ``replay(with_history)`` runs the failing episode again in fresh
    implementations (alone, or after the requests its process had received before); ``sig`` is what must
    recur.  Returns the verdict — REPRODUCED when every fresh replay alone fails the same way;
    HISTORY_DEPENDENT when the replays alone agree with each other but not with the run and every replay
    with the history fails the same way; NONDETERMINISTIC otherwise — with the replays alone and those
    with the history."""
    alone = [replay(False) for _ in range(max(1, replays))]
    if all(sig(r) == want for r in alone):
        return REPRODUCED, alone, []
    if len(alone) < 2:
        alone.append(replay(False))
    again: list[R] = []
    if has_history and all(sig(r) == sig(alone[0]) for r in alone):
        again = [replay(True) for _ in range(max(1, replays))]
        if all(sig(r) == want for r in again):
            return HISTORY_DEPENDENT, alone, again
    return NONDETERMINISTIC, alone, again


def confirm(first: Result, impl_spec: str, *, timeout: float, validate: bool, opts: Options,
            replays: int = 1) -> Confirmation:
    """Confirm the run's first failure (see the module docstring)."""
    want = signature(first)
    plain = reproducer_of(first, impl_spec, opts)
    with_history = reproducer_of(first, impl_spec, opts, history=True) if first.history else None

    def replay(history: bool) -> Result:
        return fresh_run(with_history if history else plain, impl_spec, timeout, validate, opts)

    try:
        kind, alone, again = judge(want, replay, signature, replays=replays, has_history=bool(first.history))
    except CannotStart:
        return Confirmation(UNCONFIRMED)
    if kind == REPRODUCED:
        return Confirmation(REPRODUCED)
    evidence: dict[str, Any] = {"id": first.item.id, "first": _seen(first), "replays": [_seen(r) for r in alone],
                                "reproduced": sum(signature(r) == want for r in alone), "fresh": True}
    if again:
        evidence["with_history"] = [_seen(r) for r in again]
    if kind == HISTORY_DEPENDENT:
        return Confirmation(HISTORY_DEPENDENT, {**evidence, **history_facts(first.item.id, first.history)},
                            with_history)
    return Confirmation(NONDETERMINISTIC, evidence)


def in_fresh_process(needed: bool, fn: Callable[..., R], *args: Any) -> R:
    """``fn(*args)`` here, or — when an in-process adapter takes part (``needed``), whose module state lives
    in this process — in a new Python process, as ``--replay`` would run it."""
    if not needed:
        return fn(*args)
    with ProcessPoolExecutor(max_workers=1, mp_context=multiprocessing.get_context("spawn")) as pool:
        return pool.submit(fn, *args).result()


CONFIRM_MAX = 5  # failures of a run whose reproducers are replayed alone in a fresh process


@dataclass
class Findings:
    """What confirming a run's failures showed (F-CONFORM-NONDETERMINISM, F-CONFORM-HISTORY)."""

    nondeterministic: dict[str, Any] | None = None
    history_dependent: dict[str, Any] | None = None  # the first failure that needs its process's history
    rewrites: list[tuple[Result, dict[str, Any]]] = dataclasses.field(default_factory=list)  # history reproducers


def confirm_failures(failing: list[Result], impl_spec: str, *, timeout: float, validate: bool, opts: Options,
                     replays: int = 1, limit: int = CONFIRM_MAX) -> Findings:
    """Confirm a run's failures, in item order: the first fully (:func:`confirm`), the next ones up to
    ``limit`` by one fresh replay alone, then, if that does not reproduce, one with their history.  A
    failure that needs its history gets a history reproducer; once one did, so do the failures past
    ``limit`` (unconfirmed, they are most likely to need it too)."""
    out = Findings()
    if not failing:
        return out
    first = failing[0]
    verdict = confirm(first, impl_spec, timeout=timeout, validate=validate, opts=opts, replays=replays)
    if verdict.kind == UNCONFIRMED:
        return out
    if verdict.kind == NONDETERMINISTIC:
        out.nondeterministic = verdict.evidence
        return out
    if verdict.kind == HISTORY_DEPENDENT and verdict.reproducer is not None:
        out.history_dependent = verdict.evidence
        out.rewrites.append((first, verdict.reproducer))
    for result in failing[1:limit]:
        want = signature(result)
        try:
            alone = fresh_run(reproducer_of(result, impl_spec, opts), impl_spec, timeout, validate, opts)
        except CannotStart:
            break
        if signature(alone) == want:
            continue
        evidence = {"id": result.item.id, "first": _seen(result), "replays": [_seen(alone)], "reproduced": 0,
                    "fresh": True}
        if result.history:
            data = reproducer_of(result, impl_spec, opts, history=True)
            again = fresh_run(data, impl_spec, timeout, validate, opts)
            evidence["with_history"] = [_seen(again)]
            if signature(again) == want:
                out.rewrites.append((result, data))
                if out.history_dependent is None:
                    out.history_dependent = {**evidence, **history_facts(result.item.id, result.history)}
                continue
        out.nondeterministic = evidence
        return out
    if out.history_dependent is not None:
        out.rewrites += [(r, reproducer_of(r, impl_spec, opts, history=True)) for r in failing[limit:] if r.history]
    return out


def history_facts(ident: str, history: Any) -> dict[str, Any]:
    """F-CONFORM-HISTORY: how much came before a failure that needs its process's history."""
    history = history or ()
    loads = sum(1 for cmd, _ in history if cmd == "load")
    return {"episodes": loads, "requests": len(history),
            "message": f"{ident} fails only after the {len(history)} request(s) ({loads} load(s)) its "
                       "simulator process had received before it; alone, in a fresh process, it does not"}


def write(path: str | None, data: dict[str, Any]) -> str | None:
    """Write ``data`` where the plain reproducer was (the path already printed); the path written."""
    if not path:
        return None
    target = Path(path)
    try:
        return str(repro.save_reproducer(target.parent, data))
    except OSError:
        return None


__all__ = ["Confirmation", "Findings", "confirm", "confirm_failures", "CONFIRM_MAX", "fresh_run", "history_facts",
           "in_fresh_process", "judge", "reproducer_of", "signature", "write",
           "NONDETERMINISTIC", "HISTORY_DEPENDENT", "REPRODUCED", "UNCONFIRMED"]
