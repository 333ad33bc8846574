"""Expected-failures files (``--expect FILE``, F-EXPECT, ``schemas/expectations.schema.json``).

An implementation declares its known gaps: ``{case or episode id: {"outcome": "fail"|"error",
"reason": "…"}}`` in YAML or JSON.  Keys are content-fingerprint case ids (``c-…``), so renaming a
case never breaks the file.  Applying it (test262's lesson — skip lists rot):

* a listed case that fails with the listed outcome is ``xfail`` (not a failure);
* a listed case that passes is ``xpass`` — a failure: the gap is gone, update the file;
* a listed id that names no case or episode is a *stale* entry — a failure;
* a listed case that fails with the other class (``error`` for ``fail``) keeps its real outcome.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable, Mapping

from agspec.formats import limits
from agspec.formats.schemas import validate


class ExpectError(ValueError):
    """The expectations file cannot be used: ``exit_code`` 2 when it cannot be read, 1 when its content
    is invalid (F-EXIT-CODES)."""

    def __init__(self, message: str, exit_code: int = 1) -> None:
        super().__init__(message)
        self.exit_code = exit_code


@dataclass(frozen=True)
class Expected:
    outcome: str
    reason: str = ""

    def to_json(self) -> dict[str, Any]:
        return {"outcome": self.outcome, "reason": self.reason}


def load_expectations(path: str | Path) -> dict[str, Expected]:
    """Read an expectations file (YAML or JSON); errors are located and never tracebacks."""
    path = Path(path)
    try:  # F-LIMITS: bounded reading; YAML alias bombs, deep nesting and duplicate keys are refused
        text = limits.read_text(path)
        data = limits.parse_json(text, str(path)) if path.suffix == ".json" else limits.parse_yaml(text, str(path))
    except limits.InputError as exc:
        raise ExpectError(str(exc), exc.exit_code) from None
    if data is None:
        data = {}
    problems = validate("expectations", data)
    if problems:
        p = problems[0]
        raise ExpectError(f"{path}: {p.pointer or '/'}: {p.message}")
    return {str(k): Expected(v["outcome"], str(v.get("reason", ""))) for k, v in data.items()}


def apply(raw: str, expected: Expected | None) -> str:
    """The final outcome of a case from its raw outcome (pass/fail/error/skip) and its expectation."""
    if expected is None or raw == "skip":
        return raw
    if raw == "pass":
        return "xpass"
    if raw == expected.outcome:
        return "xfail"
    return raw


_EPISODE = re.compile(r"^e-(?P<scenario>[a-z0-9-]+?)-(?P<controller>greedy|random-\d+)$")


def is_episode_id(ident: str, scenarios: Iterable[str]) -> bool:
    """Whether ``ident`` names a catalogue episode (``e-{scenario}-greedy`` / ``e-{scenario}-random-{k}``)."""
    m = _EPISODE.match(ident)
    return bool(m) and m.group("scenario") in set(scenarios)


def stale_entries(expectations: Mapping[str, Expected], known: set[str], *, suite_loaded: bool,
                  scenarios: Iterable[str]) -> list[str]:
    """Listed ids that name nothing: not a known case id and not a catalogue episode id.

    Case ids are only judged when the suite was loaded (``--no-suite`` leaves them alone).
    """
    scenarios = list(scenarios)
    out = []
    for ident in expectations:
        if ident in known or is_episode_id(ident, scenarios):
            continue
        if ident.startswith("c-") and not suite_loaded:
            continue
        out.append(ident)
    return out


__all__ = ["Expected", "ExpectError", "load_expectations", "apply", "stale_entries", "is_episode_id"]
