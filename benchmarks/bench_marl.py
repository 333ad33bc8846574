"""Env steps per second of the PettingZoo adapter (A-PZ-ENV) per official scenario.

Usage:  python benchmarks/bench_marl.py [--steps 400] [--index 1000] [--scenario S ...]
                                        [--baseline-python PY] [--reps 3] [--json]
Measures ``env.reset`` + ``env.step`` only, in CPU seconds of the process (time.process_time) — the interpreter's transition plus the A-OBS-VECTOR
encoding and masks of every agent; the actions come from a fixed rule over each mask, computed
outside the timer, so a policy's cost is not counted.  With a baseline (``--baseline-python`` or
$AGSPEC_BASELINE_PYTHON) each scenario runs in fresh processes of both builds, interleaved,
``--reps`` times each; the table shows the medians and their ratio.  Needs agspec[marl].
Nothing is asserted.
"""

from __future__ import annotations

import argparse
import json
import time

from pathlib import Path

from _common import baseline_python, paired, ratio_table, self_peak_mib

from agspec.catalogue import OFFICIAL_SCENARIOS

ROOT = Path(__file__).resolve().parents[1]
TARGET = 3.0  # issue: >= 3x the baseline's env steps/s on coalition-medium and concurrency-hard
TARGET_CELLS = ("coalition-medium", "concurrency-hard")


def _golden_rule():
    """The scripted action rule of the golden observation episodes (tests/golden/pettingzoo/record.py):
    the benchmark steps through exactly the episodes whose observation bytes the tests pin down."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("pz_golden_record", ROOT / "tests" / "golden" / "pettingzoo" / "record.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.scripted_actions


def bench(scenario: str, index: int, steps: int) -> dict:
    from agspec.pettingzoo import parallel_env

    env = parallel_env(scenario, index=index, max_cycles=steps)
    fixed_actions = _golden_rule()
    t0 = time.process_time()
    obs, _ = env.reset(seed=0)
    elapsed = time.process_time() - t0
    n = 0
    while env.agents:
        actions = fixed_actions(obs, n)
        t0 = time.process_time()
        obs, *_ = env.step(actions)
        elapsed += time.process_time() - t0
        n += 1
    robots = len(env.possible_agents)
    return {"scenario": scenario, "robots": robots, "steps": n, "seconds": round(elapsed, 3),
            "steps_per_second": round(n / elapsed, 1), "agent_steps_per_second": round(n * robots / elapsed)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--steps", type=int, default=400)
    ap.add_argument("--index", type=int, default=1000)
    ap.add_argument("--scenario", action="append", default=None)
    ap.add_argument("--baseline-python", default=None, help="Python of the baseline release's venv")
    ap.add_argument("--reps", type=int, default=3, help="interleaved runs per side and scenario (median)")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    scenarios = args.scenario or list(OFFICIAL_SCENARIOS)
    baseline = baseline_python(args.baseline_python)
    if baseline:
        rows = []
        for s in scenarios:
            cell = ["--scenario", s, "--steps", str(args.steps), "--index", str(args.index)]
            r = paired(__file__, cell, args.reps, baseline, lambda res: res["runs"][0]["steps_per_second"])
            rows.append({"scenario": s, "robots": r["last"]["new"]["runs"][0]["robots"], "baseline": r["baseline"],
                         "new": r["new"], "ratio": r["ratio"], "ok": r["ratio"] >= TARGET if s in TARGET_CELLS else None})
        if args.json:
            print(json.dumps({"benchmark": "pettingzoo-env-steps-per-second", "target_ratio": TARGET,
                              "target_cells": TARGET_CELLS, "reps": args.reps, "rows": rows}, indent=2))
            return
        ratio_table(f"PettingZoo env steps/s, medians of {args.reps} interleaved runs (index {args.index}, "
                    f"{args.steps} steps); target ratio >= {TARGET} on {', '.join(TARGET_CELLS)}",
                    rows, [("scenario", "scenario"), ("robots", "robots"), ("baseline", "baseline steps/s"),
                           ("new", "new steps/s"), ("ratio", "ratio"), ("ok", "ok")])
        return
    rows = [bench(s, args.index, args.steps) for s in scenarios]
    result = {"benchmark": "pettingzoo-adapter", "runs": rows, "peak_rss_mib": round(self_peak_mib(), 1)}
    if args.json:
        print(json.dumps(result, indent=2))
        return
    ratio_table(f"PettingZoo env steps/s (index {args.index}; no baseline given); peak RSS {result['peak_rss_mib']} MiB",
                rows, [("scenario", "scenario"), ("robots", "robots"), ("steps", "steps"), ("seconds", "seconds"),
                       ("steps_per_second", "steps/s"), ("agent_steps_per_second", "agent steps/s")])


if __name__ == "__main__":
    main()
