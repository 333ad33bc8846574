"""Episodes and evaluations: drive the reference interpreter with a controller (spec chapter 11).

``run_episode`` runs one instance to its horizon with a reference controller or a user policy
(optionally writing a trace); ``map_episodes`` is the one episode map of every campaign (through the
campaign executor, spec chapter 14); ``summarize`` reports as the paper does: mean and 95 %
half-width 1.96·s/√n over instances.
"""

from __future__ import annotations

import hashlib
import json
import math
import statistics
import time
from dataclasses import dataclass, replace
from typing import Any, Callable, Iterable, Iterator, Mapping

from agspec.campaign.executor import Done, ExecutorSpec, Task, run_ordered
from agspec.interp.observe import N_ACTIONS
from agspec.interp.snapshot import global_state
from agspec.interp.state import cell_id
from agspec.ir.fingerprint import fingerprint
from agspec.policy import fresh
from agspec.policy.contract import PolicyError, PolicySpec, PolicySpecError
from agspec.policy.host import DEFAULT_LOAD_TIMEOUT, PolicyHosts
from agspec.policy.sessions import open_session


@dataclass(frozen=True)
class EpisodeResult:
    instance_id: str
    controller: str
    metrics: dict[str, Any]
    illegal_actions: int = 0  # masked actions executed as idle (R-ACTION-VALIDATION, F-POLICY-ILLEGAL)
    actions_digest: str = ""  # sha256 of the joint actions in tick order (F-POLICY-DETERMINISM)


def as_policy(policy: str | PolicySpec) -> PolicySpec:
    """A reference controller name or a PolicySpec (F-POLICY-SPEC)."""
    return policy if isinstance(policy, PolicySpec) else PolicySpec("controller", policy, policy)


def check_joint(raw: Any, agents: list[str], t: int) -> dict[str, int]:
    """F-POLICY-ERRORS: a joint action names every agent once with an integer in 0..113 (O-ACTION-ENCODING)."""
    if not isinstance(raw, Mapping):
        raise PolicyError("bad_action", f"the policy returned {type(raw).__name__}, not a mapping agent -> action",
                          tick=t)
    known = set(agents)
    for agent in raw:
        if agent not in known:
            raise PolicyError("unknown_agent", f"action for unknown agent {agent!r}; agents are robot ids such as "
                                               f"{agents[0]!r}", tick=t, agent=str(agent))
    joint: dict[str, int] = {}
    for agent in agents:
        if agent not in raw:  # RES-POLICY-MISSING-AGENT: unlike A-PZ-STEP, never an implicit idle
            raise PolicyError("missing_agent", f"no action for agent {agent!r}", tick=t, agent=agent)
        value = raw[agent]
        if hasattr(value, "item") and not isinstance(value, (bool, int)):  # NumPy scalars and 0-d arrays
            try:
                value = value.item()
            except (TypeError, ValueError):
                pass
        if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value < N_ACTIONS:
            raise PolicyError("bad_action", f"action {value!r} of agent {agent!r} is not an integer in "
                                            f"0..{N_ACTIONS - 1}", tick=t, agent=agent)
        joint[agent] = value
    return joint


