"""The ``ray`` executor (CAMP-EXECUTOR): one Ray actor per worker, one item in flight per actor.

Needs the optional extra ``agspec[ray]``.  The task's shared data is put in the object store once
(CAMP-SHIP-ONCE) and every actor builds its context from that one object.  A dead actor (its process
or node died) is replaced and its item re-dispatched by the driver (CAMP-RETRY).  On cancel each
actor's context is closed first — stopping the simulator processes it started — and then the actors
are killed; a Ray started for the run is shut down (CAMP-CANCEL).
"""

from __future__ import annotations

from typing import Any

from agspec.campaign.task import Event, ExecutorError, ExecutorSpec, Task, describe

try:
    import ray
    from ray.exceptions import ActorDiedError, ActorUnavailableError, RayActorError, WorkerCrashedError
except ImportError:  # pragma: no cover - exercised only without the extra
    ray = None

CLOSE_SECONDS = 10.0  # how long cancelled actors get to stop their simulators before they are killed


class _Worker:
    """A Ray actor holding one context (e.g. one simulator under test) for its lifetime."""

    def __init__(self, task: Task, shared: Any):
        self.task = Task(task.fn, shared, task.init, task.close)
        self.closed, self.setup_error = False, None
        try:
            self.context = self.task.context()
        except Exception as exc:  # deterministic: reported by every item of this actor, never retried
            self.closed, self.setup_error = True, f"worker setup failed: {describe(exc)}"

    def run(self, item: Any) -> tuple[str, Any]:
        if self.setup_error is not None:
            return "raised", self.setup_error
        try:
            return "ok", self.task.fn(self.context, item)
        except Exception as exc:
            return "raised", describe(exc)

    def close(self) -> None:
        if not self.closed and self.task.close is not None:
            self.closed = True
            self.task.close(self.context)


def connect(spec: ExecutorSpec) -> bool:
    """Connect to (or start) Ray; True when this call started a local Ray that the run must stop."""
    if ray is None:
        raise ExecutorError("--executor ray needs Ray: pip install 'agspec[ray]'")
    if ray.is_initialized():
        return False
    kwargs: dict[str, Any] = {"log_to_driver": False, "logging_level": "ERROR"}
    if spec.runtime_env:
        kwargs["runtime_env"] = spec.runtime_env
    try:
        if spec.address is None:
            ray.init(num_cpus=spec.jobs or None, include_dashboard=False, **kwargs)
        else:
            ray.init(address=spec.address, **kwargs)
    except Exception as exc:  # unreachable cluster, bad address, version mismatch
        raise ExecutorError(f"cannot start or reach Ray at {spec.address or 'a new local Ray'}: {describe(exc)}")
    _cluster_errors_to_stderr()
    return True


def _cluster_errors_to_stderr() -> None:
    """Ray prints the cluster's error messages (e.g. "a worker died") on the driver's *stdout*, which
    would corrupt a command's ``--format json`` output; the driver reports those deaths itself
    (CAMP-FAULTS), so Ray's own lines are sent to stderr.  Ray has no option for this: the hook is
    its module function, replaced once and only if this Ray version has it."""
    module = getattr(getattr(ray, "_private", None), "worker", None)
    original = getattr(module, "print_to_stdstream", None)
    if original is None or getattr(original, "agspec_to_stderr", False):
        return

    def to_stderr(data: dict[str, Any], *args: Any, **kwargs: Any) -> None:
        original({**data, "is_err": True}, *args, **kwargs)

    to_stderr.agspec_to_stderr = True  # type: ignore[attr-defined]
    module.print_to_stdstream = to_stderr


class RayBackend:
    def __init__(self, task: Task, spec: ExecutorSpec):
        self.started = connect(spec)
        try:
            # one CPU per actor (and spec.gpus GPUs, CAMP-GPU): more actors than the cluster holds would
            # never be scheduled
            resources = ray.cluster_resources()
            cpus = max(1, int(resources.get("CPU", 1)))
            self.jobs = min(spec.jobs or cpus, cpus)
            if spec.gpus:
                fits = int(resources.get("GPU", 0) / spec.gpus + 1e-9)
                if fits < 1:
                    raise ExecutorError(f"each worker asks for {spec.gpus:g} GPU but the Ray cluster has "
                                        f"{resources.get('GPU', 0):g}")
                self.jobs = min(self.jobs, fits)
            self.actor_class = ray.remote(num_cpus=1, num_gpus=spec.gpus, max_concurrency=2,
                                          max_restarts=0)(_Worker)
            # the code travels by reference; the data once through the object store
            self.task = Task(task.fn, None, task.init, task.close)
            self.shared = ray.put(task.shared)
            self.idle = [self._new_actor() for _ in range(self.jobs)]
        except BaseException:
            if self.started:
                ray.shutdown()
            raise
        self.inflight: dict[Any, tuple[int, Any]] = {}  # object ref -> (item index, actor)

    def _new_actor(self):
        return self.actor_class.remote(self.task, self.shared)

    def free(self) -> int:
        return len(self.idle)

    def busy(self) -> int:
        return len(self.inflight)

    def submit(self, index: int, item: Any) -> None:
        actor = self.idle.pop()
        self.inflight[actor.run.remote(item)] = (index, actor)

    def wait(self) -> list[Event]:
        ready, _ = ray.wait(list(self.inflight), num_returns=1)
        events = []
        for ref in ready:
            index, actor = self.inflight.pop(ref)
            try:
                kind, payload = ray.get(ref)
                self.idle.append(actor)
                events.append(Event(index, kind, payload))
            except (RayActorError, ActorDiedError, ActorUnavailableError, WorkerCrashedError) as exc:
                ray.kill(actor, no_restart=True)
                self.idle.append(self._new_actor())
                events.append(Event(index, "died", describe(exc)))
            except Exception as exc:  # the result could not be transferred back
                self.idle.append(actor)
                events.append(Event(index, "raised", describe(exc)))
        return events

    def close(self, cancel: bool) -> None:
        actors = self.idle + [actor for _, actor in self.inflight.values()]
        try:
            # close every context (concurrently with a running item: max_concurrency=2), so the
            # simulators the workers started stop before their actors are killed
            refs = [actor.close.remote() for actor in actors]
            if refs:
                ray.wait(refs, num_returns=len(refs), timeout=CLOSE_SECONDS)
        finally:
            for actor in actors:
                ray.kill(actor, no_restart=True)
            self.idle, self.inflight = [], {}
            if self.started:
                ray.shutdown()


__all__ = ["RayBackend", "connect"]
