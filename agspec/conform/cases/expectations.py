"""Evaluating a case's expectations on a reply: state pointers, absent fields, event patterns
(a maximum one-to-one matching), observations and the end flag."""

from __future__ import annotations

from dataclasses import dataclass
from typing import AbstractSet as Set
from typing import Any, Mapping, Sequence

from agspec.conform.cases.model import Case, _show_path
from agspec.conform.lockstep.compare import is_diagnostic, reply_name
from agspec.formats.pointer import MISSING, first_difference, iter_differences, show
from agspec.formats.pointer import resolve as resolve_pointer


def event_matches(pattern: Mapping[str, Any], event: Mapping[str, Any]) -> bool:
    """Subset match: ``event`` has every key of ``pattern`` with an equal value."""
    return all(k in event and first_difference(v, event[k]) is None for k, v in pattern.items())


def unmatched_patterns(patterns: Sequence[Mapping[str, Any]], events: Sequence[Mapping[str, Any]]) -> list[int]:
    """Indices of patterns left unmatched by a maximum one-to-one matching onto events."""
    options = [[j for j, ev in enumerate(events) if event_matches(p, ev)] for p in patterns]
    owner: dict[int, int] = {}

    def augment(i: int, seen: set[int]) -> bool:
        for j in options[i]:
            if j in seen:
                continue
            seen.add(j)
            if j not in owner or augment(owner[j], seen):
                owner[j] = i
                return True
        return False

    return [i for i in range(len(patterns)) if not augment(i, set())]


# =============================================================================================
# expectations


@dataclass(frozen=True)
class Mismatch:
    """One failed assertion: kind is state, absent, event, no_event, observation or done."""

    kind: str
    after_tick: int
    pointer: str
    expected: Any
    actual: Any
    file: str
    line: int
    message: str

    def __str__(self) -> str:
        return f"{self.file}:{self.line}: {self.message}"


def _pointer_mismatches(wanted: Mapping[str, Any], doc: Any, diagnostic: bool = True) -> list[tuple[str, Any, Any]]:
    """(pointer, expected, actual) of the first difference under each asserted pointer of ``doc``."""
    out = []
    for pointer, want in wanted.items():
        if not diagnostic and is_diagnostic(pointer):
            continue
        got = resolve_pointer(doc, pointer)
        if got is MISSING:
            diff = (pointer, want, MISSING)
        elif diagnostic:
            diff = first_difference(want, got, pointer=pointer)
        else:  # F-TRACE-STATE: differences inside diagnostic fields do not count
            diff = next((d for d in iter_differences(want, got, pointer) if not is_diagnostic(d[0])), None)
        if diff:
            out.append(diff)
    return out


# F-CONFORM-LEVELS, RES-ASSERTION-LEVEL: the part of a reply each kind of assertion reads.  A mask
# entry of an observation (`/r/mask/k`) is read from the observations, or from the masks alone.
ASSERTION_PARTS = {"state": "state", "absent": "state", "event": "events", "no_event": "events",
                   "observation": "observations", "done": "done"}


def assertion_part(kind: str, pointer: str = "") -> str:
    """The reply part an assertion reads (``masks`` for an observation's mask entries)."""
    if kind == "observation" and pointer.split("/")[2:3] == ["mask"]:
        return "masks"
    return ASSERTION_PARTS[kind]


def assertions(exp: Mapping[str, Any]) -> list[tuple[str, str]]:
    """(kind, pointer) of every assertion of one expectation block, in evaluation order."""
    out = [("state", p) for p in exp.get("state", {})]
    out += [("absent", p) for p in exp.get("absent", [])]
    out += [("event", "")] * len(exp.get("events", []))
    out += [("no_event", "")] * len(exp.get("no_events", []))
    out += [("observation", p) for p in exp.get("observations", {})]
    if "done" in exp:
        out.append(("done", ""))
    return out


def skipped_as(kind: str, pointer: str, available: Set[str], diagnostic: bool) -> str | None:
    """Why an assertion is not evaluated on a reply that carries the ``available`` parts (None: it
    is): the part it reads (F-CONFORM-LEVELS), or ``diagnostic_state`` for a diagnostic field of
    the state that the simulator does not declare (F-TRACE-STATE)."""
    part = assertion_part(kind, pointer)
    if part == "masks" and "observations" in available:
        part = "observations"  # an observation carries its mask (O-OBSERVATION)
    if part not in available:
        return part
    if part == "state" and not diagnostic and is_diagnostic(pointer):
        return "diagnostic_state"
    return None


