"""A simulator process speaking F-PROTOCOL on stdin/stdout (``--impl "CMD ARGS"``; no shell).

The session logic is the shared :class:`~agspec.conform.impl.base.Implementation`; the process —
starting it, reader threads, bounded waits and tearing its whole process group down on every exit
path — is :class:`agspec.transport.process.LineProcess`.  This module adds what F-PROTOCOL asks of a
simulator process: pipelined golden replay and the quiet ``stop``.
"""

from __future__ import annotations

import shlex
from typing import Any, Mapping, Sequence

from agspec.conform.impl.base import Implementation, ImplSpecError
from agspec.conform.impl.pipeline import Pipeline
from agspec.formats import protocol
from agspec.formats.protocol import ProtocolError
from agspec.transport import process as transport


class SubprocessImpl(Implementation):
    """A simulator process speaking F-PROTOCOL on stdin/stdout (no shell).

    Every request waits at most ``timeout`` seconds; on a timeout the process group is killed; on any
    failure the process is dropped and the next request restarts it.
    """

    STDERR_KEEP = transport.STDERR_KEEP
    PIPELINE = 8  # F-GOLDEN: step requests a golden replay keeps in flight
    PIPE_BYTES = transport.PIPE_BYTES

    def __init__(self, command: str | list[str], timeout: float = 5.0, *, max_restarts: int = 10,
                 cwd: str | None = None, env: Mapping[str, str] | None = None, **kw: Any):
        super().__init__(**kw)
        self.argv = shlex.split(command) if isinstance(command, str) else list(command)
        if not self.argv:
            raise ImplSpecError("empty --impl command")
        self.spec = command if isinstance(command, str) else shlex.join(command)
        self.timeout = float(timeout)
        self.start_timeout = max(self.timeout, 10.0)  # interpreter / JIT start-up is not a hang
        self.max_restarts = max_restarts  # RES-GIVE-UP-SCOPE: failed starts in a row, or failures on one instance
        self.cwd, self.env = cwd, dict(env) if env is not None else None
        self.process: transport.LineProcess | None = None

    @property
    def proc(self):
        """The simulator's process (None when it is not running)."""
        return self.process.proc if self.process is not None else None

    # ---------------------------------------------------------------- process

    def _open(self) -> None:
        self.process = transport.LineProcess(self.argv, display=self.spec, cwd=self.cwd, env=self.env)

    def stderr_tail(self, limit: int = 4000) -> str:
        return self.process.stderr_tail(limit) if self.process is not None else ""

    def _exchange(self, msg: dict[str, Any], timeout: float | None) -> Any:
        self._send(msg)
        return self._receive(msg, timeout)

    def _send(self, msg: dict[str, Any]) -> None:
        if self.process is None:
            raise ProtocolError("eof", "the simulator is not running")
        self.process.send((protocol.encode(msg) + "\n").encode("utf-8"), msg["cmd"])

    def _receive(self, msg: dict[str, Any], timeout: float | None) -> bytes:
        if self.process is None:
            raise ProtocolError("eof", "the simulator is not running")
        # bytes, decoded and checked by _finish (F-GOLDEN may match the line undecoded)
        return self.process.receive(msg["cmd"], msg["seq"], self.timeout if timeout is None else timeout)

    def pipeline(self, steps: Sequence[tuple[Mapping[str, int], tuple[str, str]]]) -> Pipeline:
        """F-GOLDEN: up to PIPELINE step requests in flight (one reply per request, in request order,
        F-PROTOCOL), so the simulator computes the next reply while the harness checks this one."""
        self._ensure()
        return Pipeline(self, steps, window=self.PIPELINE)

    def _shutdown(self) -> None:
        process, self.process = self.process, None
        if process is not None:
            process.shutdown()  # F-PROTOCOL-TEARDOWN: the whole process group goes

    def _fail(self) -> None:
        if self.process is not None and self.process.alive:
            self.process.kill()
        super()._fail()

    def close(self) -> None:
        if self._alive and self.proc is not None and self.proc.poll() is None:
            try:
                self._request_quiet_stop()
            except ProtocolError:
                pass
        self._alive = False
        self._shutdown()

    def _request_quiet_stop(self) -> None:
        msg = protocol.stop(self._next_seq())
        if self.on_message:
            self.on_message("->", "stop", msg)
        reply = self._decoded(msg, self._exchange(msg, min(self.timeout, 2.0)))
        if self.on_message:
            self.on_message("<-", "stop", reply)
        if self.validate:
            problems = protocol.validate_reply("stop", reply)
            if problems:
                raise ProtocolError("schema", f"the stop reply violates its schema: {problems[0]}")


# ============================================================================================ factory
