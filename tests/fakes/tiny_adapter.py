"""A tiny in-process adapter (``--impl python:tests/fakes/tiny_adapter.py:make``), written from the
F-PROTOCOL description: ``handle(msg) -> reply`` over the reference Simulator, without agspec serve."""

from __future__ import annotations

from typing import Any


class TinyAdapter:
    def __init__(self) -> None:
        self.sim = None

    def handle(self, msg: dict[str, Any]) -> dict[str, Any]:
        from agspec.interp.snapshot import global_state
        from agspec.interp.tick import Simulator

        seq, cmd = msg["seq"], msg["cmd"]
        if cmd == "start":
            return {"seq": seq, "ok": True, "protocol": "agspec-protocol/1",
                    "implementation": {"name": "tiny", "version": "0", "language": "python"},
                    "capabilities": {"observations": False, "masks": False, "privileged_state": True, "events": True}}
        if cmd == "load":
            self.sim = Simulator(msg["instance"])
            return {"seq": seq, "ok": True}
        if cmd == "reset":
            self.sim.reset(msg["execution_seed"])
            return {"seq": seq, "ok": True, "t": 0, "state": global_state(self.sim.state),
                    "events": self.sim.reset_events}
        if cmd == "step":
            result = self.sim.step(msg["actions"])
            return {"seq": seq, "ok": True, "t": self.sim.t, "state": global_state(self.sim.state),
                    "events": result.events, "done": self.sim.done}
        return {"seq": seq, "ok": True}


def make() -> TinyAdapter:
    return TinyAdapter()
