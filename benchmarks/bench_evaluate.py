"""Wall time of the full evaluation: 4 controllers × 9 official scenarios × 50 final-test instances × 400 ticks.

Usage:  python benchmarks/bench_evaluate.py [-j 2] [--quick] [--baseline-python PY] [--json]
``--quick`` runs a subset (2 scenarios × 2 controllers × 2 instances, full 400 ticks) for CI smoke.
The run goes through the CLI (`agspec evaluate --format json`) in a fresh process, as a user would run it;
peak memory is the largest RSS among the CLI process and its (reaped) pool workers, from
getrusage(RUSAGE_CHILDREN).  Target: ≤ 60 s on 2 cores.  With a baseline (``--baseline-python`` or
$AGSPEC_BASELINE_PYTHON) the same command runs with the baseline release too, and the table shows
both wall times and their ratio (one run each: the full evaluation is long; wall time, since the
command's own pool is part of what is measured), and how many episodes got exactly the same metrics from
both builds (matched by scenario, controller and index) with the largest relative difference of a
metric value: since M-RATIO-FORMS this build computes ``blocked_ready_rate_material`` as (ready −
feasible) / ready, as the original release does, where the baseline computed 1 − feasible / ready,
so that value may differ in its last bits.
"""

from __future__ import annotations

import argparse
import json
import subprocess

from _common import ROOT, agspec_cmd, baseline_cli, baseline_python, children_peak_mib, emit, ratio_table, timed_run



def same_metrics(base: subprocess.CompletedProcess, new: subprocess.CompletedProcess) -> dict:
    """How many episodes got exactly the same metrics from both builds, matched by (scenario,
    controller, index), and the largest relative difference of a metric value (the JSON texts differ
    anyway: per-episode wall times, fields added since the baseline)."""
    if base.returncode != 0 or new.returncode != 0:
        return {"same_metrics": None, "runs_compared": 0, "max_rel_diff": None}
    runs = [{(r["scenario"], r["controller"], r["index"]): r.get("metrics") or {} for r in json.loads(p.stdout)["runs"]
             if not r.get("repeat")} for p in (base, new)]
    shared = runs[0].keys() & runs[1].keys()
    identical, largest = 0, 0.0
    for k in shared:
        a, b = runs[0][k], runs[1][k]
        identical += a == b
        for name in a.keys() & b.keys():
            x, y = a[name], b[name]
            if isinstance(x, (int, float)) and isinstance(y, (int, float)) and x != y:
                largest = max(largest, abs(x - y) / max(abs(x), abs(y)))
    return {"same_metrics": f"{identical}/{len(shared)}", "runs_compared": len(shared), "max_rel_diff": largest}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("-j", "--jobs", type=int, default=2)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--baseline-python", default=None, help="Python of the baseline release's venv")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    cmd = [*agspec_cmd(), "evaluate", "-j", str(args.jobs), "--format", "json"]
    if args.quick:
        cmd += ["--scenario", "coalition-medium", "--scenario", "flow-easy", "--controller", "greedy",
                "--controller", "random", "--indices", "1000-1001"]
        scope = "2 scenarios x 2 controllers x 2 instances x 400 ticks"
    else:
        scope = "9 scenarios x 4 controllers x 50 instances x 400 ticks"
    baseline = baseline_python(args.baseline_python)
    if baseline:
        base_cmd = [*baseline_cli(baseline), *cmd[len(agspec_cmd()):]]
        base_s, base_proc = timed_run(base_cmd, cwd=ROOT)
    seconds, proc = timed_run(cmd, cwd=ROOT)
    episodes = len(json.loads(proc.stdout)["runs"]) if proc.returncode == 0 else None
    row = {"scope": scope, "jobs": args.jobs, "episodes": episodes, "wall_s": seconds,
           "episodes_per_s": (episodes / seconds) if episodes else None, "exit_code": proc.returncode,
           "peak_rss_mib": round(children_peak_mib(), 1), "target_s": 60}
    if proc.returncode != 0:
        row["stderr"] = proc.stderr[-2000:]
    if baseline:
        row.update(baseline_wall_s=base_s, baseline_exit_code=base_proc.returncode, speedup=base_s / seconds,
                   **same_metrics(base_proc, proc))
        if args.json:
            print(json.dumps({"benchmark": "evaluate", **row}, indent=2))
            return
        ratio_table("full evaluation wall time, baseline and this build (same command)", [row],
                    [("scope", "scope"), ("jobs", "jobs"), ("episodes", "episodes"), ("baseline_wall_s", "baseline s"),
                     ("wall_s", "new s"), ("speedup", "speedup"), ("target_s", "target s"),
                     ("same_metrics", "identical metrics"), ("max_rel_diff", "largest rel. difference")])
        return
    emit({"benchmark": "evaluate", **row}, [row], ("scope", "jobs", "episodes", "wall_s", "episodes_per_s",
                                                   "peak_rss_mib"), "full evaluation wall time", args.json)


if __name__ == "__main__":
    main()
