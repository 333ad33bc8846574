"""Ticks per second of the reference interpreter per official scenario and controller.

Usage:  python benchmarks/bench_run.py [--ticks 400] [--index 1000] [--controller greedy ...]
                                       [--baseline-python PY] [--reps 3] [--json]
One cell = one episode of ``run_episode`` (interpreter + controller, as ``agspec run``), timed in
CPU seconds of the process (time.process_time: on a shared machine wall time mostly measures the
other processes).  With a baseline (``--baseline-python`` or $AGSPEC_BASELINE_PYTHON: the Python of a
virtual environment holding the baseline release), every cell runs in fresh processes of both
builds, interleaved, ``--reps`` times each; the table shows the medians and their ratio, and the
peak RSS of each side's process (a 400-tick concurrency-hard episode is the memory figure).
Figures depend on the machine and its load; nothing here is asserted.
"""

from __future__ import annotations

import argparse
import json
import time

from _common import baseline_python, paired, ratio_table, self_peak_mib

from agspec.catalogue import OFFICIAL_SCENARIOS, load_scenario_bundle
from agspec.evaluate import run_episode
from agspec.ir.instance import make_instance

TARGET = 1.5  # issue: >= 1.5x the baseline's ticks/s on every official cell


def bench(scenario: str, controller: str, index: int, ticks: int) -> dict:
    sc, recipes, profile = load_scenario_bundle(scenario)
    inst = make_instance(sc, recipes, profile, index=index)
    t0 = time.process_time()
    result = run_episode(inst, controller, horizon=ticks)
    elapsed = time.process_time() - t0
    n = result.metrics["ticks"]
    return {"scenario": scenario, "controller": controller, "index": index, "ticks": n,
            "seconds": round(elapsed, 4), "ticks_per_second": round(n / elapsed, 1),
            "delivered": result.metrics["delivered"]}


def side_by_side(args, baseline: str | None, scenarios, controllers) -> None:
    rows = []
    for s in scenarios:
        for c in controllers:
            cell = ["--scenario", s, "--controller", c, "--ticks", str(args.ticks), "--index", str(args.index)]
            tps = paired(__file__, cell, args.reps, baseline, lambda r: r["runs"][0]["ticks_per_second"])
            rss = paired(__file__, cell, 1, baseline, lambda r: r["peak_rss_mib"]) if s == "concurrency-hard" else {}
            rows.append({"scenario": s, "controller": c, "baseline": tps.get("baseline"), "new": tps["new"],
                         "ratio": tps.get("ratio"), "ok": (tps["ratio"] >= TARGET) if baseline else None,
                         "rss_baseline": rss.get("baseline"), "rss_new": rss.get("new"),
                         "delivered": tps["last"]["new"]["runs"][0]["delivered"]})
    if args.json:
        print(json.dumps({"benchmark": "interpreter-ticks-per-second", "target_ratio": TARGET, "reps": args.reps,
                          "ticks": args.ticks, "index": args.index, "rows": rows}, indent=2))
        return
    ratio_table(f"reference interpreter ticks/s, medians of {args.reps} interleaved runs (index {args.index}, "
                f"{args.ticks} ticks); target ratio >= {TARGET}",
                rows, [("scenario", "scenario"), ("controller", "controller"), ("baseline", "baseline t/s"),
                       ("new", "new t/s"), ("ratio", "ratio"), ("ok", "ok"), ("rss_baseline", "baseline RSS MiB"),
                       ("rss_new", "new RSS MiB")])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--ticks", type=int, default=400)
    ap.add_argument("--index", type=int, default=1000)
    ap.add_argument("--controller", action="append", default=None)
    ap.add_argument("--scenario", action="append", default=None)
    ap.add_argument("--baseline-python", default=None, help="Python of the baseline release's venv")
    ap.add_argument("--reps", type=int, default=3, help="interleaved runs per side and cell (median)")
    ap.add_argument("--paired", action="store_true", help="fresh processes per cell even without a baseline")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    controllers = args.controller or ["greedy", "parallel-aware", "centralized", "random"]
    scenarios = args.scenario or list(OFFICIAL_SCENARIOS)
    baseline = baseline_python(args.baseline_python)
    if baseline or args.paired:
        side_by_side(args, baseline, scenarios, controllers)
        return
    rows = [bench(s, c, args.index, args.ticks) for s in scenarios for c in controllers]
    peak = self_peak_mib()
    if args.json:
        print(json.dumps({"runs": rows, "peak_rss_mib": round(peak, 1)}, indent=2))
        return
    ratio_table(f"reference interpreter speed (index {args.index}, {args.ticks} ticks; no baseline given)",
                rows, [("scenario", "scenario"), ("controller", "controller"), ("ticks", "ticks"),
                       ("seconds", "seconds"), ("ticks_per_second", "ticks/s"), ("delivered", "delivered")])
    print(f"peak RSS {peak:.0f} MiB")


if __name__ == "__main__":
    main()
