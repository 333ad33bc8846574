"""K* solve time and exact share on the states the official episodes actually visit (M-CAPACITY).

Usage:  python benchmarks/bench_kstar_visited.py [--indices 1000-1004] [--ticks 400] [--controller C ...] [--json]

For every official scenario, instance and reference controller, the episode is stepped and, at every
decision epoch, the capacity problem of the pre-action state is built and solved once more under a
timer (the interpreter solves it as well; only the extra solve is timed, problem building excluded).
Target (issue 5): exact K* on 100 % of visited states.  bench_capacity.py covers synthetic states
beyond the suite's sizes.  Nothing is asserted.
"""

from __future__ import annotations

import argparse
import statistics
import time

from _common import emit, self_peak_mib

from agspec.catalogue import OFFICIAL_SCENARIOS, load_scenario_bundle, parse_indices
from agspec.controllers import make_controller
from agspec.interp import capacity as cap
from agspec.interp.metrics import capacity_problem
from agspec.interp.tick import Simulator
from agspec.ir.instance import make_instance


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(q * (len(ordered) - 1)))]


def visit(scenario: str, indices: list[int], controllers: list[str], ticks: int) -> dict:
    bundle = load_scenario_bundle(scenario)
    times, exact, cands = [], 0, []
    for index in indices:
        inst = make_instance(*bundle, index=index)
        for name in controllers:
            sim = Simulator(inst)
            seed = inst["seeds"]["execution"]
            sim.reset(seed)
            ctl = make_controller(name)
            ctl.reset(seed)
            while not sim.done and sim.t < ticks:
                problem, _ = capacity_problem(sim.state, sim.model, sim.decision.candidates)
                t0 = time.perf_counter()
                result = cap.solve_count(problem)
                times.append(time.perf_counter() - t0)
                exact += bool(result.exact)
                cands.append(len(problem.candidates))
                sim.step(ctl.act(sim.observe(), sim if ctl.information == "global" else None))
    return {"scenario": scenario, "states": len(times), "exact_share": exact / len(times),
            "median_ms": 1e3 * statistics.median(times), "p99_ms": 1e3 * percentile(times, 0.99),
            "max_ms": 1e3 * max(times), "candidates_max": max(cands), "_times": times, "_exact": exact}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--indices", default="1000-1004")
    ap.add_argument("--ticks", type=int, default=400)
    ap.add_argument("--controller", action="append", default=None)
    ap.add_argument("--scenario", action="append", default=None)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    controllers = args.controller or ["random", "greedy", "parallel-aware", "centralized"]
    rows = [visit(s, parse_indices(args.indices), controllers, args.ticks) for s in (args.scenario or OFFICIAL_SCENARIOS)]
    every = [t for r in rows for t in r["_times"]]
    total = {"scenario": "all", "states": len(every), "exact_share": sum(r["_exact"] for r in rows) / len(every),
             "median_ms": 1e3 * statistics.median(every), "p99_ms": 1e3 * percentile(every, 0.99),
             "max_ms": 1e3 * max(every), "candidates_max": max(r["candidates_max"] for r in rows)}
    rows = [{k: v for k, v in r.items() if not k.startswith("_")} for r in rows] + [total]
    result = {"benchmark": "kstar-visited", "indices": args.indices, "controllers": controllers, "ticks": args.ticks,
              "rows": rows, "target_exact_share": 1.0, "peak_rss_mib": round(self_peak_mib(), 1)}
    emit(result, rows, ("scenario", "states", "exact_share", "median_ms", "p99_ms", "max_ms", "candidates_max"),
         f"K* on visited states (indices {args.indices}, {', '.join(controllers)}); peak RSS {result['peak_rss_mib']} MiB",
         args.json)


if __name__ == "__main__":
    main()
