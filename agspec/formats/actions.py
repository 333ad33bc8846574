"""O-ACTION-ENCODING and F-SYMBOLIC-ACTIONS: action integers and their symbolic spelling.

An action is an integer in ``0 .. N_ACTIONS - 1``: idle, deliver, 32 pick slots, 8 handoff and 8
receive directions, 64 operation slots.  Scripts (conformance cases, shrunk counterexamples) may
spell an action symbolically; a pick or support is then resolved against the robot's option lists
*of that tick*, so that it keeps its meaning when earlier ticks change.  F-SYMBOLIC-ACTIONS: an
option that is not offered to the robot at that tick makes the script invalid (``IllegalAction``),
it never silently becomes idle.
"""

from __future__ import annotations

from typing import Any, Mapping, Sequence

from agspec.formats.values import integer

# O-ACTION-ENCODING
N_ACTIONS = 114
IDLE, DELIVER = 0, 1
PICK0, PICK_SLOTS = 2, 32
HANDOFF0, RECEIVE0 = 34, 42
OP0, OP_SLOTS = 50, 64
DIRECTION_NAMES = ("N", "NE", "E", "SE", "S", "SW", "W", "NW")
# direction index d -> (d_row, d_col): the eight radius-1 cells a handoff or receive action names
DIRECTIONS: tuple[tuple[int, int], ...] = ((-1, 0), (-1, 1), (0, 1), (1, 1), (1, 0), (1, -1), (0, -1), (-1, -1))


class IllegalAction(ValueError):
    """F-SYMBOLIC-ACTIONS: a symbolic action that cannot be resolved at this tick."""


class NotAnAction(ValueError):
    """RES-INTEGRAL-ACTIONS: a JSON value that is not an action (not an integral number)."""


def action_value(value: Any) -> int:
    """RES-INTEGRAL-ACTIONS: the action a JSON value names — an integral number (``2``, ``2.0``, ``2e0``
    are the action 2); :class:`NotAnAction` for anything else (``2.5``, ``true``, ``"2"``, null).

    The range is the reader's to judge: a simulator replaces an out-of-range action by idle
    (R-ACTION-VALIDATION), a policy's is ``bad_action`` (F-POLICY-ERRORS).  Every reader of an action
    in a message or a file calls this one function (F-VALUES)."""
    if type(value) not in (bool, int, float) and hasattr(value, "item"):  # NumPy scalars, 0-d arrays
        try:
            value = value.item()
        except (TypeError, ValueError):
            pass
    found = integer(value)
    if found is None:
        shown = repr(value) if not isinstance(value, str) else '"' + value[:30] + '"'
        raise NotAnAction(f"{shown[:40]} is not an action: an action is an integral number (RES-INTEGRAL-ACTIONS)")
    return found


def symbolic(action: int, picks: Sequence[str] = (), operations: Sequence[str] = ()) -> Any:
    """The symbolic form of an action integer, given the robot's pick and operation option ids."""
    if action == IDLE:
        return "idle"
    if action == DELIVER:
        return "deliver"
    if HANDOFF0 <= action < RECEIVE0:
        return {"handoff": DIRECTION_NAMES[action - HANDOFF0]}
    if RECEIVE0 <= action < OP0:
        return {"receive": DIRECTION_NAMES[action - RECEIVE0]}
    if PICK0 <= action < HANDOFF0 and action - PICK0 < len(picks):
        return {"pick": picks[action - PICK0]}
    if OP0 <= action < N_ACTIONS and action - OP0 < len(operations):
        return {"support": operations[action - OP0]}
    return int(action)


def resolve(action: Any, picks: Sequence[str] | None, operations: Sequence[str] | None) -> int:
    """A script action -> its integer, against the robot's pick and operation option ids this tick.

    Raises :class:`IllegalAction` for a pick or support option not offered (F-SYMBOLIC-ACTIONS) and
    for anything that is not an action.
    """
    if isinstance(action, (bool, int, float)):
        try:
            return action_value(action)
        except NotAnAction as exc:
            raise IllegalAction(str(exc)) from None
    if action == "idle":
        return IDLE
    if action == "deliver":
        return DELIVER
    if isinstance(action, Mapping) and len(action) == 1:
        ((kind, arg),) = action.items()
        if kind in ("handoff", "receive") and arg in DIRECTION_NAMES:
            return (HANDOFF0 if kind == "handoff" else RECEIVE0) + DIRECTION_NAMES.index(arg)
        if kind in ("support", "pick"):
            base, ids, what = ((OP0, list(operations or ()), f"candidate {arg!r} is not an operation option of")
                               if kind == "support" else
                               (PICK0, list(picks or ()), f"pick option {arg!r} is not offered to"))
            if arg not in ids:
                raise IllegalAction(f"{what} this robot (options: {', '.join(map(str, ids)) or 'none'})")
            return base + ids.index(arg)
    raise IllegalAction(f"{action!r} is not an action")


def option_ids(observation: Mapping[str, Any] | None) -> tuple[list[str], list[str]]:
    """(pick option ids, operation option ids) of one robot's observation (O-OBSERVATION)."""
    obs = observation or {}
    return ([p["id"] for p in obs.get("pick_options") or []], [o["id"] for o in obs.get("operation_options") or []])


def is_idle(action: Any) -> bool:
    return action == IDLE or action == "idle"


def describe(action: int) -> str:
    """An action integer in words (for diagnostics)."""
    if action == IDLE:
        return "idle"
    if action == DELIVER:
        return "deliver"
    if PICK0 <= action < HANDOFF0:
        return f"pick slot {action - PICK0}"
    if HANDOFF0 <= action < RECEIVE0:
        return f"handoff {DIRECTION_NAMES[action - HANDOFF0]}"
    if RECEIVE0 <= action < OP0:
        return f"receive {DIRECTION_NAMES[action - RECEIVE0]}"
    if OP0 <= action < N_ACTIONS:
        return f"operation slot {action - OP0}"
    return f"out-of-range action {action}"


__all__ = ["N_ACTIONS", "IDLE", "DELIVER", "PICK0", "PICK_SLOTS", "HANDOFF0", "RECEIVE0", "OP0", "OP_SLOTS",
           "DIRECTION_NAMES", "IllegalAction", "NotAnAction", "action_value", "symbolic", "resolve", "option_ids",
           "is_idle", "describe"]
