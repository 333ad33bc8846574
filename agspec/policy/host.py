"""In-process Python policies of a campaign run in a host process, timed from outside (F-POLICY-HOST).

A campaign worker (a pool process, a Ray actor, or the CLI itself with ``-j 1``) never imports a
user's policy module.  It keeps one :class:`PolicyHost` per policy target: a child interpreter
(``python -m agspec.policy.host``, in its own session and process group, its stdout sent to
stderr) that imports the module once and then runs one episode per request through the one
episode runner (:func:`agspec.policy.episode.run_here`), calling the factory once per episode
(F-POLICY-PYTHON).  The child announces each phase on its socket — loading (module import and
factory call) and each decision — and the worker waits with the phase's limit: ``load_timeout``
for loading, ``timeout`` for a decision, none while the reference simulator steps.

A phase past its limit is never interrupted inside the policy (an interrupted ``import`` leaves
``sys.modules`` half-initialised for every later episode): the worker kills the host's process
group, records the episode as ``timeout``, and the next episode starts a fresh host.  A host that
dies is recorded as ``crash`` and replaced the same way.  The child is a plain subprocess, not a
``multiprocessing`` spawn, so the caller's ``__main__`` is never run again in it.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import threading
import time
from contextlib import contextmanager
from dataclasses import replace
from multiprocessing.connection import Connection
from typing import Any, Iterator

from agspec import threads
from agspec.campaign.task import describe
from agspec.policy.contract import PolicyError
from agspec.policy.episode import DEFAULT_LOAD_TIMEOUT, job_record, run_here
from agspec.transport.process import kill_group

_PARENT_POLL = 1.0  # how often an orphaned host checks that its worker is alive


class PolicyHost:
    """One host process for one policy target (F-POLICY-HOST)."""

    def __init__(self) -> None:
        mine, theirs = socket.socketpair()
        env = threads.child_env({**os.environ, "PYTHONPATH": os.pathsep.join(p for p in sys.path if p)})  # CAMP-THREADS
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "agspec.policy.host", str(theirs.fileno()), str(os.getpid())],
            pass_fds=(theirs.fileno(),), stdin=subprocess.DEVNULL, stdout=2, env=env,
            start_new_session=True)  # its own process group: killed with whatever the policy started
        theirs.close()
        self.conn = Connection(mine.detach())

    @property
    def alive(self) -> bool:
        return self.proc.poll() is None

    def run(self, job: Any) -> dict[str, Any]:
        """The episode record of ``job``; a timeout or a dead host gives an error record (and kills the host)."""
        started = time.perf_counter()
        load_limit = job.load_timeout if job.load_timeout is not None else DEFAULT_LOAD_TIMEOUT
        try:
            self.conn.send(replace(job, timeout=None, load_timeout=None))
        except (OSError, ValueError):
            self.kill()
            return job_record(job, started, error=self._died(None))
        phase, what, tick = "load", "loading the policy", None
        while True:
            limit = load_limit if phase == "load" else (job.timeout if phase == "decide" else None)
            try:
                ready = self.conn.poll(limit)
            except (OSError, EOFError):
                ready = True
            if not ready:
                self.kill()  # RES-POLICY-TIMEOUT-REPLACES: never interrupt the policy, replace its process
                flag = "--load-timeout" if phase == "load" else "--timeout"
                return job_record(job, started, error=PolicyError(
                    "timeout", f"{what} took longer than {limit:g} s ({flag}); its host process was stopped and "
                               "the next episode starts a new one", tick=tick))
            try:
                msg = self.conn.recv()
            except (EOFError, OSError):
                self.kill()
                return job_record(job, started, error=self._died(tick))
            kind = msg[0]
            if kind == "begin":
                _, phase, what, tick = msg
            elif kind == "end":
                phase, what = "simulate", "the simulator"
            elif kind == "raised":  # agspec's own failure, not the policy's: the executor reports it
                raise RuntimeError(msg[1])
            else:  # ("record", record)
                return msg[1]

    def _died(self, tick: int | None) -> PolicyError:
        try:
            code = self.proc.wait(1.0)
        except subprocess.TimeoutExpired:
            code = None
        how = (f"was killed by signal {-code}" if code is not None and code < 0
               else f"exited with status {code}" if code is not None else "stopped answering")
        return PolicyError("crash", f"the policy's host process {how} during the episode", tick=tick)

    def kill(self) -> None:
        """Tear the host and everything it started down (its own process group)."""
        kill_group(self.proc, wait=5.0)
        self.conn.close()

    def close(self) -> None:
        if self.alive:
            try:
                self.conn.send(None)
                self.proc.wait(5.0)
            except (OSError, ValueError, subprocess.TimeoutExpired):
                pass
        self.kill()


class PolicyHosts:
    """A worker's hosts, one per policy target, replaced after a timeout or a death (F-POLICY-HOST)."""

    def __init__(self) -> None:
        self.hosts: dict[str, PolicyHost] = {}

    def run(self, job: Any) -> dict[str, Any]:
        host = self.hosts.get(job.policy.target)
        if host is None or not host.alive:
            host = self.hosts[job.policy.target] = PolicyHost()
        record = host.run(job)
        if not host.alive or (record.get("error") or {}).get("code") in ("timeout", "crash"):
            host.kill()
            del self.hosts[job.policy.target]
        return record

    def close(self) -> None:
        for host in self.hosts.values():
            host.close()
        self.hosts.clear()


# --------------------------------------------------------------------------- the host process


def _watch_parent(parent: int) -> None:
    """An orphaned host exits: its worker was killed without closing it (CAMP-CANCEL)."""
    while True:
        time.sleep(_PARENT_POLL)
        if os.getppid() != parent:
            os._exit(0)


def _host_main(conn: Connection, parent: int) -> None:
    threads.apply_inherited()  # CAMP-THREADS: the worker's budget, before a policy imports torch
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C reaches the worker, which tears the host down
    threading.Thread(target=_watch_parent, args=(parent,), daemon=True).start()

    @contextmanager
    def announce(phase: str, what: str, tick: int | None) -> Iterator[None]:
        conn.send(("begin", phase, what, tick))
        yield
        conn.send(("end",))

    try:
        while True:
            job = conn.recv()
            if job is None:
                return
            try:
                conn.send(("record", run_here(job, guard=announce)))
            except Exception as exc:
                conn.send(("raised", describe(exc)))
    except (EOFError, OSError):
        return


if __name__ == "__main__":
    _host_main(Connection(int(sys.argv[1])), int(sys.argv[2]))
