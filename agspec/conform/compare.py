"""Comparing an implementation with the reference, and reporting the first divergence.

``first_difference`` walks two JSON values in canonical order (object keys sorted, arrays by index)
and returns the first JSON Pointer (RFC 6901) where they differ; numbers compare exactly (``1`` equals
``1.0``, booleans are not numbers) unless a tolerance is given.  ``compare_reply`` applies it to the
parts of a protocol reply in a fixed order (:data:`COMPARED`).

A divergence is reported CommonMark-style (``render_divergence``): the tick, the compared part and
the JSON Pointer of the first differing field, expected vs actual, the preceding ticks' actions and
events, and a reproducer file (instance + execution seed + the action prefix up to the diverging
tick + the implementation command) that ``agspec conform --replay FILE`` re-runs (F-REPRO).
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterator, Mapping, Sequence

from agspec import __version__
from agspec.formats import limits

REPRO_FORMAT = "agspec-repro/1"
# The parts of a reset/step reply, in the order they are compared.
COMPARED = ("t", "state", "events", "observations", "masks", "applied", "done")


class _Missing:
    """A value absent on one side (rendered ``<absent>``, serialised as null + an ``*_absent`` flag)."""

    def __repr__(self) -> str:
        return "<absent>"


MISSING = _Missing()


def escape(token: str) -> str:
    """RFC 6901 escaping of one reference token."""
    return token.replace("~", "~0").replace("/", "~1")


def _same_scalar(a: Any, b: Any, tolerance: float | None) -> bool:
    if isinstance(a, bool) or isinstance(b, bool):
        return isinstance(a, bool) and isinstance(b, bool) and a == b
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        if a == b:
            return True
        if tolerance is None or math.isnan(a) or math.isnan(b):
            return False
        return abs(a - b) <= tolerance  # absolute tolerance (--float-tolerance)
    return type(a) is type(b) and a == b


def iter_differences(expected: Any, actual: Any, pointer: str = "", tolerance: float | None = None
                     ) -> Iterator[tuple[str, Any, Any]]:
    """Every differing leaf (pointer, expected, actual), depth first in canonical order."""
    if isinstance(expected, dict) and isinstance(actual, dict):
        for key in sorted(set(expected) | set(actual), key=str):
            sub = f"{pointer}/{escape(str(key))}"
            if key not in actual:
                yield (sub, expected[key], MISSING)
            elif key not in expected:
                yield (sub, MISSING, actual[key])
            else:
                yield from iter_differences(expected[key], actual[key], sub, tolerance)
        return
    if isinstance(expected, (list, tuple)) and isinstance(actual, (list, tuple)):
        for i, (e, a) in enumerate(zip(expected, actual)):
            yield from iter_differences(e, a, f"{pointer}/{i}", tolerance)
        for i in range(min(len(expected), len(actual)), max(len(expected), len(actual))):
            yield (f"{pointer}/{i}", expected[i] if i < len(expected) else MISSING,
                   actual[i] if i < len(actual) else MISSING)
        return
    if isinstance(expected, (dict, list, tuple)) or isinstance(actual, (dict, list, tuple)):
        yield (pointer, expected, actual)
        return
    if not _same_scalar(expected, actual, tolerance):
        yield (pointer, expected, actual)


def _canonical(value: Any) -> str | None:
    try:
        return json.dumps(value, sort_keys=True, separators=(",", ":"), allow_nan=False)
    except (TypeError, ValueError):
        return None


def first_difference(expected: Any, actual: Any, tolerance: float | None = None) -> tuple[str, Any, Any] | None:
    """The first (pointer, expected, actual) where ``actual`` differs from ``expected``, or None."""
    return next(iter_differences(expected, actual, "", tolerance), None)


def to_json(value: Any) -> Any:
    return None if value is MISSING else value


def show(value: Any, limit: int = 160) -> str:
    if value is MISSING:
        return "<absent>"
    text = json.dumps(value, sort_keys=True, ensure_ascii=False)
    return text if len(text) <= limit else text[: limit - 3] + "..."


@dataclass(frozen=True)
class Divergence:
    """The first difference between the reference's and the implementation's reply.

    ``tick``: the epoch whose step produced the reply (-1: the reset reply) — the case format's
    ``after_tick``; ``where``: the compared part (:data:`COMPARED`); ``pointer``: JSON Pointer into
    that part (for ``state`` a pointer into the canonical global state, e.g. ``/robots/0,1/holding``);
    ``more``: further differing pointers of the same reply (at most 10).
    """

    tick: int
    where: str
    pointer: str
    expected: Any
    actual: Any
    more: tuple[str, ...] = ()

    @property
    def path(self) -> str:
        """The pointer into the whole reply: ``/state/robots/0,1/holding``."""
        return f"/{self.where}{self.pointer}"

    def to_json(self) -> dict[str, Any]:
        return {"tick": self.tick, "where": self.where, "pointer": self.pointer, "path": self.path,
                "expected": to_json(self.expected), "actual": to_json(self.actual),
                "expected_absent": self.expected is MISSING, "actual_absent": self.actual is MISSING,
                "more": list(self.more)}

    def headline(self) -> str:
        at = "after reset" if self.tick < 0 else f"after tick {self.tick}"
        return f"{at}: {self.where} {self.pointer or '(whole)'}"


def compare_reply(tick: int, expected: Mapping[str, Any], actual: Mapping[str, Any], parts: Sequence[str],
                  tolerance: float | None = None) -> Divergence | None:
    """The first difference over ``parts`` (in :data:`COMPARED` order); parts absent on both sides are skipped."""
    for part in COMPARED:
        if part not in parts:
            continue
        e, a = expected.get(part, MISSING), actual.get(part, MISSING)
        if e is MISSING and a is MISSING:
            continue
        if e is MISSING or a is MISSING:
            return Divergence(tick, part, "", e, a)
        text = _canonical(e) if tolerance is None else None
        if text is not None and text == _canonical(a):
            continue  # identical JSON text: the common case, decided at C speed
        diffs = iter_differences(e, a, "", tolerance)
        first = next(diffs, None)
        if first is not None:
            more = []
            for ptr, _, _ in diffs:
                more.append(ptr)
                if len(more) >= 10:
                    break
            return Divergence(tick, part, first[0], first[1], first[2], tuple(more))
    return None


# --------------------------------------------------------------------------- context of a divergence


def event_summary(ev: Mapping[str, Any]) -> str:
    """One event in a few words (F-TRACE-EVENTS), for the preceding-ticks context."""
    kind = ev.get("type", "?")
    keys = ("robot", "sender", "receiver", "item", "candidate", "product", "token", "cause", "reason", "operation")
    parts = [f"{k}={ev[k]}" for k in keys if k in ev and k != "type"]
    return f"{kind}({', '.join(parts)})" if parts else str(kind)


def action_summary(actions: Mapping[str, int]) -> str:
    moves = {r: a for r, a in actions.items() if a != 0}
    if not moves:
        return "all idle"
    order = sorted(moves, key=lambda r: tuple(int(x) for x in r.split(",")) if re.fullmatch(r"\d+,\d+", r) else (1 << 30, 0))
    return " ".join(f"{r}:{moves[r]}" for r in order)


def render_divergence(title: str, ident: str, div: Divergence, context: Sequence[Mapping[str, Any]],
                      reproducer: str | None = None, impl: str | None = None) -> str:
    """The CommonMark-style report of a divergence (plain text)."""
    lines = [f"{ident} {title}",
             f"  first divergence {div.headline()}",
             f"    pointer   {div.path}",
             f"    expected  {show(div.expected)}",
             f"    actual    {show(div.actual)}"]
    if div.more:
        lines.append(f"    also      {', '.join(div.more[:5])}" + (" …" if len(div.more) > 5 else ""))
    if context:
        lines.append("  preceding ticks:")
        for entry in context:
            events = "; ".join(event_summary(e) for e in entry.get("events", [])[:6])
            if len(entry.get("events", [])) > 6:
                events += f"; … {len(entry['events']) - 6} more"
            lines.append(f"    t={entry['t']:<4} actions {action_summary(entry.get('actions', {}))}")
            if events:
                lines.append(f"           events  {events}")
    if reproducer:
        lines.append(f"  reproducer: {reproducer}")
        if impl:
            lines.append(f"  replay:     agspec conform --replay {reproducer} --impl {json.dumps(impl) if ' ' in impl else impl}")
    return "\n".join(lines)


# --------------------------------------------------------------------------- reproducers (F-REPRO)


def make_reproducer(*, ident: str, title: str, instance: Mapping[str, Any], execution_seed: int | None,
                    actions: Sequence[Mapping[str, int]], impl: str, failure: Mapping[str, Any] | None,
                    tolerance: float | None = None) -> dict[str, Any]:
    """A self-contained reproducer: re-running ``actions`` from reset reproduces the failure."""
    return {
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


def save_reproducer(directory: str | Path, data: Mapping[str, Any]) -> Path:
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    safe = re.sub(r"[^A-Za-z0-9_.-]+", "_", str(data.get("id", "case")))
    path = directory / f"{safe}.repro.json"
    path.write_text(json.dumps(data, indent=1, sort_keys=True, ensure_ascii=False) + "\n", encoding="utf-8")
    return path


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
    from agspec.ir.schemas import validate_schema

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
    return data


__all__ = [
    "COMPARED", "MISSING", "Divergence", "first_difference", "iter_differences", "compare_reply", "render_divergence",
    "event_summary", "action_summary", "make_reproducer", "save_reproducer", "load_reproducer", "ReproError",
    "REPRO_FORMAT", "show", "to_json", "escape",
]
