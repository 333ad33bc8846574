"""A simulator process speaking F-PROTOCOL on stdin/stdout (``--impl "CMD ARGS"``; no shell).

The session logic is the shared :class:`~agspec.conform.implementation.Implementation`; this module
holds what a process adds: starting it, a reader thread per pipe, bounded waits, pipelined golden
replay, and tearing the whole process group down on every exit path (teardown).
"""

from __future__ import annotations

import collections
import os
import queue
import shlex
import signal
import subprocess
import threading
import time
from typing import Any, Mapping, Sequence

from agspec.conform import teardown
from agspec.formats import protocol
from agspec.formats.protocol import ProtocolError
from agspec.conform.implementation import Implementation, ImplSpecError
from agspec.conform.pipeline import Pipeline


class SubprocessImpl(Implementation):
    """A simulator process speaking F-PROTOCOL on stdin/stdout (no shell).

    A reader thread turns stdout into lines on a queue, so every request waits at most ``timeout``
    seconds; another thread keeps the last 64 KiB of stderr.  On a timeout the process group is
    killed; on any failure the process is dropped and the next request restarts it.
    """

    STDERR_KEEP = 65536
    PIPELINE = 8  # F-GOLDEN: step requests a golden replay keeps in flight
    PIPE_BYTES = 1 << 20  # pipe and read-buffer size (Linux default pipe-max-size)
    TEARDOWN_GRACE = 0.3  # seconds for the output to end once the process group is killed

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
        self.proc: subprocess.Popen | None = None
        self._lines: queue.Queue = queue.Queue()
        self._stderr: collections.deque = collections.deque()
        self._stderr_size = 0
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._readers: list[threading.Thread] = []

    # ---------------------------------------------------------------- process

    def _open(self) -> None:
        # Replies with every observation run to ~100 KB: a 1 MiB pipe and read buffer let the simulator
        # write several pipelined replies ahead instead of blocking on a 64 KiB pipe (F-GOLDEN).  Where
        # the pipe size cannot be set (another OS, a per-user limit) the default pipe serves.
        for pipes in ({"pipesize": self.PIPE_BYTES, "bufsize": self.PIPE_BYTES}, {}):
            try:
                self.proc = subprocess.Popen(self.argv, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                             stderr=subprocess.PIPE, cwd=self.cwd, env=self.env,
                                             start_new_session=True, **pipes)
                break
            except (OSError, ValueError) as exc:
                if not pipes:
                    raise ProtocolError("spawn", f"cannot start `{self.spec}`: {exc}")
        self._lines = queue.Queue()
        with self._lock:
            self._stderr.clear()
            self._stderr_size = 0
        # F-PROTOCOL-TEARDOWN: readers that a teardown can always stop (teardown.pump)
        self._stop = threading.Event()
        self._readers = [threading.Thread(target=self._read_stdout, args=(self.proc, self._lines, self._stop),
                                          daemon=True),
                         threading.Thread(target=self._read_stderr, args=(self.proc, self._stop), daemon=True)]
        for reader in self._readers:
            reader.start()

    def _read_stdout(self, proc: subprocess.Popen, lines: queue.Queue, stop: threading.Event) -> None:
        sink = teardown.LineSink(lines)
        teardown.pump(proc.stdout.fileno(), sink, stop, self.PIPE_BYTES)
        sink.finish()

    def _read_stderr(self, proc: subprocess.Popen, stop: threading.Event) -> None:
        def keep(chunk: bytes) -> None:
            with self._lock:
                self._stderr.append(chunk)
                self._stderr_size += len(chunk)
                while self._stderr_size > self.STDERR_KEEP and len(self._stderr) > 1:
                    self._stderr_size -= len(self._stderr.popleft())

        teardown.pump(proc.stderr.fileno(), keep, stop, 65536)

    def stderr_tail(self, limit: int = 4000) -> str:
        with self._lock:
            data = b"".join(self._stderr)
        text = data.decode("utf-8", "replace")
        return text[-limit:]

    def _exit_error(self, what: str) -> ProtocolError:
        proc = self.proc
        code = None
        if proc is not None:
            try:
                code = proc.wait(timeout=1.0)
            except subprocess.TimeoutExpired:
                code = None
        time.sleep(0.05)  # let the stderr reader drain
        if code is None or code == 0:
            return ProtocolError("eof", f"the simulator closed its stdout {what}"
                                        + (" (exit status 0)" if code == 0 else ""), stderr=self.stderr_tail())
        how = f"signal {-code}" if code < 0 else f"status {code}"
        return ProtocolError("exit", f"the simulator exited with {how} {what}", stderr=self.stderr_tail())

    def _exchange(self, msg: dict[str, Any], timeout: float | None) -> Any:
        self._send(msg)
        return self._receive(msg, timeout)

    def _send(self, msg: dict[str, Any]) -> None:
        proc = self.proc
        if proc is None:
            raise ProtocolError("eof", "the simulator is not running")
        line = protocol.encode(msg) + "\n"
        try:
            proc.stdin.write(line.encode("utf-8"))
            proc.stdin.flush()
        except (BrokenPipeError, OSError, ValueError):
            raise self._exit_error(f"before the {msg['cmd']} request could be sent")

    def _receive(self, msg: dict[str, Any], timeout: float | None) -> str:
        limit = self.timeout if timeout is None else timeout
        deadline = time.monotonic() + limit
        while True:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise ProtocolError("timeout", f"no reply to {msg['cmd']} (seq {msg['seq']}) within {limit:g} s",
                                    stderr=self.stderr_tail())
            try:
                raw = self._lines.get(timeout=remaining)
            except queue.Empty:
                continue
            if raw is None:
                self._lines.put(None)
                raise self._exit_error(f"while the harness waited for the {msg['cmd']} reply")
            # F-PROTOCOL-LINES: every line is a reply, a blank one too (refused by the decoder); bytes,
            # decoded and checked by _finish (F-GOLDEN may match it undecoded)
            return raw[:-1] if raw.endswith(b"\n") else raw

    def pipeline(self, steps: Sequence[tuple[Mapping[str, int], tuple[str, str]]]) -> Pipeline:
        """F-GOLDEN: up to PIPELINE step requests in flight (one reply per request, in request order,
        F-PROTOCOL), so the simulator computes the next reply while the harness checks this one."""
        self._ensure()
        return Pipeline(self, steps, window=self.PIPELINE)

    def _shutdown(self) -> None:
        proc, self.proc = self.proc, None
        if proc is None:
            return
        readers, stop = self._readers, self._stop
        try:
            if proc.poll() is None:
                try:
                    proc.stdin.close()
                except OSError:
                    pass
                try:
                    proc.wait(timeout=0.5)
                except subprocess.TimeoutExpired:
                    pass
            # F-PROTOCOL-TEARDOWN: the whole process group goes, also children the simulator left behind
            self._kill(proc)
            # a reader still without end of file: a process in a session of its own holds the pipe
            for reader in readers:
                reader.join(self.TEARDOWN_GRACE)
            if any(r.is_alive() for r in readers):
                teardown.kill_pipe_writers(proc.stdout.fileno(), proc.stderr.fileno())
        finally:
            stop.set()  # the readers end within teardown.POLL_S whatever holds the pipes
            for reader in readers:
                reader.join(2 * teardown.POLL_S + 1.0)
            for stream in (proc.stdin, proc.stdout, proc.stderr):
                if stream is proc.stdin or not any(r.is_alive() for r in readers):
                    try:
                        stream.close()
                    except (OSError, ValueError):
                        pass

    @staticmethod
    def _kill(proc: subprocess.Popen) -> None:
        """Kill the process group this adapter started (start_new_session) and reap its leader.

        The group id is the leader's pid and stays reserved while any member lives, so this also
        reaches children of a leader that has already exited.
        """
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError, OSError):
            if proc.poll() is None:
                try:
                    proc.kill()
                except OSError:
                    pass
        try:
            proc.wait(timeout=2.0)
        except subprocess.TimeoutExpired:
            pass

    def _fail(self) -> None:
        proc = self.proc
        if proc is not None and proc.poll() is None:
            self._kill(proc)
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
