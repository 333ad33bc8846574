"""Teardown of simulators on every exit path of the harness (F-PROTOCOL-TEARDOWN).

Python runs ``finally`` blocks (and so every ``Implementation.close``, which kills the simulator's
process group) for exceptions and for SIGINT (``KeyboardInterrupt``), but not for SIGTERM or SIGHUP,
whose default action ends the process at once and leaves the simulators running.
:func:`exit_on_signals` turns those signals into ``SystemExit(128 + signal)`` for the duration of a
command, so the same ``finally`` blocks run.  On SIGKILL nothing runs in the harness: the simulator
then reads end of file on its standard input, and F-PROTOCOL requires it to exit.

Teardown itself is bounded whatever the simulator does: its output is read by :func:`pump`, which
never blocks past :data:`POLL_S`, so the reader threads always stop; a process the simulator left
behind in a session of its own (out of reach of its process group) still holding its pipes is found
by the pipe it holds and killed (:func:`kill_pipe_writers`).
"""

from __future__ import annotations

import contextlib
import os
import queue
import select
import signal
import threading
from typing import Callable, Iterator

SIGNALS = tuple(s for s in (getattr(signal, "SIGTERM", None), getattr(signal, "SIGHUP", None)) if s is not None)


def _raise_exit(signum: int, frame: object) -> None:
    raise SystemExit(128 + signum)


@contextlib.contextmanager
def exit_on_signals() -> Iterator[None]:
    """SIGTERM / SIGHUP raise ``SystemExit(128 + signum)`` inside the block (main thread only)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {s: signal.signal(s, _raise_exit) for s in SIGNALS}
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)


# --------------------------------------------------------------------------- bounded reading and teardown

POLL_S = 0.1  # how often a reader looks at its stop flag: the longest a teardown waits for it


def pump(fd: int, sink: Callable[[bytes], None], stop: threading.Event, size: int = 1 << 20) -> None:
    """Read ``fd`` into ``sink`` chunk by chunk until end of file or ``stop`` (F-PROTOCOL-TEARDOWN).

    The read never blocks longer than :data:`POLL_S`, so a teardown can always end the reader — even
    while a process the simulator left behind (in a session of its own, out of reach of its process
    group) keeps the pipe open, which would block a plain blocking read, and any close of the pipe
    behind it, until that process exits."""
    poller = select.poll()
    poller.register(fd, select.POLLIN | select.POLLHUP | select.POLLERR)
    try:
        while not stop.is_set():
            if not poller.poll(POLL_S * 1000):
                continue
            chunk = os.read(fd, size)
            if not chunk:
                return
            sink(chunk)
    except (OSError, ValueError):
        return


class LineSink:
    """Chunks in, lines out on ``lines`` (bytes with their newline; the last one without), then None."""

    def __init__(self, lines: queue.Queue):
        self.lines = lines
        self.parts: list[bytes] = []  # the line being received (never joined twice: linear in its size)

    def __call__(self, chunk: bytes) -> None:
        start = 0
        while True:
            end = chunk.find(b"\n", start)
            if end < 0:
                if start < len(chunk):
                    self.parts.append(chunk[start:])
                return
            line = chunk[start:end + 1]
            if self.parts:
                self.parts.append(line)
                line, self.parts = b"".join(self.parts), []
            self.lines.put(line)
            start = end + 1

    def finish(self) -> None:
        if self.parts:
            self.lines.put(b"".join(self.parts))
            self.parts = []
        self.lines.put(None)  # end of stream


def pipe_writers(fd: int) -> list[int]:
    """The processes other than this one that hold the *write* end of the pipe whose read end is ``fd``
    (Linux ``/proc``; [] elsewhere).  They can only have it from the simulator: the harness closed its
    own copy when it started the simulator."""
    try:
        inode = os.fstat(fd).st_ino
    except OSError:
        return []
    target, me, out = f"pipe:[{inode}]", os.getpid(), []
    try:
        entries = [e.name for e in os.scandir("/proc") if e.name.isdigit() and int(e.name) != me]
    except OSError:
        return []
    for pid in entries:
        try:
            for fd_entry in os.scandir(f"/proc/{pid}/fd"):
                if os.readlink(fd_entry.path) != target:
                    continue
                with open(f"/proc/{pid}/fdinfo/{fd_entry.name}", encoding="ascii") as info:
                    flags = next((int(line.split()[1], 8) for line in info if line.startswith("flags:")), 0)
                if flags & os.O_ACCMODE != os.O_RDONLY:
                    out.append(int(pid))
                    break
        except (OSError, ValueError):
            continue
    return out


def kill_pipe_writers(*fds: int) -> list[int]:
    """SIGKILL every process left holding the write end of one of these pipes (F-PROTOCOL-TEARDOWN:
    what a simulator started in a session of its own is still part of the simulator)."""
    killed = []
    for pid in sorted({p for fd in fds for p in pipe_writers(fd)}):
        try:
            os.kill(pid, signal.SIGKILL)
            killed.append(pid)
        except OSError:
            pass
    return killed


__all__ = ["exit_on_signals", "SIGNALS", "pump", "LineSink", "pipe_writers", "kill_pipe_writers", "POLL_S"]
