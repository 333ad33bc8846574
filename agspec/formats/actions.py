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
    if isinstance(action, bool):
        raise IllegalAction(f"{action!r} is not an action")
    if isinstance(action, int):
        return action
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
           "DIRECTION_NAMES", "IllegalAction", "symbolic", "resolve", "option_ids", "is_idle", "describe"]
