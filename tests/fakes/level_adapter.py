"""The reference interpreter declaring only some parts of a reply (F-PROTOCOL capabilities), in process.

    --impl python:tests/fakes/level_adapter.py:state_only       (also events_only, state_masks, …)

``Declares(parts)`` answers every request with agspec's own server and leaves out of the start
reply's capabilities, and out of every reply, what ``parts`` does not name (``state``, ``events``,
``observations``, ``masks``). An honest simulator at a lower level: it must never fail, and every
suite assertion on a part it declares must be checked (RES-ASSERTION-LEVEL).
"""

from __future__ import annotations

from typing import Any, Iterable

from agspec.conform.impl.serve import Server

CAPABILITY = {"state": "privileged_state", "events": "events", "observations": "observations", "masks": "masks"}


class Declares:
    def __init__(self, parts: Iterable[str]):
        self.parts = frozenset(parts)
        self.server = Server(observations="observations" in self.parts, masks="masks" in self.parts)

    def handle(self, msg: dict[str, Any]) -> dict[str, Any]:
        reply = self.server.handle(msg)
        if msg.get("cmd") == "start" and reply.get("ok"):
            caps = reply["capabilities"]
            for part, cap in CAPABILITY.items():
                caps[cap] = part in self.parts
            caps["diagnostic_state"] = "state" in self.parts
        for part in ("state", "events"):
            if part not in self.parts:
                reply.pop(part, None)
        return reply


def state_only() -> Declares:
    return Declares({"state"})


def events_only() -> Declares:
    return Declares({"events"})


def state_masks() -> Declares:
    return Declares({"state", "masks"})


def state_events() -> Declares:
    return Declares({"state", "events"})


class Tamper(Declares):
    """A simulator with one bug from epoch ``at`` on (``mode``), in process, named ``tamper``:

    ``mutate``          reports robot 0,0's ``switch_lock`` one higher than it is;
    ``drop_support``    leaves every ``support`` event out of its replies (the state is right);
    ``ignore_actions``  steps as if every robot idled (starts nothing it is asked to).
    """

    def __init__(self, mode: str, at: int = 0, parts: Iterable[str] = ("state", "events")):
        super().__init__(parts)
        self.mode, self.at = mode, at

    def handle(self, msg: dict[str, Any]) -> dict[str, Any]:
        sim = self.server.sim
        hit = msg.get("cmd") == "step" and sim is not None and sim.t >= self.at
        if hit and self.mode == "ignore_actions":
            msg = {**msg, "actions": {}}
        reply = super().handle(msg)
        if msg.get("cmd") == "start" and reply.get("ok"):
            reply["implementation"] = {"name": "tamper", "version": self.mode, "language": "python"}
        if hit and reply.get("ok") and self.mode == "mutate" and "state" in reply:
            reply["state"]["robots"]["0,0"]["switch_lock"] += 1
        if hit and reply.get("ok") and self.mode == "drop_support" and "events" in reply:
            reply["events"] = [e for e in reply["events"] if e.get("type") != "support"]
        return reply
