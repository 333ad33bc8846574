"""CPU seconds of the paper evaluation's episodes, one instance per scenario: a quick stand-in for
bench_evaluate.py that can be compared with the baseline in a few minutes.

Usage:  python benchmarks/bench_episodes.py [--index 1000] [--controller C ...] [--baseline-python PY]
                                            [--reps 3] [--floor] [--json]
For each reference controller, the nine official scenarios at suite index ``--index`` run to their
horizon through ``agspec.evaluate.run_episode`` (what every worker of ``agspec evaluate`` does per
episode), timed in CPU seconds of the process (instance generation excluded).  ``projected 1,800
episodes on 2 cores`` multiplies the four controllers' sum by the 50 final-test instances and
halves it: the whole evaluation's wall time if every instance cost what this one does (the target is
60 s).  With a baseline (``--baseline-python`` or $AGSPEC_BASELINE_PYTHON) each controller runs in
fresh processes of both builds, interleaved, ``--reps`` times; the table shows the medians and their
ratio.  Nothing is asserted.

``--floor`` adds this build's floor: the same episodes' joint actions (recorded in an untimed run)
replayed through ``Simulator.step`` alone — the transition and each epoch's decision snapshot
(candidates, options, masks), without observation records and without a controller.  Its projection
is what the evaluation would take if observing and deciding cost nothing: when that is above the
target, no work on the controllers or the observations can reach it, only a faster transition.
"""

from __future__ import annotations

import argparse
import json
import sys
import time

from _common import baseline_python, paired, ratio_table, run_json

CONTROLLERS = ("random", "greedy", "parallel-aware", "centralized")
INSTANCES, CORES, TARGET_S = 50, 2, 60


def _instances(index: int) -> list:
    # the baseline release has these, so the same worker runs under both builds
    from agspec.catalogue import OFFICIAL_SCENARIOS, load_scenario_bundle
    from agspec.ir.instance import make_instance

    return [make_instance(*load_scenario_bundle(s), index=index) for s in OFFICIAL_SCENARIOS]


def bench(controller: str, index: int) -> dict:
    from agspec.evaluate import run_episode

    instances = _instances(index)
    started = time.process_time()
    for instance in instances:
        run_episode(instance, controller)
    return {"controller": controller, "episodes": len(instances), "cpu_s": round(time.process_time() - started, 3)}


class _Actions:
    """A trace sink of ``run_episode`` that keeps only the joint actions applied, tick by tick."""

    def __init__(self) -> None:
        self.joints: list[dict[str, int]] = []

    def header(self, **_: object) -> None:
        pass

    def tick(self, *, actions: dict[str, int], **_: object) -> None:
        self.joints.append(dict(actions))

    def footer(self, **_: object) -> None:
        pass


def floor(controller: str, index: int) -> dict:
    """CPU seconds of the transition alone on the episodes of ``bench`` (this build only)."""
    from agspec.evaluate import run_episode
    from agspec.interp.tick import Simulator

    instances = _instances(index)
    streams = []
    for instance in instances:  # untimed: the joint actions the controller chose
        sink = _Actions()
        run_episode(instance, controller, trace=sink)
        streams.append(sink.joints)
    started = time.process_time()
    for instance, joints in zip(instances, streams):
        sim = Simulator(instance)
        for joint in joints:
            sim.step(joint)
    return {"controller": controller, "episodes": len(instances),
            "transition_cpu_s": round(time.process_time() - started, 3)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--index", type=int, default=1000)
    ap.add_argument("--controller", action="append", choices=CONTROLLERS, default=None)
    ap.add_argument("--baseline-python", default=None, help="Python of the baseline release's venv")
    ap.add_argument("--reps", type=int, default=3, help="interleaved runs per side and controller (median)")
    ap.add_argument("--floor", action="store_true",
                    help="also measure this build's transition alone (recorded actions replayed)")
    ap.add_argument("--floor-worker", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    controllers = args.controller or list(CONTROLLERS)
    if args.floor_worker:
        print(json.dumps({"benchmark": "episodes-floor", "rows": [floor(c, args.index) for c in controllers]}))
        return
    baseline = baseline_python(args.baseline_python)
    if args.json and not baseline and not args.floor:  # the worker of the paired runs: one side
        print(json.dumps({"benchmark": "episodes", "index": args.index,
                          "rows": [bench(c, args.index) for c in controllers]}, indent=2))
        return
    rows = []
    for c in controllers:
        if baseline:
            r = paired(__file__, ["--controller", c, "--index", str(args.index)], args.reps, baseline,
                       lambda res: res["rows"][0]["cpu_s"])
            rows.append({"controller": c, "baseline_s": r["baseline"], "new_s": r["new"],
                         "speedup": r["baseline"] / r["new"] if r["new"] else None})
        else:
            rows.append({"controller": c, "baseline_s": None, "new_s": bench(c, args.index)["cpu_s"], "speedup": None})
    if args.floor:
        measured = run_json(sys.executable, __file__,
                            ["--floor-worker", "--index", str(args.index), *(a for c in controllers for a in ("--controller", c))])
        for row, f in zip(rows, measured["rows"]):
            row["transition_s"] = f["transition_cpu_s"]
    total: dict = {"controller": "all"}
    for k in ("baseline_s", "new_s", "transition_s"):
        values = [r.get(k) for r in rows]
        total[k] = sum(values) if all(v is not None for v in values) else None
    total["speedup"] = total["baseline_s"] / total["new_s"] if total["baseline_s"] else None
    rows.append(total)
    every = set(controllers) == set(CONTROLLERS)  # the projection needs all four controllers' episodes
    for row in rows:
        for k in ("new_s", "transition_s"):
            value = row.get(k)
            row[k.replace("_s", "_projected_s")] = (round(value * INSTANCES / CORES, 1)
                                                   if row["controller"] == "all" and every and value is not None else None)
    if args.json:
        print(json.dumps({"benchmark": "episodes", "index": args.index, "reps": args.reps, "target_s": TARGET_S,
                          "rows": rows}, indent=2))
        return
    columns = [("controller", "controller")]
    if baseline:
        columns += [("baseline_s", "baseline CPU s"), ("new_s", "new CPU s"), ("speedup", "speedup")]
    else:
        columns += [("new_s", "CPU s")]
    columns += [("new_projected_s", "projected s")]
    if args.floor:
        columns += [("transition_s", "transition alone CPU s"), ("transition_projected_s", "its projection s")]
    how = f"medians of {args.reps} interleaved runs" if baseline else "one run"
    ratio_table(f"CPU seconds of the nine official scenarios per controller, {how} (index {args.index}); "
                f"projected 1,800 episodes on {CORES} cores, target {TARGET_S} s", rows, columns)

if __name__ == "__main__":
    main()
