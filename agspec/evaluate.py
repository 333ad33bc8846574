"""Evaluations: the one episode map of every campaign, and the paper's summaries (spec chapters 11, 13, 14).

``map_episodes`` is the one episode map of every campaign (through the campaign executor, spec
chapter 14) and ``run_job`` dispatches one episode to where it must run (here, a policy host, a fresh
process); ``summarize`` reports as the paper does: mean and 95 % half-width 1.96·s/√n over instances.
The episode itself is :func:`agspec.policy.episode.run_episode`, re-exported here with the names the
spec and the docs use (``agspec.evaluate.run_episode``, ``Job``, ``mean_ci``).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from typing import Any, Callable, Iterable, Iterator, Mapping

from agspec.campaign.executor import Done, ExecutorSpec, Task, run_ordered
from agspec.interp.state import cell_id
from agspec.policy import fresh
from agspec.policy.contract import PolicyError, PolicySpec
from agspec.policy.episode import DEFAULT_LOAD_TIMEOUT, EpisodeResult, Job, as_policy, check_joint, job_record
from agspec.policy.episode import run_episode, run_here
from agspec.policy.host import PolicyHosts
from agspec.policy.stats import mean_ci

# F-POLICY-HOST: policies whose code runs in the worker's Python (user factories, trained checkpoints)
HOSTED_KINDS = ("python", "checkpoint")


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
    return run_here(job, guard)


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


__all__ = ["DEFAULT_LOAD_TIMEOUT", "EpisodeResult", "Job", "as_policy", "run_episode", "run_job", "map_episodes",
           "evaluate", "summarize", "mean_ci", "cell_id", "check_joint", "job_record"]
