"""The events of two replies compared as sequences (F-EVENT-DIFF).

The events of a transition are a list in R-TICK-ORDER order (F-TRACE-EVENTS).  Compared index by
index, one missing event shifts every later one, so a missing ``support`` reads as a wrong field
of the next event.  :func:`event_diff` instead aligns the two lists by each event's *identity* —
its type and the fields that say which robot, candidate, product, item or activity it concerns
(:data:`IDENTITY`) — with :class:`difflib.SequenceMatcher`, then

* pairs, inside each stretch that does not align, the events of one type about the same subject
  (the first of ``robot``, ``sender``, ``candidate``, ``product``, ``item``; else the type alone):
  such a pair is one event whose fields differ (``changed``);
* calls an expected-only event and an actual-only event with the same identity one event in
  another place (``moved``);
* leaves the rest ``missing`` (expected only) and ``extra`` (actual only).

The field differences of every paired event come from the one comparison of JSON values
(:func:`agspec.formats.pointer.iter_differences`).  The result is plain JSON: rows in a merged
order, each ``{"op", "expected_index", "actual_index", "type", ...}``, as the report carries it
(F-REPORT ``failure.events``) and the failure blocks print it.
"""

from __future__ import annotations

import json
from difflib import SequenceMatcher
from typing import Any, Mapping, Sequence

from agspec.formats.pointer import MISSING, iter_differences, show, to_json

# F-TRACE-EVENTS: the fields that say which event it is; the others (end, latency, expires_at,
# shelf_row, action, consumed, produced, holder, recipe) are its values
IDENTITY = ("type", "robot", "sender", "receiver", "candidate", "from", "to", "product", "item", "token",
            "activity", "operation", "reason", "cause", "kind")
SUBJECT = ("robot", "sender", "candidate", "product", "item")
OPS = ("same", "changed", "moved", "missing", "extra")
MAX_ROWS = 200  # rows kept in the JSON form; a reply rarely has more events
SUMMARY_FIELDS = ("robot", "sender", "receiver", "from", "to", "item", "candidate", "product", "token", "cause",
                  "reason", "operation")


def event_summary(ev: Any) -> str:
    """One event in a few words: ``support(robot=0,1, candidate=op:0:fit:0,0;0,1)``."""
    if not isinstance(ev, Mapping):
        return show(ev, 60)
    kind = ev.get("type", "?")
    parts = [f"{k}={ev[k]}" for k in SUMMARY_FIELDS if k in ev]
    return f"{kind}({', '.join(parts)})" if parts else str(kind)


def _text(value: Any) -> str:
    try:
        return json.dumps(value, sort_keys=True, separators=(",", ":"), allow_nan=False, default=str)
    except ValueError:
        return repr(value)


def identity(ev: Any) -> str:
    """The alignment key of an event: its type and identity fields (canonical JSON text)."""
    if not isinstance(ev, Mapping):
        return "?" + _text(ev)
    return _text([[k, ev[k]] for k in IDENTITY if k in ev])


def _subject(ev: Any) -> str:
    if not isinstance(ev, Mapping):
        return "?"
    who = next((k for k in SUBJECT if k in ev), None)
    return _text([ev.get("type"), who, ev.get(who) if who else None])


def _fields(e: Any, a: Any, tolerance: float | None) -> list[dict[str, Any]]:
    out = []
    for ptr, ev, av in iter_differences(e, a, "", tolerance):
        out.append({"pointer": ptr, "expected": to_json(ev), "actual": to_json(av),
                    "expected_absent": ev is MISSING, "actual_absent": av is MISSING})
    return out


def _pair_block(exp: Sequence[Any], act: Sequence[Any], i1: int, i2: int, j1: int, j2: int
                ) -> list[tuple[int | None, int | None]]:
    """A stretch that does not align: pairs of one type and subject, in order; the rest unpaired.
    Returned in merged order (each actual-only event before the first pair that follows it)."""
    free = list(range(j1, j2))
    pairs: list[tuple[int | None, int | None]] = []
    for i in range(i1, i2):
        key = _subject(exp[i])
        j = next((j for j in free if _subject(act[j]) == key), None)
        if j is not None:
            free.remove(j)
        pairs.append((i, j))
    out: list[tuple[int | None, int | None]] = []
    pending = sorted(free)
    for i, j in pairs:
        if j is not None:
            while pending and pending[0] < j:
                out.append((None, pending.pop(0)))
        out.append((i, j))
    out.extend((None, j) for j in pending)
    return out


