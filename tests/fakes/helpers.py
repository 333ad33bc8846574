"""Helper processes a misbehaving child leaves behind (tests of "every process agspec starts is gone").

``leave(how, tag)`` starts one helper that ignores SIGTERM and sleeps for ten minutes, its command line
carrying ``tag`` so that a test finds it in /proc:

* ``group``    — in the caller's own process group (a plain fork);
* ``session``  — in a session of its own, still holding the caller's stdout and stderr;
* ``detached`` — double-forked into a session of its own, holding none of the caller's pipes.

Python policy modules, policy processes and simulators of tests/fakes call it on request.
"""

from __future__ import annotations

import os
import sys

HOWS = ("group", "session", "detached")
SLEEPER = "import signal, time; signal.signal(signal.SIGTERM, signal.SIG_IGN); time.sleep(600)"


def leave(how: str, tag: str) -> None:
    if how not in HOWS:
        raise ValueError(f"unknown helper kind {how!r}")
    pid = os.fork()
    if pid == 0:
        try:
            if how != "group":
                os.setsid()
            if how == "detached":
                if os.fork() != 0:
                    os._exit(0)
                devnull = os.open(os.devnull, os.O_RDWR)
                for fd in (0, 1, 2):
                    os.dup2(devnull, fd)
            os.execv(sys.executable, [sys.executable, "-c", SLEEPER, tag])
        finally:
            os._exit(0)
    if how == "detached":
        os.waitpid(pid, 0)  # the intermediate exits at once: the helper is orphaned
