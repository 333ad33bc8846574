"""What an implementation's sessions remember across items: the requests of the current process
(F-REPRO, F-CONFORM-HISTORY) and the failures that decide when to stop sending (RES-GIVE-UP-SCOPE).

* :class:`RequestLog` — the ``load``, ``reset`` and ``step`` requests sent to the current process (or
  in-process adapter), in order; a new process starts with an empty log.  A failure that needs what
  the process did before gets these as the history of its reproducer.
* :func:`send` — a history sent again to a fresh process, before the episode that needs it.
* :class:`Budget` — giving up scoped to what failed: failed starts in a row (no item runs without a
  started simulator) and failures per instance (its fingerprint); other instances always run.
"""

from __future__ import annotations

from typing import Any, Mapping, Sequence

from agspec.formats.protocol import ProtocolError, Unsupported
from agspec.ir.fingerprint import fingerprint

LOG_CAP = 1_000_000  # requests a log keeps (beyond: the history is incomplete, not reproducible from it)


class RequestLog:
    """F-REPRO: the behavioural requests of one process's session, as ``(cmd, payload)``."""

    def __init__(self) -> None:
        self.requests: list[tuple[str, Any]] = []
        self.complete = True

    def clear(self) -> None:
        """A new process: no history."""
        self.requests, self.complete = [], True

    def record(self, cmd: str, fields: Mapping[str, Any]) -> None:
        if len(self.requests) >= LOG_CAP:
            self.complete = False
            return
        if cmd == "load":
            self.requests.append(("load", fields["instance"]))
        elif cmd == "reset":
            self.requests.append(("reset", fields.get("execution_seed")))
        elif cmd == "step":
            self.requests.append(("step", dict(fields.get("actions") or {})))

    def snapshot(self) -> tuple[tuple[str, Any], ...] | None:
        """The requests so far (None when the log overflowed)."""
        return tuple(self.requests) if self.complete else None


class Budget:
    """RES-GIVE-UP-SCOPE: when the harness stops sending, scoped to what failed (``limit`` None: never)."""

    def __init__(self, limit: int | None = None) -> None:
        self.limit = limit
        self.start_failures = 0
        self.last_start_failure = "?"
        self.by_instance: dict[str, int] = {}
        self.instance: Mapping[str, Any] | None = None  # the instance of the session

    def check_start(self, spec: str) -> None:
        if self.limit is not None and self.start_failures >= self.limit:
            raise ProtocolError("gave_up", f"gave up: `{spec}` failed to start {self.start_failures} times in a row "
                                           f"(last: {self.last_start_failure}); no item runs without a started "
                                           "simulator")

    def started(self) -> None:
        self.start_failures = 0

    def failed(self, cmd: str, exc: ProtocolError) -> None:
        """Count a failure (crash, timeout, protocol error) against its scope: the start, or the session's
        instance."""
        if cmd == "start":
            self.start_failures += 1
            self.last_start_failure = str(exc)
        elif self.instance is not None:
            fp = fingerprint(self.instance)
            self.by_instance[fp] = self.by_instance.get(fp, 0) + 1

    def check_instance(self, instance: Mapping[str, Any], spec: str) -> None:
        """An instance on which the simulator failed ``limit`` times is not sent again."""
        self.instance = instance
        if self.limit is None or not self.by_instance:
            return
        failed = self.by_instance.get(fingerprint(instance), 0)
        if failed >= self.limit:
            name = instance.get("id") if isinstance(instance.get("id"), str) else "(no id)"
            raise ProtocolError("gave_up", f"gave up on instance {name}: `{spec}` failed on it {failed} times in this "
                                           "run (the harness no longer sends it; other instances still run)")



def send(impl: Any, history: Sequence[tuple[str, Any]]) -> None:
    """F-REPRO: send a history reproducer's earlier requests, in order, before its episode; their replies
    are not compared (the original run compared them in their own items).  A refusal (``ok: false``,
    ``unsupported``) is part of that history; any other failure is the item's error."""
    for cmd, payload in history:
        try:
            if cmd == "load":
                impl.load(payload)
            elif cmd == "reset":
                impl.reset(payload)
            else:
                impl.step(payload)
        except Unsupported:
            continue
        except ProtocolError as exc:
            if exc.code != "error_reply":
                exc.message = f"while its history was sent again ({cmd}): {exc.message}"
                raise


__all__ = ["RequestLog", "Budget", "LOG_CAP", "send"]
