"""The seam of a campaign's executor (spec chapter 14, CAMP-EXECUTOR): its plain data and the backend protocol.

The dispatcher (:mod:`agspec.campaign.executor`) and every backend (the local ones there, Ray in
:mod:`agspec.campaign.ray_backend`) import these types from here, so the backends depend on the seam and
never on the dispatcher that chooses them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Protocol

EXECUTORS = ("local", "ray")
DEFAULT_RETRIES = 2


@dataclass(frozen=True)
class ExecutorSpec:
    """How a campaign runs (CAMP-EXECUTOR): ``kind`` local or ray; ``jobs`` workers (None: 1 locally,
    every CPU of the Ray cluster); ``address`` of a Ray cluster (None: a local Ray started for the
    run; ``auto``; ``ray://host:port``); ``retries`` per item whose worker dies; ``dispatch_seed``
    shuffles the dispatch order (the results are identical, CAMP-ORDER); ``runtime_env`` for Ray;
    ``gpus`` per Ray worker (CAMP-GPU)."""

    kind: str = "local"
    jobs: int | None = None
    address: str | None = None
    retries: int = DEFAULT_RETRIES
    dispatch_seed: int | None = None
    runtime_env: dict[str, Any] | None = None
    gpus: float = 0.0  # with Ray: GPUs each worker holds (a fraction shares one); local workers ignore it


@dataclass(frozen=True)
class Task:
    """The unit of work: ``fn(context, item)`` where ``context`` is ``init(shared)`` (or ``shared``),
    made once per worker.  ``shared`` is shipped once per run (CAMP-SHIP-ONCE); ``fn`` and ``init``
    are module-level functions (they travel by reference); ``close(context)`` runs when a worker
    stops (e.g. it stops the worker's simulator process)."""

    fn: Callable[[Any, Any], Any]
    shared: Any = None
    init: Callable[[Any], Any] | None = None
    close: Callable[[Any], None] | None = None

    def context(self) -> Any:
        return self.init(self.shared) if self.init is not None else self.shared


@dataclass(frozen=True)
class Done:
    value: Any


@dataclass(frozen=True)
class Failed:
    """An item that produced no result: ``cause`` says why, ``attempts`` how often it was dispatched,
    ``worker_died`` whether the worker died (else the task raised)."""

    cause: str
    attempts: int
    worker_died: bool

    def message(self) -> str:
        if self.worker_died:
            return f"the worker died {self.attempts} time(s) running it: {self.cause}"
        return f"it raised {self.cause}"


Outcome = Done | Failed


class RunFatal(Exception):
    """An exception that ends the whole run instead of failing its item (CAMP-FAULTS): the run cannot go on
    whichever item comes next (e.g. a result that cannot be written, F-OUTPUT-FAILURES).  It is raised
    again in the driver, also from a pool worker, so it must pickle (a subclass with its own ``__init__``
    defines ``__reduce__``)."""


class ExecutorError(Exception):
    """The executor could not start (Ray missing or unreachable): a usage/I-O problem of the run."""


@dataclass(frozen=True)
class Event:
    """What a backend reports about one dispatched item: ``kind`` is ``ok``, ``raised`` or ``died``;
    ``proven`` is False when a death cannot be blamed on this item alone (the local pool breaks for
    every item in flight), so the driver re-runs it alone before counting the attempt."""

    index: int
    kind: str
    payload: Any
    proven: bool = True


class Backend(Protocol):
    def free(self) -> int: ...

    def busy(self) -> int: ...

    def submit(self, index: int, item: Any) -> None: ...

    def wait(self) -> list[Event]: ...

    def close(self, cancel: bool) -> None: ...


def describe(exc: BaseException) -> str:
    """One line naming an exception (the cause reported for a failed item)."""
    text = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {text[0]}" if text else type(exc).__name__