def event_diff(expected: Sequence[Any], actual: Sequence[Any], tolerance: float | None = None) -> dict[str, Any]:
    """The aligned comparison of two event lists (see the module docstring); plain JSON."""
    ek, ak = [identity(e) for e in expected], [identity(a) for a in actual]
    matcher = SequenceMatcher(None, ek, ak, autojunk=False)
    slots: list[tuple[int | None, int | None]] = []
    for tag, i1, i2, j1, j2 in matcher.get_opcodes():
        if tag == "equal":
            slots.extend((i1 + k, j1 + k) for k in range(i2 - i1))
        else:
            slots.extend(_pair_block(expected, actual, i1, i2, j1, j2))
    # an expected-only and an actual-only event with one identity: the same event, elsewhere
    extra_at = {}
    for n, (i, j) in enumerate(slots):
        if i is None:
            extra_at.setdefault(ak[j], []).append(n)
    moved: dict[int, int] = {}  # slot of the missing event -> slot of the extra one
    for n, (i, j) in enumerate(slots):
        if j is None and extra_at.get(ek[i]):
            moved[n] = extra_at[ek[i]].pop(0)
    dropped = set(moved.values())
    rows: list[dict[str, Any]] = []
    for n, (i, j) in enumerate(slots):
        if n in dropped:
            continue
        if n in moved:
            j = slots[moved[n]][1]
        e = expected[i] if i is not None else MISSING
        a = actual[j] if j is not None else MISSING
        if i is None:
            op = "extra"
        elif j is None:
            op = "missing"
        elif n in moved:
            op = "moved"
        else:
            op = "same" if ek[i] == ak[j] else "changed"
        fields = _fields(e, a, tolerance) if i is not None and j is not None else []
        if op == "same" and fields:
            op = "changed"
        ev = e if e is not MISSING else a
        row: dict[str, Any] = {"op": op, "expected_index": i, "actual_index": j,
                               "type": ev.get("type") if isinstance(ev, Mapping) else None,
                               "expected": to_json(e), "actual": to_json(a)}
        if fields:
            row["fields"] = fields
        rows.append(row)
    counts = {op: sum(1 for r in rows if r["op"] == op) for op in OPS}
    out: dict[str, Any] = {"expected_count": len(expected), "actual_count": len(actual), "counts": counts,
                           "rows": rows[:MAX_ROWS]}
    if len(rows) > MAX_ROWS:
        out["rows_omitted"] = len(rows) - MAX_ROWS
    return out


def differing(diff: Mapping[str, Any]) -> list[dict[str, Any]]:
    """The rows that are not ``same``."""
    return [r for r in diff.get("rows", []) if r["op"] != "same"]


def describe_row(row: Mapping[str, Any]) -> str:
    """A row in words: ``missing support(robot=0,1, candidate=…)``, ``admitted(…): /end 6 -> 7``."""
    ev = row["expected"] if row["op"] != "extra" else row["actual"]
    text = event_summary(ev)
    if row["op"] == "missing":
        return f"missing {text} (expected #{row['expected_index']}, not sent)"
    if row["op"] == "extra":
        return f"extra {text} (sent as #{row['actual_index']}, not expected)"
    if row["op"] == "moved":
        return f"reordered {text} (expected #{row['expected_index']}, sent as #{row['actual_index']})"
    if row["op"] == "changed":
        f = (row.get("fields") or [{}])[0]
        return f"{text}: {f.get('pointer', '')} differs"
    return text


_MARK = {"same": "=", "changed": "~", "moved": "↕", "missing": "-", "extra": "+"}


def render_event_diff(diff: Mapping[str, Any], expected_label: str = "expected", actual_label: str = "actual",
                      indent: str = "    ", width: int = 72, keep: int = 2) -> list[str]:
    """Side-by-side lines: one row per aligned event (``-`` expected only, ``+`` actual only, ``~``
    fields differ, ``↕`` reordered), the field differences under a changed row; runs of more than
    ``2 * keep`` equal events are cut to their ends; the left column is at most ``width`` wide."""
    rows = list(diff.get("rows", []))
    bad = [k for k, r in enumerate(rows) if r["op"] != "same"]
    shown = {k for b in bad for k in range(b - keep, b + keep + 1)}
    width = min(width, max([len(expected_label)] + [len(event_summary(r["expected"])) for k, r in enumerate(rows)
                                                     if r["op"] != "extra" and (k in shown or r["op"] != "same")]))
    lines = [f"{indent}  {'#':>3} {expected_label:<{width}} {'#':>3} {actual_label}"]
    skipped = 0
    for k, r in enumerate(rows):
        if r["op"] == "same" and k not in shown:
            skipped += 1
            continue
        if skipped:
            lines.append(f"{indent}    … {skipped} equal event(s)")
            skipped = 0
        ei = "" if r["expected_index"] is None else str(r["expected_index"])
        ai = "" if r["actual_index"] is None else str(r["actual_index"])
        left = event_summary(r["expected"]) if r["op"] != "extra" else ""
        right = event_summary(r["actual"]) if r["op"] != "missing" else ""
        if len(left) > width:
            left = left[: width - 1] + "…"
        lines.append(f"{indent}{_MARK[r['op']]} {ei:>3} {left:<{width}} {ai:>3} {right}".rstrip())
        for f in r.get("fields") or []:
            e = "<absent>" if f.get("expected_absent") else show(f["expected"], 60)
            a = "<absent>" if f.get("actual_absent") else show(f["actual"], 60)
            lines.append(f"{indent}        {f['pointer']}: expected {e}, actual {a}")
    if skipped:
        lines.append(f"{indent}    … {skipped} equal event(s)")
    if diff.get("rows_omitted"):
        lines.append(f"{indent}    … {diff['rows_omitted']} more row(s) not kept")
    return lines


__all__ = ["event_diff", "event_summary", "identity", "differing", "describe_row", "render_event_diff", "IDENTITY"]
