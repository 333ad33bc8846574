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

    def begin(self, instance: Mapping[str, Any] | None, execution_seed: int | None,
              golden: tuple[str, str] | None = None) -> Any:
        """RES-STREAM-INPUT: the input is a stream of lines, so ``load`` and the ``reset`` after it go out in
        one write, on every path (live and golden): a simulator that reads a chunk and answers one line of
        it is judged alike everywhere.  After a refused load the reset's reply is read and dropped, so the
        session stays in step."""
        if instance is None:
            return self.reset(execution_seed, golden)
        self.budget.check_instance(instance, self.spec)
        if not self._alive:
            self.start()
        self._instance = None
        load = self._prepare("load", instance=instance)
        reset = self._prepare("reset", execution_seed=execution_seed)
        try:
            self.process.send(b"".join((protocol.encode(m) + "\n").encode("utf-8") for m in (load, reset)), "load")
        except ProtocolError as exc:
            raise self._failed(exc)
        try:
            self._finish(load, lambda: self._receive(load, self._limit("load")), None)
        except BaseException:
            if self._alive:  # the simulator answered the load (``ok: false``, unsupported): drop the reset's reply
                try:
                    self._finish(reset, lambda: self._receive(reset, None), None)
                except (ProtocolError, protocol.Unsupported):
                    pass
            raise
        self._instance = instance
        return self._finish(reset, lambda: self._receive(reset, None), golden)

    def _failed(self, exc: ProtocolError) -> ProtocolError:
        """A request that could not be sent ends the session (the next request restarts it)."""
        if not exc.stderr:
            exc.stderr = self.stderr_tail()
        self.budget.failed("load", exc)
        self._fail()
        return exc

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
