"""Every process agspec starts is gone when agspec is done (F-PROCESS-TEARDOWN).

Each child is torn down with its process group where it is used (:func:`agspec.transport.process.kill_group`).
What escapes a process group — a helper double-forked into a session of its own, holding no pipe of its
parent — is caught here: the ``agspec`` command makes itself a child subreaper (Linux ``prctl``), so such
orphans are re-parented to it instead of to init, and on every exit path it kills every descendant that
was started after the command began.  Where the subreaper cannot be set (another OS), the descendants
still attached to agspec's process tree are killed all the same.
"""

from __future__ import annotations

import ctypes
import os
import signal
import sys
from pathlib import Path

PR_SET_CHILD_SUBREAPER = 36  # linux/prctl.h
CLOCK_TICKS = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100


def adopt_orphans() -> bool:
    """Make this process the subreaper of its descendants (Linux); False where that is not possible."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return libc.prctl(PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0) == 0
    except (OSError, AttributeError):
        return False


def now_ticks() -> int:
    """Clock ticks since boot (the unit of a process's start time in /proc), 0 where unknown."""
    try:
        return int(float(Path("/proc/uptime").read_text().split()[0]) * CLOCK_TICKS)
    except (OSError, ValueError, IndexError):
        return 0


def _processes() -> dict[int, tuple[int, int]]:
    """pid -> (parent pid, start time in ticks since boot), from /proc."""
    out = {}
    for entry in Path("/proc").iterdir() if Path("/proc").is_dir() else ():
        if not entry.name.isdigit():
            continue
        try:
            fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
        except (OSError, IndexError):
            continue
        out[int(entry.name)] = (int(fields[1]), int(fields[19]))  # ppid (field 4), starttime (field 22)
    return out


def descendants(root: int, since: int = 0) -> list[int]:
    """The descendants of ``root`` started at or after ``since`` (ticks since boot), parents first."""
    table = _processes()
    children: dict[int, list[int]] = {}
    for pid, (ppid, _) in table.items():
        children.setdefault(ppid, []).append(pid)
    out, todo = [], list(children.get(root, ()))
    while todo:
        pid = todo.pop(0)
        if table.get(pid, (0, 0))[1] >= since:
            out.append(pid)
        todo += children.get(pid, ())
    return out


def kill_descendants(since: int = 0) -> list[int]:
    """SIGKILL every descendant of this process started at or after ``since``; the pids signalled."""
    killed = []
    for pid in descendants(os.getpid(), since):
        try:
            os.kill(pid, signal.SIGKILL)
            killed.append(pid)
        except (ProcessLookupError, PermissionError):
            pass
    for pid in killed:  # reap the ones that are our own children (the rest are reaped by their parents)
        try:
            os.waitpid(pid, os.WNOHANG)
        except ChildProcessError:
            pass
    return killed


__all__ = ["adopt_orphans", "descendants", "kill_descendants", "now_ticks"]
