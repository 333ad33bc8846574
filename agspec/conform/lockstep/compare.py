"""Comparing an implementation with the reference, and reporting the first divergence.

``compare_reply`` applies the one comparison of JSON values
(:func:`agspec.formats.pointer.first_difference`) to the parts of a protocol reply in a fixed order
(:data:`COMPARED`).

A divergence is reported CommonMark-style (``render_divergence``): the reply it is in
(:func:`reply_name`, one wording everywhere), the compared part and the JSON Pointer of the first
differing field, expected vs actual, the events of that reply aligned as sequences (F-EVENT-DIFF,
:mod:`agspec.conform.lockstep.eventdiff`), the joint actions of the last ticks up to that reply with the
events of the ticks before it, and a reproducer file (instance + execution seed + the action prefix up to the diverging
tick + the implementation command) that ``agspec conform --replay FILE`` re-runs (F-REPRO).
"""

from __future__ import annotations

import json
import marshal
import re
from dataclasses import dataclass, replace
from typing import Any, Mapping, Sequence

from agspec.conform.lockstep.eventdiff import describe_row, differing, event_diff, event_summary, render_event_diff
from agspec.formats.actions import describe as describe_action
from agspec.formats.pointer import MISSING, escape, first_difference, iter_differences, show, to_json
from agspec.formats.trace import DIAGNOSTIC_FIELDS, behavioural, is_diagnostic

# The parts of a reset/step reply, in the order they are compared.
COMPARED = ("t", "state", "events", "observations", "masks", "applied", "done")


# The exact serialisation of the values as built, in their own key order (marshal format 2: no
# back-references, so equal values give equal bytes whatever object sharing).  Equal bytes prove the
# same types and values — a boolean is not a number, 1 is not 1.0 — so they prove equal JSON at C
# speed without the per-object key sort, whenever both sides build their objects in the same order
# (the reference and every server that follows it).  The one exception is NaN (equal bytes, yet NaN
# equals nothing): bytes that may hold a non-finite float go on to the canonical JSON text, which
# refuses NaN.
_MARSHAL_VERSION = 2
_NON_FINITE = re.compile(rb"g[\x00-\xff]{6}[\xf0-\xff][\x7f\xff]", re.DOTALL)  # 'g' + IEEE-754 LE, exponent all ones


def _exact(value: Any) -> bytes | None:
    try:
        data = marshal.dumps(value, _MARSHAL_VERSION)
    except (ValueError, TypeError):
        return None
    return None if _NON_FINITE.search(data) else data


def _canonical(value: Any) -> str | None:
    try:
        return json.dumps(value, sort_keys=True, separators=(",", ":"), allow_nan=False)
    except (TypeError, ValueError):
        return None


def _same_text(e: Any, a: Any) -> bool:
    """Equal exact bytes, else equal canonical JSON text: a sufficient test of JSON equality, never a
    necessary one — unequal bytes go on to the field-level :func:`iter_differences`, which alone
    decides and locates a difference."""
    data = _exact(e)
    if data is not None and data == _exact(a):
        return True
    text = _canonical(e)
    return text is not None and text == _canonical(a)


def reply_name(tick: int, short: bool = False) -> str:
    """Which reply a failure is in, in the one wording of every report (F-CONFORM): the reply to
    ``reset`` or to the ``step`` sent at epoch ``tick`` — its joint action, and the state it leads
    to (``short``: without that explanation, for lines that follow a full one)."""
    if tick < 0:
        return "in the reply to reset" + ("" if short else " (the state of epoch 0)")
    if short:
        return f"in the reply to step {tick}"
    return f"in the reply to step {tick} (the joint action of epoch {tick} \u2192 the state of epoch {tick + 1})"