def run_episode(
    instance: Mapping[str, Any],
    controller: str | PolicySpec = "greedy",
    *,
    horizon: int | None = None,
    seed: int | None = None,
    trace=None,
    observations_in_trace: bool = False,
    on_tick: Callable[[int, int], None] | None = None,
    strict: bool = False,
    timeout: float | None = None,
    load_timeout: float | None = None,
    guard: Callable[[str, str, int | None], Any] | None = None,
    scenario: str | None = None,
    index: int | None = None,
) -> EpisodeResult:
    """Run one episode of a reference controller or a user policy (F-POLICY-RUNNER), in this process.

    ``trace`` is an optional TraceWriter; ``horizon`` may shorten the run.  A misbehaving policy
    raises :class:`~agspec.policy.contract.PolicyError` (F-POLICY-ERRORS); a masked action is
    executed as idle and counted, or raises under ``strict`` (F-POLICY-ILLEGAL).  ``timeout``
    bounds each decision, ``load_timeout`` the loading of a Python policy; ``guard`` replaces the
    in-process alarm that enforces both (F-POLICY-HOST).
    """
    spec = as_policy(controller)
    # F-POLICY-EVALUATION: the instance's own execution seed (S-SEEDS) and the scenario horizon
    exec_seed = seed if seed is not None else instance.get("seeds", {}).get("execution")
    session = open_session(spec, instance, exec_seed, timeout=timeout, load_timeout=load_timeout, guard=guard,
                           scenario=scenario, index=index)
    try:
        sim = session.sim
        agents = sim.agents()
        limit = sim.model.horizon if horizon is None else min(horizon, sim.model.horizon)
        if trace is not None:
            trace.header(
                instance=instance,
                fingerprint=fingerprint(instance),
                execution_seed=exec_seed,
                controller={"name": session.name, "information": session.information},
                initial_state=global_state(sim.state),
                initial_events=sim.reset_events,
                horizon=limit,
            )
        digest = hashlib.sha256()
        illegal = 0
        while not sim.done and sim.t < limit:
            t = sim.t
            joint = check_joint(session.act(), agents, t)
            digest.update(json.dumps([joint[a] for a in agents]).encode())
            step = session.step(joint)
            coerced = [a for a in agents if step.applied[a] != joint[a]]
            if coerced and strict:
                a = coerced[0]
                raise PolicyError("illegal_action", f"action {joint[a]} of agent {a!r} is masked (O-MASK); "
                                                    "--strict makes this an error", tick=t, agent=a)
            illegal += len(coerced)
            if trace is not None:
                trace.tick(
                    t=t,
                    actions=step.applied,
                    events=step.events,
                    state=global_state(sim.state),
                    observations=session.observations if observations_in_trace else None,
                    chosen={a: joint[a] for a in coerced},  # F-TRACE: pairs with action_coerced
                )
            if on_tick is not None:
                on_tick(sim.t, limit)
        metrics = sim.final_metrics()
        if trace is not None:
            trace.footer(metrics=metrics)
        return EpisodeResult(instance.get("id", "?"), spec.label, metrics, illegal, digest.hexdigest())
    finally:
        session.close()


def mean_ci(values: list[float]) -> tuple[float, float]:
    """Mean and 95 % normal-approximation half-width 1.96·s/√n (s: sample standard deviation)."""
    if not values:
        return (math.nan, math.nan)
    mean = statistics.fmean(values)
    if len(values) < 2:
        return (mean, 0.0)
    return (mean, 1.96 * statistics.stdev(values) / math.sqrt(len(values)))


# F-POLICY-HOST: policies whose code runs in the worker's Python (user factories, trained checkpoints)
HOSTED_KINDS = ("python", "checkpoint")


@dataclass(frozen=True)
class Job:
    """One episode of a campaign: which policy on which instance, and how (F-POLICY-RUNNER)."""

    scenario: str
    index: int
    policy: PolicySpec
    instance: Mapping[str, Any]
    strict: bool = False
    timeout: float | None = None  # seconds per decision (F-POLICY-ERRORS)
    repeat: bool = False  # a second run of the same episode, for F-POLICY-DETERMINISM
    load_timeout: float | None = None  # seconds to load a Python policy (None: the default, F-POLICY-HOST)


def job_record(job: Job, started: float, result: EpisodeResult | None = None,
               error: PolicyError | None = None) -> dict[str, Any]:
    """The results-bundle record of one episode (F-POLICY-BUNDLE): its result or its error."""
    record: dict[str, Any] = {"scenario": job.scenario, "controller": job.policy.label, "index": job.index}
    if result is not None:
        record.update(status="ok", metrics=result.metrics, illegal_actions=result.illegal_actions,
                      actions_sha256=result.actions_digest, error=None)
    else:
        record.update(status="error", metrics=None, illegal_actions=None, actions_sha256=None,
                      error=(error or PolicyError("worker", "no result")).record())
    record["wall_time"] = round(time.perf_counter() - started, 6)
    if job.repeat:
        record["repeat"] = True
    return record


def run_job(job: Job, hosts: PolicyHosts | None = None,
            guard: Callable[[str, str, int | None], Any] | None = None) -> dict[str, Any]:
    """One episode as a record of the results bundle (F-POLICY-BUNDLE); a misbehaving policy gives an
    ``error`` record instead of stopping the campaign (F-POLICY-ERRORS).

    With ``hosts`` (a campaign worker's), a Python policy's episode runs in that worker's policy host
    (F-POLICY-HOST); otherwise here, its phases bounded by ``guard`` or the in-process alarm.
    """
    if job.repeat and job.policy.kind == "python":
        return fresh.run_fresh(job)  # F-POLICY-DETERMINISM: an in-process policy repeats in a new process
    if hosts is not None and job.policy.kind in HOSTED_KINDS:
        return hosts.run(job)
    started = time.perf_counter()
    try:
        result = run_episode(job.instance, job.policy, strict=job.strict, timeout=job.timeout,
                             load_timeout=job.load_timeout if job.load_timeout is not None else DEFAULT_LOAD_TIMEOUT,
                             guard=guard, scenario=job.scenario, index=job.index)
    except (PolicyError, PolicySpecError) as exc:
        return job_record(job, started, error=exc if isinstance(exc, PolicyError) else PolicyError("setup", str(exc)))
    return job_record(job, started, result)