def tally(case: Case, t_after: int, available: Set[str], diagnostic: bool = True) -> tuple[int, dict[str, int]]:
    """(assertions evaluated, assertions skipped by the part they need) after tick ``t_after``."""
    checked, skipped = 0, {}
    for exp in case.expectations_at(t_after):
        for kind, pointer in assertions(exp):
            why = skipped_as(kind, pointer, available, diagnostic)
            if why is None:
                checked += 1
            else:
                skipped[why] = skipped.get(why, 0) + 1
    return checked, skipped


def available_parts(state: Any, events: Any, observations: Any, masks: Any, done: Any) -> set[str]:
    """The parts of a reply that assertions may read: those given (None: not declared, not sent)."""
    given = {"state": state, "events": events, "observations": observations, "masks": masks, "done": done}
    return {part for part, value in given.items() if value is not None}


def mismatches(
    case: Case,
    t_after: int,
    state: Mapping[str, Any] | None,
    events: Sequence[Mapping[str, Any]] | None,
    *,
    observations: Mapping[str, Any] | None = None,
    masks: Mapping[str, Any] | None = None,
    done: bool | None = None,
    diagnostic: bool = True,
) -> list[Mismatch]:
    """Every failed assertion of ``case`` after the step applied at epoch ``t_after``.

    Only the assertions on the parts given are evaluated (:func:`skipped_as`; None: the simulator
    does not declare the part, F-CONFORM-LEVELS): state and absent-field assertions when ``state``
    is given, event assertions when ``events`` is, observation assertions when ``observations`` is
    — their mask entries also from ``masks`` alone —, ``done`` assertions when ``done`` is; state
    assertions on diagnostic fields only if ``diagnostic`` (F-TRACE-STATE).  :func:`tally` counts
    what this evaluates and skips.
    """
    out: list[Mismatch] = []
    file = _show_path(case.source, case.root)
    available = available_parts(state, events, observations, masks, done)
    if observations is None and masks is not None:  # mask entries read from the masks (O-MASK)
        observations = {r: {"mask": m} for r, m in masks.items()}

    def wanted(exp: Mapping[str, Any], key: str, kind: str) -> dict[str, Any]:
        return {p: v for p, v in exp.get(key, {}).items() if skipped_as(kind, p, available, diagnostic) is None}

    for k, exp in enumerate(case.expectations):
        if exp["after_tick"] != t_after:
            continue
        line = case.line_of(f"expectations/{exp.get('_index', k)}")
        where = reply_name(t_after, short=True)

        def add(kind: str, pointer: str, expected: Any, actual: Any, message: str) -> None:
            out.append(Mismatch(kind, t_after, pointer, expected, actual, file, line, f"{where}: {message}"))

        for at, e, a in _pointer_mismatches(wanted(exp, "state", "state"), state, diagnostic):
            add("state", at, e, a, f"state {at or '(whole state)'}: expected {show(e)}, got {show(a)}")
        for pointer in exp.get("absent", []):
            if skipped_as("absent", pointer, available, diagnostic) is not None:
                continue
            got = resolve_pointer(state, pointer)
            if got is not MISSING:
                add("absent", pointer, MISSING, got, f"state {pointer}: expected absent, got {show(got)}")
        patterns = exp.get("events", []) if events is not None else []
        for i in unmatched_patterns(patterns, events):
            near = [ev for ev in events if ev.get("type") == patterns[i].get("type")]
            add("event", "", patterns[i], near or list(events),
                f"no event matches {show(patterns[i])}; events of this type: {show(near)}")
        for pattern in exp.get("no_events", []) if events is not None else []:
            hits = [ev for ev in events if event_matches(pattern, ev)]
            if hits:
                add("no_event", "", pattern, hits, f"unexpected event {show(hits[0])} (matches {show(pattern)})")
        for at, e, a in _pointer_mismatches(wanted(exp, "observations", "observation"), observations):
            add("observation", at, e, a, f"observation {at}: expected {show(e)}, got {show(a)}")
        if done is not None and "done" in exp and bool(exp["done"]) != bool(done):
            add("done", "", exp["done"], done, f"expected done={exp['done']}, got done={done}")
    return out


def check_expectations(case: Case, t_after: int, state: Mapping[str, Any], events: Sequence[Mapping[str, Any]],
                       **options: Any) -> list[str]:
    """Messages (``file:line: after tick t: …``) for every failed assertion after tick ``t_after``
    (``options``: ``observations``, ``done`` as for :func:`mismatches`)."""
    return [str(m) for m in mismatches(case, t_after, state, events, **options)]
