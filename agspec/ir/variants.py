"""S-RULE-VARIANTS: the document options that change a rule, declared in one table.

Each :class:`Option` names where it lives (a scenario or a profile field), the rule it changes, its
default and the values the reference interpreter implements.  The interpreter reads an option only
through :func:`enabled` (never ``profile.get(...)`` with its own default), and the validator
rejects a value the interpreter does not implement (:func:`check`, AG423) — an option is never
silently ignored.

Adding a variant: a row here, its effect in the rule that reads :func:`enabled`, a row in the
spec's S-RULE-VARIANTS table, a conformance case (see docs/architecture.md).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

from agspec.formats.diagnostics import Issue
from agspec.formats.pointer import join


@dataclass(frozen=True)
class Option:
    document: str  # "scenario" or "profile"
    path: tuple[str, ...]  # field path inside that document
    rule: str  # the spec ID of the rule the option changes
    default: bool
    supported: tuple[bool, ...]  # the values the reference interpreter implements
    meaning: str

    @property
    def name(self) -> str:
        return self.path[-1]


OPTIONS: tuple[Option, ...] = (
    Option("scenario", ("coordination", "bilateral_handoff"), "R-HANDOFF", True, (True,),
           "a handoff needs the receiver's matching receive action; v1 defines only bilateral handoffs"),
    Option("scenario", ("coordination", "support_visible"), "O-SUPPORT-FRACTION", True, (True, False),
           "false hides the coordination cue: every support fraction is 0"),
    Option("profile", ("motion_planning",), "G-MOTION", True, (True, False),
           "false (geometry-off control): approach and retreat take no time, A = R = 0"),
    Option("profile", ("trajectory_conflicts",), "G-CONFLICT", True, (True, False),
           "false (geometry-off control): only common targets conflict, no segment test"),
)
BY_NAME: dict[str, Option] = {o.name: o for o in OPTIONS}


def _lookup(doc: Mapping[str, Any] | None, path: tuple[str, ...]) -> Any:
    cur: Any = doc
    for key in path:
        if not isinstance(cur, Mapping) or key not in cur:
            return None
        cur = cur[key]
    return cur


def enabled(name: str, document: Mapping[str, Any] | None) -> bool:
    """The value of option ``name`` in its scenario or profile ``document`` (the default when absent)."""
    option = BY_NAME[name]
    value = _lookup(document, option.path)
    return option.default if value is None else bool(value)


def check(kind: str, document: Mapping[str, Any], prefix: str = "") -> list[Issue]:
    """AG423 for every option of a ``kind`` document ("scenario" or "profile") set to a value the
    interpreter does not implement; ``prefix`` is the pointer of the document inside the IR."""
    out: list[Issue] = []
    for option in OPTIONS:
        if option.document != kind:
            continue
        value = _lookup(document, option.path)
        if isinstance(value, bool) and value not in option.supported:
            shown = ", ".join(str(v).lower() for v in option.supported)
            out.append(Issue("AG423", f"`{'.'.join(option.path)}: {str(value).lower()}` is not implemented by "
                                      f"the v1 interpreter ({option.rule}; supported: {shown})",
                             prefix + join(*option.path), hint=option.meaning))
    return out


__all__ = ["Option", "OPTIONS", "BY_NAME", "enabled", "check"]
