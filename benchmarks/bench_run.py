"""Ticks per second of the reference interpreter per official scenario and controller.

Usage:  python benchmarks/bench_run.py [--ticks 400] [--index 1000] [--controller greedy ...] [--json]
Prints a table (and JSON with --json).  Figures depend on the machine; nothing here is asserted.
"""

from __future__ import annotations

import argparse
import json
import resource
import time

from rich.console import Console
from rich.table import Table

from agspec.catalogue import OFFICIAL_SCENARIOS, load_scenario_bundle
from agspec.evaluate import run_episode
from agspec.ir.instance import make_instance


def bench(scenario: str, controller: str, index: int, ticks: int) -> dict:
    sc, recipes, profile = load_scenario_bundle(scenario)
    inst = make_instance(sc, recipes, profile, index=index)
    t0 = time.perf_counter()
    result = run_episode(inst, controller, horizon=ticks)
    elapsed = time.perf_counter() - t0
    n = result.metrics["ticks"]
    return {"scenario": scenario, "controller": controller, "index": index, "ticks": n,
            "seconds": round(elapsed, 4), "ticks_per_second": round(n / elapsed, 1),
            "delivered": result.metrics["delivered"]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--ticks", type=int, default=400)
    ap.add_argument("--index", type=int, default=1000)
    ap.add_argument("--controller", action="append", default=None)
    ap.add_argument("--scenario", action="append", default=None)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    controllers = args.controller or ["greedy", "parallel-aware", "centralized", "random"]
    scenarios = args.scenario or list(OFFICIAL_SCENARIOS)
    rows = [bench(s, c, args.index, args.ticks) for s in scenarios for c in controllers]
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    if args.json:
        print(json.dumps({"runs": rows, "peak_rss_mib": round(peak, 1)}, indent=2))
        return
    table = Table(title=f"reference interpreter speed (index {args.index}, {args.ticks} ticks)")
    for col in ("scenario", "controller", "ticks", "seconds", "ticks/s", "delivered"):
        table.add_column(col, justify="right" if col not in ("scenario", "controller") else "left")
    for r in rows:
        table.add_row(r["scenario"], r["controller"], str(r["ticks"]), f"{r['seconds']:.2f}",
                      f"{r['ticks_per_second']:.0f}", str(r["delivered"]))
    Console().print(table)
    Console().print(f"peak RSS {peak:.0f} MiB")


if __name__ == "__main__":
    main()
