"""F-TRACE-EMISSION as data: which step of R-TICK-ORDER emits which events, and in which order.

The spec's table (spec/09-formats.md, F-TRACE-EMISSION) and :data:`EMISSION` are the same table;
tests/test_trace_pairing.py parses the one and compares it with the other, and the pairing check
(:mod:`agspec.trace.pairing`) holds every trace to it.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Step:
    """One emitting step of a transition.

    ``step``: the R-TICK-ORDER step number; ``rules``: the rules that emit; ``events``: the event types
    it emits (``blocked:KIND`` for a ``blocked`` event of that ``kind``), in the order one attempt emits
    them; ``order``: how the attempts of the step are ordered — ``robot`` (row-major robot id of the
    event's ``robot``), ``sender`` (row-major ``sender``), ``candidate`` (ascending candidate id string,
    RES-CANDIDATE-ORDER-STRING), ``creation`` (the completing activities' creation order) or ``once``
    (at most one event).
    """

    step: int
    rules: tuple[str, ...]
    events: tuple[str, ...]
    order: str

    def emits(self, key: str) -> bool:
        return key in self.events


# F-TRACE-EMISSION, in tick order. Step 0 is the reset (the header's events).
RESET = Step(0, ("R-RELEASE",), ("release", "release_lost"), "once")
EMISSION: tuple[Step, ...] = (
    Step(2, ("R-ACTION-VALIDATION",), ("action_coerced",), "robot"),
    Step(3, ("R-PICK", "R-BLOCKING"), ("pick_started", "blocked:pick"), "robot"),
    Step(4, ("R-HANDOFF", "R-BLOCKING"), ("handoff_started", "blocked:handoff"), "sender"),
    Step(5, ("R-SUPPORT", "R-SUPPORT-LIFECYCLE"), ("support_switched", "proposal_created", "support"), "robot"),
    Step(5, ("R-ADMISSION", "R-BLOCKING"), ("admitted", "blocked:operation"), "candidate"),
    Step(5, ("R-EXPIRY",), ("admission_failed", "proposal_abandoned"), "candidate"),
    Step(6, ("R-DELIVERY", "R-BLOCKING"), ("delivery_started", "blocked:deliver"), "robot"),
    Step(9, ("R-COMPLETION",), ("pick_completed", "handoff_completed", "operation_completed", "delivered"),
         "creation"),
    Step(12, ("R-RELEASE",), ("release", "release_lost"), "once"),
    Step(13, ("R-EXPIRY",), ("admission_failed", "proposal_abandoned"), "candidate"),
)
# indices into EMISSION the pairing check names
SUPPORT, ADMISSION, IN_EPOCH_EXPIRY, COMPLETION, RELEASE, POST_ADVANCE_EXPIRY = 3, 4, 5, 7, 8, 9


def event_key(event: dict) -> str:
    """The key of an event in :data:`EMISSION`: its type, or ``blocked:KIND``."""
    kind = event.get("type")
    return f"blocked:{event.get('kind')}" if kind == "blocked" else str(kind)


__all__ = ["Step", "EMISSION", "RESET", "event_key", "SUPPORT", "ADMISSION", "IN_EPOCH_EXPIRY", "COMPLETION",
           "RELEASE", "POST_ADVANCE_EXPIRY"]
