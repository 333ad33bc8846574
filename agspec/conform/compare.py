"""Comparing an implementation with the reference, and reporting the first divergence.

``compare_reply`` applies the one comparison of JSON values
(:func:`agspec.formats.pointer.first_difference`) to the parts of a protocol reply in a fixed order
(:data:`COMPARED`).

A divergence is reported CommonMark-style (``render_divergence``): the reply it is in
(:func:`reply_name`, one wording everywhere), the compared part and the JSON Pointer of the first
differing field, expected vs actual, the events of that reply aligned as sequences (F-EVENT-DIFF,
:mod:`agspec.conform.eventdiff`), the joint actions of the last ticks up to that reply with the
events of the ticks before it, and a reproducer file (instance + execution seed + the action prefix up to the diverging
tick + the implementation command) that ``agspec conform --replay FILE`` re-runs (F-REPRO).
"""

from __future__ import annotations

import json
import marshal
import re
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Mapping, Sequence

from agspec import __version__
from agspec.conform.eventdiff import describe_row, differing, event_diff, event_summary, render_event_diff
from agspec.formats import limits
from agspec.formats import output
from agspec.formats.actions import describe as describe_action
from agspec.formats.pointer import MISSING, escape, first_difference, iter_differences, show, to_json
from agspec.formats.schemas import self_check
from agspec.ir.schemas import validate_schema

REPRO_FORMAT = "agspec-repro/1"
# The parts of a reset/step reply, in the order they are compared.
COMPARED = ("t", "state", "events", "observations", "masks", "applied", "done")


# F-TRACE-STATE: the diagnostic fields of the canonical state — bookkeeping no observer sees, compared
# only when the implementation declares the `diagnostic_state` capability; every other field is behavioural.
DIAGNOSTIC_FIELDS: dict[str, frozenset[str]] = {
    "robots": frozenset({"busy_until", "switch_lock", "ee", "q"}),
    "activities": frozenset({"approach", "process", "retreat"}),
}


def behavioural(state: Any) -> Any:
    """``state`` without its diagnostic fields (a shallow copy; the input is not modified)."""
    if not isinstance(state, dict):
        return state
    out = dict(state)
    robots, acts = state.get("robots"), state.get("activities")
    if isinstance(robots, dict):
        drop = DIAGNOSTIC_FIELDS["robots"]
        out["robots"] = {k: {f: v for f, v in r.items() if f not in drop} if isinstance(r, dict) else r
                         for k, r in robots.items()}
    if isinstance(acts, list):
        drop = DIAGNOSTIC_FIELDS["activities"]
        out["activities"] = [{f: v for f, v in a.items() if f not in drop} if isinstance(a, dict) else a for a in acts]
    return out


