"""Evaluating a case's expectations on a reply: state pointers, absent fields, event patterns
(a maximum one-to-one matching), observations and the end flag."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping, Sequence

from agspec.conform.cases.model import Case, _show_path
from agspec.formats.pointer import MISSING, first_difference, show
from agspec.formats.pointer import resolve as resolve_pointer


def event_matches(pattern: Mapping[str, Any], event: Mapping[str, Any]) -> bool:
    """Subset match: ``event`` has every key of ``pattern`` with an equal value."""
    return all(k in event and first_difference(v, event[k]) is None for k, v in pattern.items())


def _match_events(patterns: Sequence[Mapping[str, Any]], events: Sequence[Mapping[str, Any]]) -> list[int]:
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


def _pointer_mismatches(wanted: Mapping[str, Any], doc: Any) -> list[tuple[str, Any, Any]]:
    """(pointer, expected, actual) of the first difference under each asserted pointer of ``doc``."""
    out = []
    for pointer, want in wanted.items():
        got = resolve_pointer(doc, pointer)
        diff = first_difference(want, got, pointer=pointer) if got is not MISSING else (pointer, want, MISSING)
        if diff:
            out.append(diff)
    return out


def mismatches(
    case: Case,
    t_after: int,
    state: Mapping[str, Any],
    events: Sequence[Mapping[str, Any]],
    *,
    observations: Mapping[str, Any] | None = None,
    done: bool | None = None,
) -> list[Mismatch]:
    """Every failed assertion of ``case`` after the step applied at epoch ``t_after``.

    Observation assertions are skipped when ``observations`` is None (the implementation lacks the
    capability, see ``Case.needs_observations``); ``done`` assertions when ``done`` is None.
    """
    out: list[Mismatch] = []
    file = _show_path(case.source)
    for k, exp in enumerate(case.expectations):
        if exp["after_tick"] != t_after:
            continue
        line = case.line_of(f"expectations/{exp.get('_index', k)}")
        where = f"after tick {t_after}"

        def add(kind: str, pointer: str, expected: Any, actual: Any, message: str) -> None:
            out.append(Mismatch(kind, t_after, pointer, expected, actual, file, line, f"{where}: {message}"))

        for at, e, a in _pointer_mismatches(exp.get("state", {}), state):
            add("state", at, e, a, f"state {at or '(whole state)'}: expected {show(e)}, got {show(a)}")
        for pointer in exp.get("absent", []):
            got = resolve_pointer(state, pointer)
            if got is not MISSING:
                add("absent", pointer, MISSING, got, f"state {pointer}: expected absent, got {show(got)}")
        patterns = exp.get("events", [])
        for i in _match_events(patterns, events):
            near = [ev for ev in events if ev.get("type") == patterns[i].get("type")]
            add("event", "", patterns[i], near or list(events),
                f"no event matches {show(patterns[i])}; events of this type: {show(near)}")
        for pattern in exp.get("no_events", []):
            hits = [ev for ev in events if event_matches(pattern, ev)]
            if hits:
                add("no_event", "", pattern, hits, f"unexpected event {show(hits[0])} (matches {show(pattern)})")
        if observations is not None:
            for at, e, a in _pointer_mismatches(exp.get("observations", {}), observations):
                add("observation", at, e, a, f"observation {at}: expected {show(e)}, got {show(a)}")
        if done is not None and "done" in exp and bool(exp["done"]) != bool(done):
            add("done", "", exp["done"], done, f"expected done={exp['done']}, got done={done}")
    return out


def check_expectations(case: Case, t_after: int, state: Mapping[str, Any], events: Sequence[Mapping[str, Any]],
                       **options: Any) -> list[str]:
    """Messages (``file:line: after tick t: …``) for every failed assertion after tick ``t_after``
    (``options``: ``observations``, ``done`` as for :func:`mismatches`)."""
    return [str(m) for m in mismatches(case, t_after, state, events, **options)]
