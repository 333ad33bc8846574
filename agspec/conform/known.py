"""Naming a conformance failure that is a known divergence of the original release (F-CONFORM-KNOWN).

spec/10-divergences.md lists where the original release departs from the paper; a simulator that
wraps or ports the original shows exactly those departures.  Each ``reply`` signature of
``conformance/divergences.yaml`` (:mod:`agspec.formats.divergences`) says what the first divergence
of an item looks like when it is that known divergence; :func:`match` checks a divergence against
every one of them, on the two replies and the parts the run compared.  A match is strict — every
difference the run saw in a part the signature describes must be explained by it — so an unrelated
failure that happens at the same tick is not named.
"""

from __future__ import annotations

from typing import Any, Mapping, Sequence

from agspec.conform.cases.expectations import event_matches, unmatched_patterns
from agspec.conform.lockstep.compare import Divergence, behavioural
from agspec.conform.lockstep.eventdiff import differing, event_diff
from agspec.formats.divergences import by_scope, expect_entry
from agspec.formats.pointer import MISSING, iter_differences, resolve

SPEC = "spec/10-divergences.md"


def _covers(patterns: Sequence[Mapping[str, Any]], events: Sequence[Mapping[str, Any]]) -> bool:
    """The events and the patterns match one to one (a pattern matches an event with its fields)."""
    return len(patterns) == len(events) and not unmatched_patterns(patterns, events)


def _events_hold(sig: Mapping[str, Any], diff: Mapping[str, Any]) -> bool:
    rows = differing(diff)
    if any(r["op"] not in ("missing", "extra") for r in rows):
        return False
    missing = [r["expected"] for r in rows if r["op"] == "missing"]
    extra = [r["actual"] for r in rows if r["op"] == "extra"]
    return _covers(sig.get("missing", []), missing) and _covers(sig.get("extra", []), extra)


def _number(value: Any) -> float | None:
    return float(value) if isinstance(value, (int, float)) and not isinstance(value, bool) else None


def _matches(pattern: str, pointer: str) -> bool:
    """``pattern`` with ``*`` standing for one token names ``pointer``."""
    want, got = pattern.split("/"), pointer.split("/")
    return len(want) == len(got) and all(w in ("*", g) for w, g in zip(want, got))


def _state_holds(sig: Mapping[str, Any], expected: Any, actual: Any) -> bool:
    for pointer, delta in (sig.get("delta") or {}).items():
        e, a = _number(resolve(expected, pointer)), _number(resolve(actual, pointer))
        if e is None or a is None or a - e != delta:
            return False
    changed, added = tuple(sig.get("changed", ())), tuple(sig.get("added", ()))
    for ptr, e, _ in iter_differences(behavioural(expected), behavioural(actual)):
        if any(ptr == c or ptr.startswith(c + "/") for c in changed):
            continue
        if e is MISSING and any(_matches(p, ptr) for p in added):
            continue
        return False
    return True


def match(div: Divergence | None, expected: Mapping[str, Any], actual: Mapping[str, Any] | None,
          parts: Sequence[str]) -> dict[str, Any] | None:
    """The known divergence ``div`` is, or None: ``{"id", "title", "summary", "spec"}``."""
    if div is None or actual is None or div.where not in ("state", "events"):
        return None
    ref_events = [e for e in expected.get("events") or [] if isinstance(e, Mapping)]
    for ident, sig in by_scope("reply").items():
        if not all(any(event_matches(p, e) for e in ref_events) for p in sig["reference_events"]):
            continue
        checked = 0
        if "events" in sig and "events" in parts:
            diff = div.events
            if diff is None:  # the events were equal (or not lists): nothing to explain there
                act = actual.get("events")
                diff = event_diff(ref_events, act if isinstance(act, list) else [])
            if not _events_hold(sig["events"], diff):
                continue
            checked += 1
        elif "events" in parts and div.events is not None:
            continue  # event differences the signature does not describe
        if "state" in sig and "state" in parts:
            if not _state_holds(sig["state"], expected.get("state"), actual.get("state")):
                continue
            checked += 1
        elif "state" in parts and div.where == "state":
            continue
        if checked:
            return {"id": ident, "title": sig["title"], "summary": " ".join(str(sig.get("summary", "")).split()),
                    "spec": SPEC}
    return None


def render(known: Mapping[str, Any], item_id: str, indent: str = "  ") -> list[str]:
    """The lines of a failure block that name the divergence and the --expect entry accepting it."""
    return [f"{indent}known divergence {known['id']} \u2014 {known['title']} ({known['spec']})",
            *([f"{indent}  {known['summary']}"] if known.get("summary") else []),
            f"{indent}  to accept it, list it in your --expect file (F-EXPECT):",
            f"{indent}    {expect_entry(item_id, known['id'])}"]


__all__ = ["match", "render", "SPEC"]
