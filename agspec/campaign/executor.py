"""The executor seam of a campaign (spec chapter 14): items in, results out in item order.

A campaign is a list of independent items (an episode, a conformance case, a trace) and one
:class:`Task` that turns an item into a result.  :func:`run_ordered` dispatches the items to a
backend — the in-process loop (``local``, ``jobs`` 1), a process pool (``local``, ``jobs`` > 1) or
Ray actors (``ray``, :mod:`agspec.campaign.ray_backend`) — and yields ``(index, outcome)`` strictly
in item order whatever order the workers finish in (CAMP-ORDER), so reports written from the
yielded outcomes are byte-identical across executors (CAMP-IDENTICAL).  An item whose worker dies is
re-dispatched at most ``retries`` times and then yielded as a :class:`Failed` outcome naming the
cause (CAMP-RETRY); an exception raised by the task itself is deterministic and is not retried
(CAMP-FAULTS).  Leaving the generator early (``break``, an error, Ctrl-C) cancels the pending work
and tears the workers down (CAMP-CANCEL).
"""

from __future__ import annotations

import random
from collections import deque
from concurrent.futures import FIRST_COMPLETED, BrokenExecutor, Future, ProcessPoolExecutor, wait
from multiprocessing.util import Finalize
from typing import Any, Callable, Iterator, Sequence

from agspec.campaign.task import DEFAULT_RETRIES, EXECUTORS, Backend, Done, Event, ExecutorError, ExecutorSpec, Failed
from agspec.campaign.task import Outcome, RunFatal, Task, describe

# --------------------------------------------------------------------------- local backends


class InlineBackend:
    """``local`` with one worker: the items run in this process, in order (no pickling at all)."""

    def __init__(self, task: Task):
        self.task = task
        self.context = task.context()
        self.done: list[Event] = []

    def free(self) -> int:
        return 0 if self.done else 1

    def busy(self) -> int:
        return len(self.done)

    def submit(self, index: int, item: Any) -> None:
        try:
            self.done.append(Event(index, "ok", self.task.fn(self.context, item)))
        except RunFatal:  # a result that cannot be written (F-OUTPUT-FAILURES) ends the run, not the item
            raise
        except Exception as exc:  # the task's own failure: deterministic, reported, never retried
            self.done.append(Event(index, "raised", describe(exc)))

    def wait(self) -> list[Event]:
        out, self.done = self.done, []
        return out

    def close(self, cancel: bool) -> None:
        if self.task.close is not None:
            self.task.close(self.context)


_CONTEXT: dict[str, Any] = {}  # per pool worker process: its task and context (never shared)


def _init_pool_worker(task: Task) -> None:
    try:
        context = task.context()
    except Exception as exc:  # deterministic: every item of this worker reports it, none is retried
        _CONTEXT.update(task=task, setup_error=f"worker setup failed: {describe(exc)}")
        return
    _CONTEXT.update(task=task, context=context)
    if task.close is not None:  # runs when the worker exits normally, also after a cancelled run
        Finalize(None, task.close, args=(context,), exitpriority=10)


def _run_in_pool_worker(item: Any) -> tuple[str, Any]:
    if "setup_error" in _CONTEXT:
        return "raised", _CONTEXT["setup_error"]
    try:
        return "ok", _CONTEXT["task"].fn(_CONTEXT["context"], item)
    except RunFatal as exc:  # raised again in the driver (F-OUTPUT-FAILURES)
        return "fatal", exc
    except Exception as exc:
        return "raised", describe(exc)