@dataclass(frozen=True)
class Divergence:
    """The first difference between the expected and the actual reply (the one divergence of agspec).

    ``tick``: the epoch whose step produced the reply (-1: the reset reply) — the case format's
    ``after_tick``; ``where``: the compared part (:data:`COMPARED`) or ``"error"`` (one side failed:
    crash, timeout, protocol error — ``pointer`` is then ``kind/code`` and ``side`` the failing one);
    ``pointer``: JSON Pointer into that part (for ``state`` a pointer into the canonical global
    state, e.g. ``/robots/0,1/holding``; for ``events`` the index of the event in the expected list —
    in the actual list for an extra event — and the differing field); ``more``: further differing
    pointers of the same reply (at most 10); ``events``: the two event lists of the reply aligned as
    sequences (F-EVENT-DIFF, :func:`agspec.conform.lockstep.eventdiff.event_diff`) whenever they were
    compared and differ, whatever part differed first.
    """

    tick: int
    where: str
    pointer: str
    expected: Any
    actual: Any
    more: tuple[str, ...] = ()
    message: str = ""
    side: str = ""  # "A" or "B" for errors
    events: Mapping[str, Any] | None = None

    @property
    def path(self) -> str:
        """The pointer into the whole reply: ``/state/robots/0,1/holding``."""
        return f"/{self.where}{self.pointer}"

    def to_json(self) -> dict[str, Any]:
        out = {"tick": self.tick, "reply": reply_name(self.tick), "where": self.where, "pointer": self.pointer,
               "path": self.path, "expected": to_json(self.expected), "actual": to_json(self.actual),
               "expected_absent": self.expected is MISSING, "actual_absent": self.actual is MISSING,
               "more": list(self.more)}
        if self.message:
            out["message"] = self.message
        if self.side:
            out["side"] = self.side
        if self.events is not None:
            out["events"] = dict(self.events)
        return out

    def headline(self) -> str:
        what = self.message if self.where == "events" and self.message else (self.pointer or "(whole)")
        return f"{reply_name(self.tick)}: {self.where} {what}"

    def signature(self) -> tuple[str, str]:
        """What must stay the same while shrinking: the compared part and the pointer with every token
        holding a digit generalised (``/robots/0,1/holding`` -> ``/robots/*/holding``); for events,
        how the first differing event differs and its type (``missing support``)."""
        if self.where == "error":
            return ("error", f"{self.side}:{self.pointer}")
        if self.where == "events" and self.events is not None:
            first = next(iter(differing(self.events)), None)
            if first is not None:
                return ("events", f"{first['op']} {first['type']}")
        return (self.where, generalize(self.pointer))

    def show(self, expected_label: str = "expected", actual_label: str = "actual") -> str:
        if self.where == "error":
            return self.message
        width = max(len(expected_label), len(actual_label))
        lines = [self.headline(),
                 f"    {expected_label:<{width}} : {show(self.expected, 200)}",
                 f"    {actual_label:<{width}} : {show(self.actual, 200)}"]
        if self.events is not None:
            lines.append("    events of that reply, aligned by type (- expected only, + actual only, "
                         "~ fields differ, \u2195 reordered):")
            lines += render_event_diff(self.events, expected_label, actual_label, indent="    ")
        return "\n".join(lines)


def generalize(pointer: str) -> str:
    return "/".join("*" if any(ch.isdigit() for ch in tok) else tok for tok in pointer.split("/"))


def _events_divergence(tick: int, diff: Mapping[str, Any]) -> Divergence:
    """The divergence of a reply whose events are the first differing part: its first differing row."""
    rows = differing(diff)
    first = rows[0]
    if first["op"] == "extra":
        pointer, e, a = f"/{first['actual_index']}", MISSING, first["actual"]
    elif first["op"] == "missing":
        pointer, e, a = f"/{first['expected_index']}", first["expected"], MISSING
    elif first["op"] == "changed":
        f = first["fields"][0]
        pointer = f"/{first['expected_index']}{f['pointer']}"
        e = MISSING if f["expected_absent"] else f["expected"]
        a = MISSING if f["actual_absent"] else f["actual"]
    else:  # moved
        pointer, e, a = f"/{first['expected_index']}", first["expected"], first["actual"]
    more = tuple(f"/{r['expected_index'] if r['expected_index'] is not None else r['actual_index']}"
                 for r in rows[1:11])
    return Divergence(tick, "events", pointer, e, a, more, message=describe_row(first), events=diff)


