"""Episodes and evaluations: drive the reference interpreter with a controller (spec chapter 11).

``run_episode`` runs one instance to its horizon (optionally writing a trace); ``evaluate`` runs
many (scenario, controller, index) triples in a process pool and summarizes them as the paper
does: mean and 95 % half-width 1.96·s/√n over instances.
"""

from __future__ import annotations

import math
import statistics
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from typing import Any, Callable, Iterable, Mapping

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
            horizon=limit,
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


def _job(args: tuple[Mapping[str, Any], str]) -> dict[str, Any]:
    instance, controller = args
    return run_episode(instance, controller).metrics


def evaluate(jobs: Iterable[tuple[str, str, int, Mapping[str, Any]]], workers: int = 1,
             on_done: Callable[[dict[str, Any]], None] | None = None) -> list[dict[str, Any]]:
    """Run (scenario, controller, index, instance) jobs; results come back in job order."""
    jobs = list(jobs)
    runs: list[dict[str, Any]] = []
    payload = [(inst, ctl) for _, ctl, _, inst in jobs]
    if workers <= 1:
        results = map(_job, payload)
        for (scenario, ctl, index, _), metrics in zip(jobs, results):
            run = {"scenario": scenario, "controller": ctl, "index": index, "metrics": metrics}
            runs.append(run)
            if on_done:
                on_done(run)
        return runs
    with ProcessPoolExecutor(max_workers=workers) as pool:
        for (scenario, ctl, index, _), metrics in zip(jobs, pool.map(_job, payload, chunksize=1)):
            run = {"scenario": scenario, "controller": ctl, "index": index, "metrics": metrics}
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
            values = [r["metrics"][key] for r in group if r["metrics"].get(key) is not None]
            mean, half = mean_ci([float(v) for v in values])
            entry[key] = {"mean": mean, "half_width": half, "n": len(values)}
        out.append(entry)
    return out


__all__ = ["EpisodeResult", "run_episode", "evaluate", "summarize", "mean_ci", "cell_id"]