class PoolBackend:
    """``local`` with ``jobs`` > 1: a process pool; at most ``jobs`` items in flight so that a death
    can be pinned on the items that were running; a broken pool is replaced."""

    def __init__(self, task: Task, jobs: int):
        self.task, self.jobs = task, jobs
        self.pool = self._new_pool()
        self.inflight: dict[Future, int] = {}

    def _new_pool(self) -> ProcessPoolExecutor:
        return ProcessPoolExecutor(max_workers=self.jobs, initializer=_init_pool_worker, initargs=(self.task,))

    def free(self) -> int:
        return self.jobs - len(self.inflight)

    def busy(self) -> int:
        return len(self.inflight)

    def submit(self, index: int, item: Any) -> None:
        try:
            future = self.pool.submit(_run_in_pool_worker, item)
        except BrokenExecutor:  # broke since the last wait (a worker died idle): the next wait replaces it
            future = Future()
            future.set_exception(BrokenExecutor("the pool broke"))
        self.inflight[future] = index

    def wait(self) -> list[Event]:
        finished, _ = wait(list(self.inflight), return_when=FIRST_COMPLETED)
        events, broken = [], []
        for fut in finished:
            index = self.inflight.pop(fut)
            try:
                kind, payload = fut.result()
            except BrokenExecutor as exc:
                broken.append((index, exc))
                continue
            except Exception as exc:  # the result could not be sent back (e.g. not picklable)
                kind, payload = "raised", describe(exc)
            if kind == "fatal":  # e.g. a worker could not write a result (F-OUTPUT-FAILURES)
                raise payload
            events.append(Event(index, kind, payload))
        if broken:
            # every item in flight fails with the pool: only a lone one is proven to have killed it
            for fut, index in self.inflight.items():
                broken.append((index, BrokenExecutor("the pool broke")))
            self.inflight.clear()
            lone = len(broken) == 1
            events += [Event(index, "died", describe(exc), proven=lone) for index, exc in broken]
            self.pool.shutdown(wait=False, cancel_futures=True)
            self.pool = self._new_pool()
        return events

    def close(self, cancel: bool) -> None:
        # a normal shutdown lets each worker finish its item and exit, which runs task.close
        # (the worker's simulator is stopped) — the same guarantee on Ctrl-C (CAMP-CANCEL)
        self.pool.shutdown(wait=True, cancel_futures=cancel)


def make_backend(spec: ExecutorSpec, task: Task) -> Backend:
    if spec.kind == "ray":
        from agspec.campaign.ray_backend import RayBackend

        return RayBackend(task, spec)
    if spec.kind != "local":
        raise ExecutorError(f"unknown executor {spec.kind!r} (expected one of {', '.join(EXECUTORS)})")
    jobs = spec.jobs or 1
    return InlineBackend(task) if jobs <= 1 else PoolBackend(task, jobs)


# --------------------------------------------------------------------------- the driver


def dispatch_order(n: int, seed: int | None) -> list[int]:
    order = list(range(n))
    if seed is not None:
        random.Random(seed).shuffle(order)
    return order


def run_ordered(task: Task, items: Sequence[Any], spec: ExecutorSpec | None = None, *,
                on_progress: Callable[[int, Outcome], None] | None = None) -> Iterator[tuple[int, Outcome]]:
    """Run ``task`` over ``items``; yield ``(index, outcome)`` in item order (CAMP-ORDER).

    ``on_progress`` is called as each item finishes, in completion order (for progress bars only).
    Closing the generator early cancels what is pending and stops the workers (CAMP-CANCEL).
    """
    spec = spec or ExecutorSpec()
    if spec.retries < 0:
        raise ExecutorError(f"--retries must be >= 0, got {spec.retries}")
    n = len(items)
    if n == 0:
        return
    queue = deque(dispatch_order(n, spec.dispatch_seed))
    suspects: deque[int] = deque()  # died alongside others: re-run alone before an attempt counts
    attempts = [0] * n
    ready: dict[int, Outcome] = {}
    emitted = 0
    backend = make_backend(spec, task)
    cancel = True
    try:
        while emitted < n:
            if suspects:
                if backend.busy() == 0:
                    index = suspects.popleft()
                    attempts[index] += 1
                    backend.submit(index, items[index])
            else:
                while queue and backend.free() > 0:
                    index = queue.popleft()
                    attempts[index] += 1
                    backend.submit(index, items[index])
            for event in backend.wait():
                i = event.index
                if event.kind == "died":
                    if not event.proven:
                        attempts[i] -= 1
                        suspects.append(i)
                        continue
                    if attempts[i] <= spec.retries:
                        queue.appendleft(i)
                        continue
                    outcome: Outcome = Failed(str(event.payload), attempts[i], True)
                elif event.kind == "raised":
                    outcome = Failed(str(event.payload), attempts[i], False)
                else:
                    outcome = Done(event.payload)
                ready[i] = outcome
                if on_progress is not None:
                    on_progress(i, outcome)
            while emitted in ready:
                yield emitted, ready.pop(emitted)
                emitted += 1
        cancel = False
    finally:
        backend.close(cancel)


__all__ = ["ExecutorSpec", "Task", "Done", "Failed", "Outcome", "ExecutorError", "run_ordered", "EXECUTORS",
           "DEFAULT_RETRIES", "describe", "dispatch_order"]
