"""Wall time of the full evaluation: 4 controllers × 9 official scenarios × 50 final-test instances × 400 ticks.

Usage:  python benchmarks/bench_evaluate.py [-j 2] [--quick] [--json]
``--quick`` runs a subset (2 scenarios × 2 controllers × 2 instances, full 400 ticks) for CI smoke.
The run goes through the CLI (`agspec evaluate --format json`) in a fresh process, as a user would run it;
peak memory is the largest RSS among the CLI process and its (reaped) pool workers, from
getrusage(RUSAGE_CHILDREN).  Target (issue 5): ≤ 10 minutes on 2 cores.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from _common import agspec_cmd, children_peak_mib, emit, timed_run

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("-j", "--jobs", type=int, default=2)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    cmd = [*agspec_cmd(), "evaluate", "-j", str(args.jobs), "--format", "json"]
    if args.quick:
        cmd += ["--scenario", "coalition-medium", "--scenario", "flow-easy", "--controller", "greedy",
                "--controller", "random", "--indices", "1000-1001"]
        scope = "2 scenarios x 2 controllers x 2 instances x 400 ticks"
    else:
        scope = "9 scenarios x 4 controllers x 50 instances x 400 ticks"
    seconds, proc = timed_run(cmd, cwd=ROOT)
    episodes = len(json.loads(proc.stdout)["runs"]) if proc.returncode == 0 else None
    row = {"scope": scope, "jobs": args.jobs, "episodes": episodes, "wall_s": seconds,
           "episodes_per_s": (episodes / seconds) if episodes else None, "exit_code": proc.returncode,
           "peak_rss_mib": round(children_peak_mib(), 1), "target_s": 600}
    if proc.returncode != 0:
        row["stderr"] = proc.stderr[-2000:]
    emit({"benchmark": "evaluate", **row}, [row], ("scope", "jobs", "episodes", "wall_s", "episodes_per_s",
                                                   "peak_rss_mib"), "full evaluation wall time", args.json)


if __name__ == "__main__":
    main()
