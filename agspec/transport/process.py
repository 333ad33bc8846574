"""A child process speaking JSON Lines on stdin/stdout, and its teardown (F-PROTOCOL, F-PROTOCOL-TEARDOWN).

:class:`LineProcess` starts a command (no shell) in a session and process group of its own, reads its
stdout into lines and keeps the tail of its stderr on reader threads that a teardown can always stop
(:func:`agspec.transport.teardown.pump`), sends a line and waits for one with a bound, and on
:meth:`~LineProcess.shutdown` or :meth:`~LineProcess.kill` takes the whole process group down, also
children that outlived their leader and processes in a session of their own that still hold its pipes.
:func:`kill_group` is the one process-group kill, used by every child agspec starts.
"""

from __future__ import annotations

import collections
import os
import queue
import signal
import subprocess
import threading
import time
from typing import Mapping, Sequence

from agspec.formats.protocol import ProtocolError
from agspec.transport import teardown

STDERR_KEEP = 65536  # bytes of the child's stderr kept for error reports
PIPE_BYTES = 1 << 20  # pipe and read-buffer size (Linux default pipe-max-size)
TEARDOWN_GRACE = 0.3  # seconds for the output to end once the process group is killed


def kill_group(proc: subprocess.Popen, wait: float = 2.0) -> None:
    """Kill the process group of ``proc`` (started with ``start_new_session``) and reap its leader.

    The group id is the leader's pid and stays reserved while any member lives, so this also reaches
    children of a leader that has already exited (F-PROTOCOL-TEARDOWN, F-POLICY-HOST).
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
        proc.wait(timeout=wait)
    except subprocess.TimeoutExpired:
        pass


class LineProcess:
    """One running child: ``send`` a line, ``receive`` the next one within a time limit.

    ``name`` says who the child is in messages ("simulator", "policy").  Raises
    :class:`~agspec.formats.protocol.ProtocolError`: ``spawn`` (cannot start), ``timeout``, ``eof``
    (stdout closed), ``exit`` (the child exited), each with the tail of its stderr.
    """

    def __init__(self, argv: Sequence[str], *, display: str, cwd: str | None = None,
                 env: Mapping[str, str] | None = None, name: str = "simulator"):
        self.display, self.name = display, name
        self.lines: queue.Queue = queue.Queue()
        self._stderr: collections.deque = collections.deque()
        self._stderr_size = 0
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self.proc: subprocess.Popen | None = None
        # Replies with every observation run to ~100 KB: a 1 MiB pipe and read buffer let the child
        # write several pipelined replies ahead instead of blocking on a 64 KiB pipe (F-GOLDEN).  Where
        # the pipe size cannot be set (another OS, a per-user limit) the default pipe serves.
        for pipes in ({"pipesize": PIPE_BYTES, "bufsize": PIPE_BYTES}, {}):
            try:
                self.proc = subprocess.Popen(list(argv), stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                             stderr=subprocess.PIPE, cwd=cwd, env=None if env is None else dict(env),
                                             start_new_session=True, **pipes)
                break
            except (OSError, ValueError) as exc:
                if not pipes:
                    raise ProtocolError("spawn", f"cannot start `{display}`: {exc}")
        proc = self.proc
        self._readers = [threading.Thread(target=self._read_stdout, args=(proc,), daemon=True),
                         threading.Thread(target=self._read_stderr, args=(proc,), daemon=True)]
        for reader in self._readers:
            reader.start()

    # ---------------------------------------------------------------- readers

    def _read_stdout(self, proc: subprocess.Popen) -> None:
        sink = teardown.LineSink(self.lines)
        teardown.pump(proc.stdout.fileno(), sink, self._stop, PIPE_BYTES)
        sink.finish()

    def _read_stderr(self, proc: subprocess.Popen) -> None:
        def keep(chunk: bytes) -> None:
            with self._lock:
                self._stderr.append(chunk)
                self._stderr_size += len(chunk)
                while self._stderr_size > STDERR_KEEP and len(self._stderr) > 1:
                    self._stderr_size -= len(self._stderr.popleft())

        teardown.pump(proc.stderr.fileno(), keep, self._stop, 65536)

    def stderr_tail(self, limit: int = 4000) -> str:
        with self._lock:
            data = b"".join(self._stderr)
        return data.decode("utf-8", "replace")[-limit:]

    # ---------------------------------------------------------------- lines

    @property
    def alive(self) -> bool:
        return self.proc is not None and self.proc.poll() is None

    def exit_error(self, what: str) -> ProtocolError:
        """Why there is no line: the child closed its stdout or exited (with its status)."""
        proc, code = self.proc, None
        if proc is not None:
            try:
                code = proc.wait(timeout=1.0)
            except subprocess.TimeoutExpired:
                code = None
        time.sleep(0.05)  # let the stderr reader drain
        if code is None or code == 0:
            return ProtocolError("eof", f"the {self.name} closed its stdout {what}"
                                        + (" (exit status 0)" if code == 0 else ""), stderr=self.stderr_tail())
        how = f"signal {-code}" if code < 0 else f"status {code}"
        return ProtocolError("exit", f"the {self.name} exited with {how} {what}", stderr=self.stderr_tail())

    def send(self, data: bytes, cmd: str) -> None:
        """Write ``data`` (one or more whole lines) to the child's stdin."""
        proc = self.proc
        if proc is None:
            raise ProtocolError("eof", f"the {self.name} is not running")
        try:
            proc.stdin.write(data)
            proc.stdin.flush()
        except (BrokenPipeError, OSError, ValueError):
            raise self.exit_error(f"before the {cmd} request could be sent")

    def receive(self, cmd: str, seq: int, limit: float) -> bytes:
        """The next line of the child's stdout, without its newline, within ``limit`` seconds
        (F-PROTOCOL-LINES: every line is a reply, a blank one too)."""
        deadline = time.monotonic() + limit
        while True:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise ProtocolError("timeout", f"no reply to {cmd} (seq {seq}) within {limit:g} s",
                                    stderr=self.stderr_tail())
            try:
                raw = self.lines.get(timeout=remaining)
            except queue.Empty:
                continue
            if raw is None:
                self.lines.put(None)
                raise self.exit_error(f"while the harness waited for the {cmd} reply")
            return raw[:-1] if raw.endswith(b"\n") else raw

    # ---------------------------------------------------------------- teardown

    def kill(self) -> None:
        """Kill the process group now (a timeout, a failure); then release the pipes."""
        if self.proc is not None:
            kill_group(self.proc)
        self.shutdown()

    def shutdown(self) -> None:
        """End of file on stdin, a short wait, then the whole process group goes (F-PROTOCOL-TEARDOWN),
        and the readers stop within :data:`teardown.POLL_S` whatever still holds the pipes."""
        proc, self.proc = self.proc, None
        if proc is None:
            return
        readers = self._readers
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
            kill_group(proc)
            # a reader still without end of file: a process in a session of its own holds the pipe
            for reader in readers:
                reader.join(TEARDOWN_GRACE)
            if any(r.is_alive() for r in readers):
                teardown.kill_pipe_writers(proc.stdout.fileno(), proc.stderr.fileno())
        finally:
            self._stop.set()
            for reader in readers:
                reader.join(2 * teardown.POLL_S + 1.0)
            for stream in (proc.stdin, proc.stdout, proc.stderr):
                if stream is proc.stdin or not any(r.is_alive() for r in readers):
                    try:
                        stream.close()
                    except (OSError, ValueError):
                        pass


__all__ = ["LineProcess", "kill_group", "PIPE_BYTES", "STDERR_KEEP", "TEARDOWN_GRACE"]