def compare_reply(tick: int, expected: Mapping[str, Any], actual: Mapping[str, Any], parts: Sequence[str],
                  tolerance: float | None = None) -> Divergence | None:
    """The first difference over ``parts`` (in :data:`COMPARED` order); parts absent on both sides are
    skipped.  The events are compared as sequences (F-EVENT-DIFF); when they differ, the divergence
    carries their alignment whichever part differed first."""
    found: Divergence | None = None
    for part in COMPARED:
        if part not in parts:
            continue
        e, a = expected.get(part, MISSING), actual.get(part, MISSING)
        if e is MISSING and a is MISSING:
            continue
        if e is MISSING or a is MISSING:
            found = Divergence(tick, part, "", e, a)
            break
        if tolerance is None and _same_text(e, a):
            continue  # identical JSON text: the common case, decided at C speed
        if part == "events" and isinstance(e, list) and isinstance(a, list):
            diff = event_diff(e, a, tolerance)
            if differing(diff):
                found = _events_divergence(tick, diff)
                break
            continue
        diffs = iter_differences(e, a, "", tolerance)
        first = next(diffs, None)
        if first is not None:
            more = []
            for ptr, _, _ in diffs:
                more.append(ptr)
                if len(more) >= 10:
                    break
            found = Divergence(tick, part, first[0], first[1], first[2], tuple(more))
            break
    if found is None or found.events is not None or "events" not in parts:
        return found
    e, a = expected.get("events"), actual.get("events")
    if isinstance(e, list) and isinstance(a, list) and not (tolerance is None and _same_text(e, a)):
        diff = event_diff(e, a, tolerance)
        if differing(diff):  # the events of the diverging reply explain what differed first
            found = replace(found, events=diff)
    return found


# --------------------------------------------------------------------------- context of a divergence


def action_summary(actions: Mapping[str, int]) -> str:
    """A joint action in words, robots in row-major order, idle robots left out."""
    moves = {r: a for r, a in actions.items() if a != 0}
    if not moves:
        return "all idle"
    order = sorted(moves, key=lambda r: tuple(int(x) for x in r.split(",")) if re.fullmatch(r"\d+,\d+", r) else (1 << 30, 0))
    return ", ".join(f"{r} {describe_action(moves[r])} [{moves[r]}]" for r in order)


def render_context(context: Sequence[Mapping[str, Any]], tick: int, indent: str = "  ") -> list[str]:
    """The joint actions of the last ticks up to the failing step (F-REPORT ``context``), with the
    implementation's events of the ticks before it; the failing step is marked."""
    if not context:
        return []
    lines = [f"{indent}joint actions up to that reply (robots not listed idle):"]
    for entry in context:
        mark = "   \u2190 its reply is the one that failed" if entry["t"] == tick else ""
        lines.append(f"{indent}  epoch {entry['t']:<4} {action_summary(entry.get('actions', {}))}{mark}")
        events = list(entry.get("events") or [])
        if events and entry["t"] != tick:
            text = "; ".join(event_summary(e) for e in events[:6])
            if len(events) > 6:
                text += f"; \u2026 {len(events) - 6} more"
            lines.append(f"{indent}             events {text}")
    return lines


def render_divergence(title: str, ident: str, div: Divergence, context: Sequence[Mapping[str, Any]],
                      reproducer: str | None = None, impl: str | None = None, heading: str | None = None) -> str:
    """The CommonMark-style report of a divergence (plain text); ``heading``: its first line (default
    ``IDENT TITLE``)."""
    lines = [heading or f"{ident} {title}",
             f"  first divergence {div.headline()}",
             f"    pointer   {div.path}",
             f"    expected  {show(div.expected)}",
             f"    actual    {show(div.actual)}"]
    if div.more:
        lines.append(f"    also      {', '.join(div.more[:5])}" + (" \u2026" if len(div.more) > 5 else ""))
    if div.events is not None:
        lines.append("  events of that reply, aligned by type (- expected only, + actual only, ~ fields differ, "
                     "\u2195 reordered):")
        lines += render_event_diff(div.events, "expected (reference)", "actual", indent="    ")
    lines += render_context(context, div.tick)
    if reproducer:
        lines.append(f"  reproducer: {reproducer}")
        if impl:
            lines.append(f"  replay:     agspec conform --replay {reproducer} --impl {json.dumps(impl) if ' ' in impl else impl}")
    return "\n".join(lines)


__all__ = [
    "COMPARED", "MISSING", "Divergence", "first_difference", "iter_differences", "compare_reply", "render_divergence",
    "event_summary", "action_summary", "render_context", "reply_name", "show", "to_json", "escape", "generalize", "DIAGNOSTIC_FIELDS", "behavioural", "is_diagnostic",
]