def is_diagnostic(pointer: str) -> bool:
    """Whether a JSON Pointer into the state names a diagnostic field (or a part of one)."""
    tokens = pointer.split("/")[1:]
    return len(tokens) >= 3 and tokens[2] in DIAGNOSTIC_FIELDS.get(tokens[0], frozenset())


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
    sequences (F-EVENT-DIFF, :func:`agspec.conform.eventdiff.event_diff`) whenever they were
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
                      reproducer: str | None = None, impl: str | None = None) -> str:
    """The CommonMark-style report of a divergence (plain text)."""
    lines = [f"{ident} {title}",
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


# --------------------------------------------------------------------------- reproducers (F-REPRO)


def make_reproducer(*, ident: str, title: str, instance: Mapping[str, Any], execution_seed: int | None,
                    actions: Sequence[Mapping[str, int]], impl: str, failure: Mapping[str, Any] | None,
                    tolerance: float | None = None, expectations: Sequence[Mapping[str, Any]] = (),
                    history: Sequence[tuple[str, Any]] = ()) -> dict[str, Any]:
    """A self-contained reproducer: re-running ``actions`` from reset reproduces the failure — after the
    ``history`` requests (F-REPRO: a failure that depends on what the process did before), with the
    case's ``expectations`` checked."""
    data = {
        "format": REPRO_FORMAT,
        "agspec_version": __version__,
        "id": ident,
        "title": title,
        "impl": impl,
        "instance": dict(instance),
        "execution_seed": execution_seed,
        "actions": [dict(a) for a in actions],
        "failure": dict(failure) if failure else None,
        "options": {"tolerance": tolerance},
    }
    if expectations:
        data["expectations"] = [dict(e) for e in expectations]
    if history:
        data["history"] = history_record(history)
    return data


def history_record(requests: Sequence[tuple[str, Any]]) -> dict[str, Any]:
    """F-REPRO ``history``: the requests, each instance written once (``instances``, referenced by index)."""
    instances: list[Mapping[str, Any]] = []
    index: dict[int, int] = {}  # id() of an instance dict -> its index (the same object is one instance)
    out: list[dict[str, Any]] = []
    for cmd, payload in requests:
        if cmd == "load":
            if id(payload) not in index:
                index[id(payload)] = len(instances)
                instances.append(payload)
            out.append({"cmd": "load", "instance": index[id(payload)]})
        elif cmd == "reset":
            out.append({"cmd": "reset", "execution_seed": payload})
        else:
            out.append({"cmd": "step", "actions": dict(payload)})
    return {"instances": [dict(i) for i in instances], "requests": out}


def save_reproducer(directory: str | Path, data: Mapping[str, Any]) -> Path:
    directory = output.make_dir(directory)  # F-OUTPUT-FAILURES: written whole or not at all
    self_check("repro", data)  # F-SCHEMAS-SELF
    safe = re.sub(r"[^A-Za-z0-9_.-]+", "_", str(data.get("id", "case")))
    return output.write_text(directory / f"{safe}.repro.json",
                             json.dumps(data, indent=1, sort_keys=True, ensure_ascii=False, allow_nan=False) + "\n")


class ReproError(ValueError):
    """A reproducer file cannot be used: ``exit_code`` 2 when it cannot be read, 1 when its content is
    invalid (F-EXIT-CODES)."""

    def __init__(self, message: str, exit_code: int = 1) -> None:
        super().__init__(message)
        self.exit_code = exit_code


def load_reproducer(path: str | Path) -> dict[str, Any]:
    """Read and check a reproducer file (F-REPRO); errors name the file and the offending field."""
    path = Path(path)
    try:  # F-LIMITS: bounded, located reading
        data = limits.load_json(path)
    except limits.InputError as exc:
        raise ReproError(str(exc), exc.exit_code) from None
    if not isinstance(data, dict) or data.get("format") != REPRO_FORMAT:
        raise ReproError(f"{path}: not a reproducer (expected \"format\": \"{REPRO_FORMAT}\")")
    inst = data.get("instance")
    if not isinstance(inst, dict) or inst.get("kind") != "instance":
        raise ReproError(f"{path}: /instance must be an instance IR")

    problems = [i for i in validate_schema(inst) if i.severity == "error"]
    if problems:
        raise ReproError(f"{path}: /instance{problems[0].pointer}: {problems[0].message} [{problems[0].code}]")
    actions = data.get("actions")
    if not isinstance(actions, list) or not all(
        isinstance(a, dict) and all(isinstance(k, str) and isinstance(v, int) and not isinstance(v, bool)
                                    for k, v in a.items()) for a in actions):
        raise ReproError(f"{path}: /actions must be a list of joint actions {{robot id: integer}}")
    seed = data.get("execution_seed")
    if seed is not None and (not isinstance(seed, int) or isinstance(seed, bool)):
        raise ReproError(f"{path}: /execution_seed must be an integer or null")
    exps = data.get("expectations", [])
    if not isinstance(exps, list) or not all(isinstance(e, dict) and isinstance(e.get("after_tick"), int)
                                             for e in exps):
        raise ReproError(f"{path}: /expectations must be a list of case expectations with `after_tick`")
    _check_history(path, data.get("history"))
    return data


def _check_history(path: Path, history: Any) -> None:
    """F-REPRO ``history``: ``{"instances": [instance IR...], "requests": [{"cmd": load|reset|step, ...}]}``."""
    if history is None:
        return
    if not isinstance(history, dict) or not isinstance(history.get("instances"), list) \
            or not isinstance(history.get("requests"), list):
        raise ReproError(f"{path}: /history must be {{\"instances\": [...], \"requests\": [...]}}")
    for k, inst in enumerate(history["instances"]):
        if not isinstance(inst, dict) or inst.get("kind") != "instance":
            raise ReproError(f"{path}: /history/instances/{k} must be an instance IR")
        problems = [i for i in validate_schema(inst) if i.severity == "error"]
        if problems:
            raise ReproError(f"{path}: /history/instances/{k}{problems[0].pointer}: {problems[0].message} "
                             f"[{problems[0].code}]")
    n = len(history["instances"])
    for k, req in enumerate(history["requests"]):
        cmd = req.get("cmd") if isinstance(req, dict) else None
        ok = (cmd == "load" and isinstance(req.get("instance"), int) and not isinstance(req.get("instance"), bool)
              and 0 <= req["instance"] < n) \
            or (cmd == "reset" and (req.get("execution_seed") is None
                                    or (isinstance(req.get("execution_seed"), int)
                                        and not isinstance(req.get("execution_seed"), bool)))) \
            or (cmd == "step" and isinstance(req.get("actions"), dict)
                and all(isinstance(v, int) and not isinstance(v, bool) for v in req["actions"].values()))
        if not ok:
            raise ReproError(f"{path}: /history/requests/{k} must be a load (instance index), reset or step request")


__all__ = [
    "COMPARED", "MISSING", "Divergence", "first_difference", "iter_differences", "compare_reply", "render_divergence",
    "event_summary", "action_summary", "render_context", "reply_name", "make_reproducer", "save_reproducer", "load_reproducer", "ReproError",
    "history_record",
    "REPRO_FORMAT", "show", "to_json", "escape", "generalize", "DIAGNOSTIC_FIELDS", "behavioural", "is_diagnostic",
]
