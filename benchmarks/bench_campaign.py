"""Campaign executors (spec/14-campaigns.md): wall time and items/s of local -j1, local -j2, and Ray
with 1 and 2 workers, in one run, as ratios against local -j1 measured in the same run.

Usage:  python benchmarks/bench_campaign.py [--quick] [--json]

Two workloads per executor: *episodes* (``agspec.evaluate.evaluate`` on greedy/random episodes of
coalition-easy and flow-easy, full horizon) and *no-op items* (a task that returns its item): one
no-op item measures the workers' start-up, N of them add the executor's own overhead per item —
dispatch, transfer, ordering — reported as (T(N) - T(1)) / (N - 1).  Ray is started once (a local Ray
with 2 CPUs) before its rows; its start-up time is reported on its own line, not in the rows.  The
figures feed the estimate in docs/scale-out.md; nothing here asserts a time.
"""

from __future__ import annotations

import argparse
import time

from _common import emit

from agspec.campaign.executor import ExecutorSpec, Task, run_ordered
from agspec.catalogue import load_scenario_bundle
from agspec.evaluate import evaluate


def identity(_context, item):
    return item


def episode_jobs(indices: range) -> list:
    from agspec.ir.instance import make_instance

    jobs = []
    for scenario in ("coalition-easy", "flow-easy"):
        bundle = load_scenario_bundle(scenario)
        for k in indices:
            inst = make_instance(*bundle, index=k)
            jobs += [(scenario, ctl, k, inst) for ctl in ("greedy", "random")]
    return jobs


def measure(spec: ExecutorSpec, jobs: list, noop_items: int) -> dict:
    t0 = time.perf_counter()
    runs = evaluate(jobs, executor=spec)
    episodes_s = time.perf_counter() - t0
    assert all(r["metrics"] is not None for r in runs), "an episode failed"
    seconds = []
    for n in (1, noop_items):  # one item: the start-up of the workers; n items: plus n-1 items' overhead
        t0 = time.perf_counter()
        out = list(run_ordered(Task(identity), list(range(n)), spec))
        seconds.append(time.perf_counter() - t0)
        assert [o.value for _, o in out] == list(range(n))
    return {"episodes": len(jobs), "wall_s": episodes_s, "episodes_per_s": len(jobs) / episodes_s,
            "s_per_episode": episodes_s / len(jobs), "startup_s": seconds[0],
            "overhead_ms_per_item": 1000 * max(0.0, seconds[1] - seconds[0]) / (noop_items - 1),
            "noop_items_per_s": noop_items / seconds[1]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="2 instances per scenario, 100 no-op items")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    jobs = episode_jobs(range(1000, 1002) if args.quick else range(1000, 1004))
    noop = 100 if args.quick else 400
    rows = []
    for label, spec in (("local -j1", ExecutorSpec("local", 1)), ("local -j2", ExecutorSpec("local", 2))):
        rows.append({"executor": label, **measure(spec, jobs, noop)})
    ray_start_s = None
    try:
        import ray
    except ImportError:
        ray = None
    if ray is not None:
        t0 = time.perf_counter()
        ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False, logging_level="ERROR")
        ray_start_s = time.perf_counter() - t0
        try:
            for label, spec in (("ray 1 worker", ExecutorSpec("ray", 1)), ("ray 2 workers", ExecutorSpec("ray", 2))):
                rows.append({"executor": label, **measure(spec, jobs, noop)})
        finally:
            ray.shutdown()
    base = rows[0]
    for row in rows:
        row["speedup_vs_local_j1"] = base["wall_s"] / row["wall_s"]
    emit({"benchmark": "campaign", "rows": rows, "ray_start_s": ray_start_s, "noop_items": noop},
         rows, ("executor", "episodes", "wall_s", "episodes_per_s", "s_per_episode", "startup_s",
                "overhead_ms_per_item", "speedup_vs_local_j1"),
         f"campaign executors ({len(jobs)} episodes; {noop} no-op items; Ray start-up "
         f"{'%.1f s' % ray_start_s if ray_start_s else 'n/a'})", args.json)


if __name__ == "__main__":
    main()
