"""CPU seconds of the paper evaluation's episodes, one instance per scenario: a quick stand-in for
bench_evaluate.py that can be compared with the baseline in a few minutes.

Usage:  python benchmarks/bench_episodes.py [--index 1000] [--controller C ...] [--baseline-python PY]
                                            [--reps 3] [--json]
For each reference controller, the nine official scenarios at suite index ``--index`` run to their
horizon through ``agspec.evaluate.run_episode`` (what every worker of ``agspec evaluate`` does per
episode), timed in CPU seconds of the process (instance generation excluded).  ``projected 1,800
episodes on 2 cores`` multiplies the four controllers' sum by the 50 final-test instances and
halves it: the whole evaluation's wall time if every instance cost what this one does (the target is
60 s).  With a baseline (``--baseline-python`` or $AGSPEC_BASELINE_PYTHON) each controller runs in
fresh processes of both builds, interleaved, ``--reps`` times; the table shows the medians and their
ratio.  Nothing is asserted.
"""

from __future__ import annotations

import argparse
import json
import time

from _common import baseline_python, paired, ratio_table

CONTROLLERS = ("random", "greedy", "parallel-aware", "centralized")
INSTANCES, CORES, TARGET_S = 50, 2, 60


def bench(controller: str, index: int) -> dict:
    # the baseline release has these three, so the same worker runs under both builds
    from agspec.catalogue import OFFICIAL_SCENARIOS, load_scenario_bundle
    from agspec.evaluate import run_episode
    from agspec.ir.instance import make_instance

    instances = [make_instance(*load_scenario_bundle(s), index=index) for s in OFFICIAL_SCENARIOS]
    started = time.process_time()
    for instance in instances:
        run_episode(instance, controller)
    return {"controller": controller, "episodes": len(instances), "cpu_s": round(time.process_time() - started, 3)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--index", type=int, default=1000)
    ap.add_argument("--controller", action="append", choices=CONTROLLERS, default=None)
    ap.add_argument("--baseline-python", default=None, help="Python of the baseline release's venv")
    ap.add_argument("--reps", type=int, default=3, help="interleaved runs per side and controller (median)")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    controllers = args.controller or list(CONTROLLERS)
    baseline = baseline_python(args.baseline_python)
    if not baseline:  # one side: the worker mode of the paired runs, and a plain report
        rows = [bench(c, args.index) for c in controllers]
        if args.json:
            print(json.dumps({"benchmark": "episodes", "index": args.index, "rows": rows}, indent=2))
            return
        ratio_table(f"CPU seconds of the nine official scenarios per controller (index {args.index})", rows,
                    [("controller", "controller"), ("episodes", "episodes"), ("cpu_s", "CPU s")])
        return
    rows = []
    for c in controllers:
        r = paired(__file__, ["--controller", c, "--index", str(args.index)], args.reps, baseline,
                   lambda res: res["rows"][0]["cpu_s"])
        rows.append({"controller": c, "baseline_s": r["baseline"], "new_s": r["new"],
                     "speedup": r["baseline"] / r["new"] if r["new"] else None})
    total = {"controller": "all", "baseline_s": sum(r["baseline_s"] for r in rows),
             "new_s": sum(r["new_s"] for r in rows)}
    total["speedup"] = total["baseline_s"] / total["new_s"]
    rows.append(total)
    every = set(controllers) == set(CONTROLLERS)  # the projection needs all four controllers' episodes
    for row in rows:
        row["projected_s"] = round(row["new_s"] * INSTANCES / CORES, 1) if row["controller"] == "all" and every else None
    if args.json:
        print(json.dumps({"benchmark": "episodes", "index": args.index, "reps": args.reps, "target_s": TARGET_S,
                          "rows": rows}, indent=2))
        return
    ratio_table(f"CPU seconds of the nine official scenarios per controller, medians of {args.reps} interleaved "
                f"runs (index {args.index}); projected 1,800 episodes on {CORES} cores, target {TARGET_S} s", rows,
                [("controller", "controller"), ("baseline_s", "baseline CPU s"), ("new_s", "new CPU s"),
                 ("speedup", "speedup"), ("projected_s", "projected s (new)")])


if __name__ == "__main__":
    main()
