"""Episodes and evaluations: drive the reference interpreter with a controller (spec chapter 11).

``run_episode`` runs one instance to its horizon (optionally writing a trace); ``evaluate`` runs
many (scenario, controller, index) triples through the campaign executor (spec chapter 14) and summarizes them as the paper
does: mean and 95 % half-width 1.96·s/√n over instances.
"""

from __future__ import annotations

import math
import statistics
from dataclasses import dataclass
from typing import Any, Callable, Iterable, Mapping

from agspec.campaign.executor import Done, ExecutorSpec, Task, run_ordered
from agspec.controllers import make_controller
from agspec.interp.snapshot import global_state
from agspec.interp.state import cell_id
from agspec.interp.tick import Simulator
from agspec.ir.fingerprint import fingerprint


@dataclass(frozen=True)
class EpisodeResult:
    instance_id: str
    controller: str
    metrics: dict[str, Any]


def run_episode(
    instance: Mapping[str, Any],
    controller: str = "greedy",
    *,
    horizon: int | None = None,
    seed: int | None = None,
    trace=None,
    observations_in_trace: bool = False,
    on_tick: Callable[[int, int], None] | None = None,
) -> EpisodeResult:
    """Run one episode; ``trace`` is an optional TraceWriter; ``horizon`` may shorten the run."""
    sim = Simulator(instance)
    exec_seed = seed if seed is not None else instance.get("seeds", {}).get("execution")
    sim.reset(exec_seed)
    ctl = make_controller(controller)
    ctl.reset(exec_seed)
    limit = sim.model.horizon if horizon is None else min(horizon, sim.model.horizon)
    if trace is not None:
        trace.header(
            instance=instance,
            fingerprint=fingerprint(instance),
            execution_seed=exec_seed,
            controller={"name": ctl.name, "information": ctl.information},
            initial_state=global_state(sim.state),
            initial_events=sim.reset_events,
        )
    while not sim.done and sim.t < limit:
        obs = sim.observe()
        actions = ctl.act(obs, sim if ctl.information == "global" else None)
        t = sim.t
        result = sim.step(actions)
        if trace is not None:
            trace.tick(
                t=t,
                actions=result.applied,
                events=result.events,
                state=global_state(sim.state),
                observations=obs if observations_in_trace else None,
            )
        if on_tick is not None:
            on_tick(sim.t, limit)
    metrics = sim.final_metrics()
    if trace is not None:
        trace.footer(metrics=metrics)
    return EpisodeResult(instance.get("id", "?"), ctl.name, metrics)


def mean_ci(values: list[float]) -> tuple[float, float]:
    """Mean and 95 % normal-approximation half-width 1.96·s/√n (s: sample standard deviation)."""
    if not values:
        return (math.nan, math.nan)
    mean = statistics.fmean(values)
    if len(values) < 2:
        return (mean, 0.0)
    return (mean, 1.96 * statistics.stdev(values) / math.sqrt(len(values)))


def _episode(instances: list[Mapping[str, Any]], item: tuple[str, int, int]) -> dict[str, Any]:
    _, controller, slot = item
    return run_episode(instances[slot], controller).metrics


def evaluate(jobs: Iterable[tuple[str, str, int, Mapping[str, Any]]], workers: int = 1,
             on_done: Callable[[dict[str, Any]], None] | None = None,
             executor: ExecutorSpec | None = None) -> list[dict[str, Any]]:
    """Run (scenario, controller, index, instance) jobs; results come back in job order (CAMP-ORDER).

    ``executor`` says where the episodes run (default: ``workers`` local processes).  Each distinct
    instance is shipped once (CAMP-SHIP-ONCE), however many controllers run it.  An episode that
    produced no metrics (its worker died past the retries, or it raised) is a run with ``metrics``
    None and an ``error`` naming the cause (CAMP-FAULTS).
    """
    jobs = list(jobs)
    instances: list[Mapping[str, Any]] = []
    slots: dict[tuple[str, int], int] = {}
    items = []
    for scenario, ctl, index, inst in jobs:
        slot = slots.get((scenario, index))
        if slot is None or instances[slot] != inst:
            slot = slots[(scenario, index)] = len(instances)
            instances.append(inst)
        items.append((scenario, ctl, slot))
    runs: list[dict[str, Any]] = []
    spec = executor or ExecutorSpec(jobs=workers)
    for i, outcome in run_ordered(Task(_episode, instances), items, spec):
        scenario, ctl, index, _ = jobs[i]
        run: dict[str, Any] = {"scenario": scenario, "controller": ctl, "index": index,
                               "metrics": outcome.value if isinstance(outcome, Done) else None}
        if not isinstance(outcome, Done):
            run["error"] = f"episode {scenario}/{ctl}/{index} failed: {outcome.message()}"
        runs.append(run)
        if on_done:
            on_done(run)
    return runs


def summarize(runs: list[dict[str, Any]], keys: Iterable[str] = ("delivered",)) -> list[dict[str, Any]]:
    """Group runs by (scenario, controller) and report mean ± half-width for each metric key."""
    groups: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for run in runs:
        if run["metrics"] is None:  # a failed episode (CAMP-FAULTS): reported, never averaged
            continue
        groups.setdefault((run["scenario"], run["controller"]), []).append(run)
    out = []
    for (scenario, ctl), group in groups.items():
        entry: dict[str, Any] = {"scenario": scenario, "controller": ctl, "n": len(group)}
        for key in keys:
            values = [r["metrics"][key] for r in group if r["metrics"].get(key) is not None]
            mean, half = mean_ci([float(v) for v in values])
            entry[key] = {"mean": mean, "half_width": half, "n": len(values)}
        out.append(entry)
    return out


__all__ = ["EpisodeResult", "run_episode", "evaluate", "summarize", "mean_ci", "cell_id"]
