#!/usr/bin/env python3
"""The reference server behind a line transport, one of whose replies is mutated (never shipped).

In process, :class:`LineSim` is a :class:`~agspec.conform.impl.SubprocessImpl` whose transport is the server: the
lines reach the harness exactly as a simulator's stdout would (blank lines, several lines per reply,
pipelined replies), so the one decoder and the reply checks see what a process sends, at in-process
speed.  As a process::

    python tests/fakes/line_sim.py --target POSITION --klass CLASS --seed S

serves the reference (``agspec serve``'s encoding) and answers every request at POSITION — ``start``,
``load``, ``reset`` or ``step:K`` (the K-th step after a reset) — with
``reply_mutations.mutate(reply, CLASS, Random(S))``.  Like a deterministic simulator, it does so each
time the position comes round, so a failure it causes reproduces.
"""

from __future__ import annotations

import argparse
import json
import queue
import random
import sys
from pathlib import Path
from typing import Any, Callable

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from agspec.conform.impl import SubprocessImpl  # noqa: E402
from agspec.formats.protocol import ProtocolError, loads  # noqa: E402
from agspec.conform.impl.serve import Server  # noqa: E402
from agspec.formats.jsonl import compact_bytes  # noqa: E402

from reply_mutations import Mutation, mutate  # noqa: E402  (tests/reply_mutations.py)

POSITIONS = ("start", "load", "reset", "step:1", "step:2", "step:3", "step:4", "step:5")


class _Positions:
    """Where a request falls: its command, and for a step how many steps since the last reset."""

    def __init__(self) -> None:
        self.steps = 0

    def of(self, msg: dict[str, Any]) -> str:
        cmd = msg.get("cmd")
        if cmd == "reset":
            self.steps = 0
        if cmd == "step":
            self.steps += 1
            return f"step:{self.steps}"
        return str(cmd)


class _ServerLines:
    """The transport of :class:`LineSim`: :class:`agspec.transport.process.LineProcess`'s interface over the
    reference server in this process, every reply line queued exactly as a process would write it."""

    def __init__(self, sim: "LineSim"):
        self.sim, self.server, self.lines = sim, Server(), queue.Queue()

    alive = True
    proc = None  # no operating-system process behind it

    def send(self, data: bytes, cmd: str) -> None:
        for request in data.splitlines():  # several requests may come in one write (RES-STREAM-INPUT)
            msg = json.loads(request)
            reply = self.server.handle(msg)
            out = compact_bytes(reply)
            if self.sim.target in (self.sim.positions.of(msg), "*") and self.sim.mutation is not None:
                self.sim.applied = self.sim.mutation(reply)
                out = self.sim.applied.data
            for line in out.split(b"\n"):
                self.lines.put(line)

    def receive(self, cmd: str, seq: int, limit: float) -> bytes:
        try:
            return self.lines.get_nowait()
        except queue.Empty:
            raise ProtocolError("timeout", f"no reply to {cmd} (seq {seq}) within {limit:g} s") from None

    def stderr_tail(self, limit: int = 4000) -> str:
        return ""

    def kill(self) -> None:
        self.server = None

    shutdown = kill


class LineSim(SubprocessImpl):
    """``mutation(reply) -> Mutation`` replaces the line of every reply at ``target`` (a position, or
    ``*``: every reply)."""

    def __init__(self, target: str | None = None, mutation: Callable[[Any], Mutation] | None = None,
                 timeout: float = 5.0, **kw: Any):
        super().__init__("line-sim", timeout, **kw)
        self.target, self.mutation = target, mutation
        self.applied: Mutation | None = None
        self.positions = _Positions()

    def _open(self) -> None:
        if self.restarts > self.max_restarts:
            raise ProtocolError("gave_up", f"gave up after {self.max_restarts} restarts of `{self.spec}`")
        self.process, self.positions = _ServerLines(self), _Positions()


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--target", required=True, choices=POSITIONS)
    ap.add_argument("--klass", required=True)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    server, positions = Server(), _Positions()
    out = sys.stdout.buffer
    for line in sys.stdin.buffer:
        if not line.strip():
            continue
        msg = loads(line)
        reply = server.handle(msg)
        hit = positions.of(msg) == args.target
        data = mutate(reply, args.klass, random.Random(args.seed)).data if hit else compact_bytes(reply)
        out.write(data + b"\n")
        out.flush()
        if server.stopped:
            return 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
