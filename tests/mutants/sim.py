#!/usr/bin/env python3
"""The reference interpreter as a subprocess simulator speaking F-PROTOCOL ("agspec-protocol/1").

    python tests/mutants/sim.py                      # the reference: must pass the whole suite
    python tests/mutants/sim.py --mutant dup-handoff # a seeded mutant (tests/mutants/mutant_registry.py)
    python tests/mutants/sim.py --list               # the mutants

It is written from the protocol description alone (JSON Lines on stdin/stdout, one reply per
request, ``seq`` echoed unchanged) and deliberately shares no code with ``agspec serve``: it is an
independent client of the harness, the way a simulator author's adapter would be.  A mutant is
applied inside this process before the first request by monkeypatching agspec.interp.
"""

from __future__ import annotations

import argparse
import json
import sys
import traceback
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

import mutant_registry as registry  # noqa: E402  (tests/mutants/mutant_registry.py)

PROTOCOL = "agspec-protocol/1"


def _error(seq: Any, code: str, message: str) -> dict[str, Any]:
    return {"seq": seq, "ok": False, "error": {"code": code, "message": message}}


class Server:
    def __init__(self, session: registry.Session, name: str):
        self.session = session
        self.name = name
        self.instance: dict[str, Any] | None = None

    # the full reply of reset / step: state, events, observations, masks
    def _snapshot(self, sim, events: list) -> dict[str, Any]:
        from agspec.interp.snapshot import global_state

        caps = self.session.capabilities
        out: dict[str, Any] = {"t": sim.t, "done": sim.done}
        if caps["privileged_state"]:
            out["state"] = global_state(sim.state)
        if caps["events"]:
            out["events"] = events
        if caps["observations"]:
            out["observations"] = sim.observe()
        if caps["masks"]:
            out["masks"] = sim.masks()
        return out

    def handle(self, msg: dict[str, Any]) -> dict[str, Any]:
        seq = msg.get("seq")
        cmd = msg.get("cmd")
        if cmd == "start":
            if msg.get("protocol") != PROTOCOL:
                return _error(seq, "unsupported-protocol", f"this simulator speaks {PROTOCOL}")
            from agspec import __version__

            return {"seq": seq, "ok": True, "protocol": PROTOCOL,
                    "implementation": {"name": self.name, "version": __version__, "language": "python"},
                    "capabilities": dict(self.session.capabilities)}
        if cmd == "load":
            from agspec.interp.tick import Simulator

            self.instance = msg.get("instance")
            refusal = self.session.refuse(self.instance) if self.session.refuse else None
            if refusal:  # F-PROTOCOL-UNSUPPORTED: decline, stay alive
                self.session.sim = None
                return _error(seq, "unsupported", refusal)
            try:
                self.session.sim = Simulator(self.instance)
            except Exception as exc:  # a bad instance is a request error, not a crash
                self.session.sim = None
                return _error(seq, "bad-instance", f"{type(exc).__name__}: {exc}")
            return {"seq": seq, "ok": True}
        if cmd == "reset":
            sim = self.session.sim
            if sim is None:
                return _error(seq, "no-instance", "reset before load")
            sim.reset(msg.get("execution_seed"))
            return {"seq": seq, "ok": True, **self._snapshot(sim, list(sim.reset_events))}
        if cmd == "step":
            sim = self.session.sim
            if sim is None:
                return _error(seq, "no-instance", "step before load")
            actions = msg.get("actions") or {}
            if not isinstance(actions, dict):
                return _error(seq, "bad-request", "actions must be an object robot id -> int")
            result = sim.step({str(k): int(v) for k, v in actions.items()})
            reply = {"seq": seq, "ok": True, **self._snapshot(sim, result.events)}
            if self.session.capabilities["events"]:  # without events, `applied` is not sent either
                reply["applied"] = dict(result.applied)
            return reply
        if cmd == "stop":
            return {"seq": seq, "ok": True}
        return _error(seq, "unknown-command", f"unknown cmd {cmd!r}")

    def serve(self, stdin, stdout) -> int:
        for line in stdin:
            if not line.strip():
                continue
            try:
                msg = json.loads(line)
            except json.JSONDecodeError as exc:
                self._write(stdout, _error(None, "bad-json", str(exc)))
                continue
            if not isinstance(msg, dict):
                self._write(stdout, _error(None, "bad-request", "a request is a JSON object"))
                continue
            for hook in self.session.before.get(msg.get("cmd"), []):
                hook(msg, self.session)
            try:
                reply: Any = self.handle(msg)
            except Exception as exc:
                traceback.print_exc(file=sys.stderr)
                reply = _error(msg.get("seq"), "internal", f"{type(exc).__name__}: {exc}")
            for hook in self.session.after:
                reply = hook(msg, reply) if isinstance(reply, dict) else reply
            self._write(stdout, reply)
            if msg.get("cmd") == "stop":
                return 0
        return 0

    @staticmethod
    def _write(stdout, reply: Any) -> None:
        text = reply if isinstance(reply, str) else json.dumps(reply, separators=(",", ":"), allow_nan=False)
        stdout.write(text + "\n")
        stdout.flush()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mutant", default=None, help="apply a seeded mutant (see --list)")
    parser.add_argument("--honest", default=None, help="run an honest variant (see --list)")
    parser.add_argument("--list", action="store_true", help="list the mutants and honest variants, and exit")
    args = parser.parse_args(argv)
    if args.list:
        for m in registry.MUTANTS.values():
            print(f"{m.name:24} {m.outcome:5} {m.breaks:40} {m.description}")
        for h in registry.HONEST.values():
            print(f"{h.name:24} pass  {h.level:40} {h.description}")
        return 0
    session = registry.Session()
    name = "agspec-mutant-sim"
    for label, which in (("mutant", args.mutant), ("honest", args.honest)):
        if which:
            try:
                registry.apply(which, session) if label == "mutant" else registry.apply_honest(which, session)
            except KeyError as exc:
                print(exc.args[0], file=sys.stderr)
                return 2
            name += f"+{which}"
    return Server(session, name).serve(sys.stdin, sys.stdout)


if __name__ == "__main__":
    raise SystemExit(main())
