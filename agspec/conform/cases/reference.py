"""Running cases on the reference (through the lockstep driver), coverage of the spec's rule and
invariant headings, and the suite's self-lint."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Iterable, Sequence

from agspec.conform.cases.expectations import check_expectations
from agspec.conform.cases.model import STATE_KEYS, Case, _show_path
from agspec.conform.impl import ReferenceImpl
from agspec.conform.lockstep.actions import ControllerPolicy, ScriptPolicy
from agspec.conform.lockstep.driver import Pair, Step, lockstep
from agspec.formats.pointer import MISSING
from agspec.formats.pointer import parse as parse_pointer
from agspec.formats.pointer import resolve as resolve_pointer
from agspec.ir.fingerprint import fingerprint
from agspec.ir.schemas import validate_schema
from agspec.ir.validate import errors, validate_instance
from agspec.spec_index import spec_ids

# =============================================================================================
# running a case on the reference interpreter (used by lint, tests and the reference adapter)


@dataclass(frozen=True)
class TickResult:
    t: int  # the epoch the joint action was applied at (after_tick)
    actions: dict[str, int]  # submitted
    applied: dict[str, int]
    state: dict[str, Any]
    events: list[dict[str, Any]]
    observations: dict[str, Any] | None
    done: bool


def reference_run(case: Case, *, observations: bool | Iterable[int] = False) -> list[TickResult]:
    """Run ``case`` on the reference interpreter (the lockstep driver with one side), one
    :class:`TickResult` per transition.

    ``observations``: True for every tick, or the ticks after which observations are wanted.
    """
    want = observations if isinstance(observations, bool) else set(observations)
    if case.driver is not None and "controller" in case.driver:
        seed = case.driver.get("seed")
        policy: Any = ControllerPolicy(case.driver["controller"], case.execution_seed if seed is None else seed)
    else:
        policy = ScriptPolicy(case.actions)
    out: list[TickResult] = []

    def collect(step: Step) -> bool:
        if step.t >= 0:
            reply = step.expected
            obs = reply.get("observations") if (want is True or (want is not False and step.t in want)) else None
            out.append(TickResult(step.t, dict(step.joint), dict(reply["applied"]), reply["state"], reply["events"],
                                  obs, reply["done"]))
        return False

    reference = ReferenceImpl(observations=bool(want) or policy.observes, masks=False)
    try:
        run = lockstep(Pair(reference, None), case.instance, case.execution_seed, policy, case.ticks,
                       stop_at_done=False, observer=collect)
    finally:
        reference.close()
    if run.failure is not None:
        raise RuntimeError(run.failure.message) from run.failure.__cause__
    return out


def check_reference(case: Case) -> list[str]:
    """Run ``case`` on the reference and return every failed expectation (empty: the case passes)."""
    ticks = {e["after_tick"] for e in case.expectations if "observations" in e}
    out: list[str] = []
    for r in reference_run(case, observations=ticks):
        out += check_expectations(case, r.t, r.state, r.events, observations=r.observations, done=r.done)
    return out


# =============================================================================================
# coverage


def coverage(cases: Sequence[Case], universe: Sequence[str] | None = None) -> dict[str, Any]:
    """Which spec rules and invariants the cases exercise.

    ``{"rules": {ID: [case ids]}, "invariants": {ID: [case ids]}, "uncovered": [IDs]}`` over the
    ``### R-…`` and ``### INV-…`` headings of spec/ (every declared ID appears as a key).
    """

    ids = list(universe) if universe is not None else spec_ids(("R-", "INV-"))
    rules: dict[str, list[str]] = {i: [] for i in ids if i.startswith("R-")}
    invariants: dict[str, list[str]] = {i: [] for i in ids if i.startswith("INV-")}
    for case in cases:
        for rid in case.rules:
            if rid in rules and case.id not in rules[rid]:
                rules[rid].append(case.id)
        for iid in case.invariants:
            if iid in invariants and case.id not in invariants[iid]:
                invariants[iid].append(case.id)
    uncovered = [i for i in ids if not (rules.get(i) or invariants.get(i))]
    return {"rules": rules, "invariants": invariants, "uncovered": uncovered}


# =============================================================================================
# self-lint


def lint_suite(cases: Sequence[Case], *, run: bool = True) -> list[str]:
    """The suite's self-check; each problem is ``file:line: message``. Empty means clean.

    * case ids are unique (two cases with the same defining content are duplicates);
    * every cited rule / invariant ID is a heading of the spec;
    * every instance passes the instance schema and the semantic checks (AG5xx errors);
    * every case asserts something (no vacuous case);
    * with ``run``: on the reference interpreter, every scripted action is legal under the mask
      unless the case cites R-ACTION-VALIDATION (masked actions must be deliberate), and every
      asserted state or observation pointer exists.
    """

    problems: list[str] = []
    known = set(spec_ids(("R-", "O-", "D-", "INV-")))
    seen: dict[str, Case] = {}
    checked: dict[str, list[str]] = {}
    for case in cases:
        loc = case.location
        if case.id in seen:
            problems.append(f"{loc}: duplicate case id {case.id}: same content as {seen[case.id].location}")
        seen.setdefault(case.id, case)
        for ident in case.rules + case.invariants:
            if ident not in known:
                problems.append(f"{loc}: {ident} is not a rule or invariant heading of the spec (R-, O-, D-, INV-)")
        fp = fingerprint(case.instance)
        if fp not in checked:
            issues = errors(validate_schema(case.instance)) or errors(validate_instance(case.instance))
            checked[fp] = [f"{i.code} {i.pointer or '/'}: {i.message}" for i in issues]
        for msg in checked[fp]:
            problems.append(f"{case.location}: instance {case.instance.get('id')!r}: {msg}")
        if not case.expectations:
            problems.append(f"{loc}: the case asserts nothing (no expectations)")
        for ident, wanted in (("R-", case.rules), ("INV-", case.invariants)):
            if not wanted and ident == "R-":
                problems.append(f"{loc}: the case cites no rule")
        if run and not checked[fp]:
            problems += _lint_run(case)
    return problems


def _lint_run(case: Case) -> list[str]:
    out: list[str] = []
    file = _show_path(case.source, case.root)
    deliberate = "R-ACTION-VALIDATION" in case.rules
    obs_ticks = {e["after_tick"] for e in case.expectations if "observations" in e}
    try:
        for r in reference_run(case, observations=obs_ticks):
            if case.driver is None and not deliberate:
                for robot, a in r.actions.items():
                    if r.applied.get(robot) != a:
                        line = case.line_of(f"script/{r.t}")
                        out.append(f"{file}:{line}: script tick {r.t}, robot {robot}: action {a} is masked for the "
                                   "reference (coerced to idle); cite R-ACTION-VALIDATION if that is intended")
            for k, exp in enumerate(case.expectations):
                if exp["after_tick"] != r.t or exp.get("_index") == "trace":
                    continue
                line = case.line_of(f"expectations/{exp.get('_index', k)}")
                for pointer in exp.get("state", {}):
                    toks = parse_pointer(pointer)
                    if toks and toks[0] not in STATE_KEYS:
                        out.append(f"{file}:{line}: {pointer}: the global state has no field {toks[0]!r}")
                    elif resolve_pointer(r.state, pointer) is MISSING:
                        out.append(f"{file}:{line}: {pointer} does not exist in the reference state after tick {r.t}")
                for pointer in exp.get("observations", {}):
                    if r.observations is not None and resolve_pointer(r.observations, pointer) is MISSING:
                        out.append(f"{file}:{line}: observation {pointer} does not exist after tick {r.t}")
    except Exception as exc:  # the reference crashing on a case is a suite problem worth a located report
        out.append(f"{case.location}: the reference interpreter failed: {type(exc).__name__}: {exc}")
    return out