@dataclass
class EpisodeWorker:
    """What one campaign worker holds: the shipped instances and its policy hosts (F-POLICY-HOST)."""

    instances: list[Mapping[str, Any]]
    hosts: PolicyHosts


def _worker_open(instances: list[Mapping[str, Any]]) -> EpisodeWorker:
    return EpisodeWorker(instances, PolicyHosts())


def _worker_close(worker: EpisodeWorker) -> None:
    worker.hosts.close()


def _run_slot(worker: EpisodeWorker, item: tuple[Job, int]) -> dict[str, Any]:
    job, slot = item
    return run_job(replace(job, instance=worker.instances[slot]), worker.hosts)


def map_episodes(jobs: list[Job], workers: int = 1, executor: ExecutorSpec | None = None) -> Iterator[dict[str, Any]]:
    """THE episode map: every campaign's episodes go through here, results in job order (CAMP-ORDER).

    ``executor`` says where they run (spec chapter 14; default ``workers`` local processes).  Each
    distinct instance is shipped once however many policies run it (CAMP-SHIP-ONCE).  An episode
    whose worker died past the retries is an ``error`` record with code ``worker`` (CAMP-FAULTS).
    Leaving the iterator early stops the workers (CAMP-CANCEL).  Each worker runs Python policies in
    its policy hosts, imported once per host and replaced after a timeout (F-POLICY-HOST).
    """
    instances: list[Mapping[str, Any]] = []
    slots: dict[tuple[str, int], int] = {}
    items = []
    for job in jobs:
        slot = slots.get((job.scenario, job.index))
        if slot is None or instances[slot] != job.instance:
            slot = slots[(job.scenario, job.index)] = len(instances)
            instances.append(job.instance)
        items.append((replace(job, instance=None), slot))
    task = Task(_run_slot, instances, init=_worker_open, close=_worker_close)
    for i, outcome in run_ordered(task, items, executor or ExecutorSpec(jobs=workers)):
        if isinstance(outcome, Done):
            yield outcome.value
            continue
        error = PolicyError("worker", f"the episode was not run: {outcome.message()}")
        yield {**job_record(jobs[i], time.perf_counter(), error=error), "wall_time": 0.0}


def evaluate(jobs: Iterable[tuple[str, str | PolicySpec, int, Mapping[str, Any]] | Job], workers: int = 1,
             on_done: Callable[[dict[str, Any]], None] | None = None,
             executor: ExecutorSpec | None = None) -> list[dict[str, Any]]:
    """Run (scenario, controller, index, instance) jobs (or :class:`Job` s); results come back in job order."""
    todo = [j if isinstance(j, Job) else Job(j[0], j[2], as_policy(j[1]), j[3]) for j in jobs]
    runs: list[dict[str, Any]] = []
    for run in map_episodes(todo, workers, executor):
        runs.append(run)
        if on_done:
            on_done(run)
    return runs


def summarize(runs: list[dict[str, Any]], keys: Iterable[str] = ("delivered",)) -> list[dict[str, Any]]:
    """Group runs by (scenario, controller) and report mean ± half-width for each metric key."""
    groups: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for run in runs:
        groups.setdefault((run["scenario"], run["controller"]), []).append(run)
    out = []
    for (scenario, ctl), group in groups.items():
        entry: dict[str, Any] = {"scenario": scenario, "controller": ctl, "n": len(group)}
        for key in keys:
            values = [r["metrics"][key] for r in group if r.get("metrics") and r["metrics"].get(key) is not None]
            mean, half = mean_ci([float(v) for v in values])
            # JSON has no NaN; one value has no interval (F-POLICY-COVERAGE: never "± 0" over n = 1)
            entry[key] = {"mean": mean if math.isfinite(mean) else None,
                          "half_width": half if len(values) >= 2 and math.isfinite(half) else None, "n": len(values)}
        out.append(entry)
    return out


__all__ = ["EpisodeResult", "Job", "run_episode", "run_job", "map_episodes", "evaluate", "summarize", "mean_ci",
           "cell_id", "check_joint"]
