"""Conformance overhead: `agspec conform --impl reference` over plain runs of the same episodes.

Usage:  python benchmarks/bench_conform.py [--ticks 400] [--episodes 1] [--impl "agspec serve"] [--quick] [--json]
        python benchmarks/bench_conform.py --full-suite [--baseline-python PY] [--json]

Both sides are cold processes, so start-up is included on both:
  conform:  agspec conform --impl reference --no-suite --episodes E --ticks T
            (F-CONFORM-EPISODES: each official scenario at index 0, greedy plus E-1 seeded random)
  plain:    the same episodes through agspec.evaluate.run_episode (what `agspec run` does), one process.
ratio = conform / plain (targets: ≤ 1.5 for the reference in process, ≤ 2 for `--impl "agspec serve"`,
whose per-tick protocol cost — encode, pipe, decode — is then part of the figure).  Peak memory of each is the child's max RSS.
If `agspec conform` does not exist in this build, the benchmark says so and exits 0.
``--full-suite`` instead measures one plain `agspec conform --impl reference` (suite and episodes) —
wall time and peak RSS — for this build and, with a baseline (``--baseline-python`` or
$AGSPEC_BASELINE_PYTHON), for the baseline release too.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

from _common import agspec_cmd, baseline_python, emit, ratio_table, timed_run

ROOT = Path(__file__).resolve().parents[1]

PLAIN = """
import sys
from agspec.catalogue import OFFICIAL_SCENARIOS, load_scenario_bundle
from agspec.evaluate import run_episode
from agspec.ir.instance import make_instance
ticks, episodes = int(sys.argv[1]), int(sys.argv[2])
scenarios = sys.argv[3:] or OFFICIAL_SCENARIOS
for name in scenarios:
    inst = make_instance(*load_scenario_bundle(name), index=0)
    run_episode(inst, "greedy", horizon=ticks)
    for k in range(1, episodes):
        run_episode(inst, "random", horizon=ticks, seed=k)
"""


def _measure(cmd: list[str]) -> tuple[float, subprocess.CompletedProcess, float]:
    """Wall time and the peak RSS (MiB) of this one child, from os.wait4's own rusage."""
    import os
    import tempfile
    import time

    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
        t0 = time.perf_counter()
        proc = subprocess.Popen(cmd, cwd=ROOT, stdout=out, stderr=err, text=True)
        _, status, usage = os.wait4(proc.pid, 0)
        seconds = time.perf_counter() - t0
        proc.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        done = subprocess.CompletedProcess(cmd, proc.returncode, out.read(), err.read())
    return seconds, done, usage.ru_maxrss / 1024


def full_suite(args) -> None:
    conform = ["conform", "--impl", "reference", "--format", "json"]
    sides = [("new", [*agspec_cmd(), *conform])]
    baseline = baseline_python(args.baseline_python)
    if baseline:
        sides.insert(0, ("baseline", [baseline, "-c", "from agspec.cli.main import main; main()", *conform]))
    rows = []
    for side, cmd in sides:
        seconds, proc, peak = _measure(cmd)
        rows.append({"side": side, "wall_s": seconds, "exit_code": proc.returncode, "peak_rss_mib": peak})
    if args.json:
        print(json.dumps({"benchmark": "conform-full-suite", "rows": rows}, indent=2))
        return
    ratio_table("agspec conform --impl reference (full suite): wall time and peak RSS", rows,
                [("side", "build"), ("wall_s", "wall s"), ("exit_code", "exit"), ("peak_rss_mib", "peak RSS MiB")])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--ticks", type=int, default=400)
    ap.add_argument("--episodes", type=int, default=1)
    ap.add_argument("--scenario", action="append", default=None)
    ap.add_argument("--impl", default="reference", help='implementation under test, e.g. "agspec serve"')
    ap.add_argument("--quick", action="store_true", help="2 scenarios x 40 ticks (CI smoke)")
    ap.add_argument("--full-suite", action="store_true", help="peak RSS and wall time of a default conform run")
    ap.add_argument("--baseline-python", default=None, help="Python of the baseline release's venv")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    if args.quick:
        args.ticks, args.scenario = 40, args.scenario or ["coalition-medium", "flow-easy"]
    probe = subprocess.run([*agspec_cmd(), "conform", "--help"], capture_output=True, text=True)
    if probe.returncode != 0:
        print("agspec conform is not available in this build; conformance overhead not measured")
        return
    if args.full_suite:
        full_suite(args)
        return
    select = []
    if args.scenario:
        select = ["-k", " or ".join(f"e-{s}-*" for s in args.scenario)]
    conform_cmd = [*agspec_cmd(), "conform", "--impl", args.impl, "--no-suite", "--episodes", str(args.episodes),
                   "--ticks", str(args.ticks), "--format", "json", *select]
    plain_cmd = [sys.executable, "-c", PLAIN, str(args.ticks), str(args.episodes), *(args.scenario or [])]
    plain_s, plain, plain_peak = _measure(plain_cmd)
    conform_s, conform, conform_peak = _measure(conform_cmd)
    rows = [
        {"side": "plain run_episode", "wall_s": plain_s, "exit_code": plain.returncode, "peak_rss_mib": plain_peak},
        {"side": f"agspec conform --impl {args.impl}", "wall_s": conform_s, "exit_code": conform.returncode,
         "peak_rss_mib": conform_peak},
    ]
    result = {"benchmark": "conform", "ticks": args.ticks, "episodes_per_scenario": args.episodes,
              "scenarios": args.scenario or "all nine official", "plain_s": plain_s, "conform_s": conform_s,
              "impl": args.impl, "ratio": conform_s / plain_s, "overhead": conform_s / plain_s - 1,
              "target_ratio": 2.0 if args.impl != "reference" else 1.5,
              "rows": rows}
    if conform.returncode != 0:
        result["conform_stderr"] = conform.stderr[-2000:]
    emit(result, rows, ("side", "wall_s", "exit_code", "peak_rss_mib"),
         f"conform --impl {args.impl}: {conform_s / plain_s:.2f}x the wall time of the plain runs", args.json)


if __name__ == "__main__":
    main()
