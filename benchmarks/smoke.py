"""CI smoke run of the benchmarks: quick versions of every script, printing figures (never asserting times).

Runs in well under 30 s on 2 cores.  A script that fails makes the smoke run fail (exit status), so
the scripts themselves stay runnable; the figures are informative only.
"""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent

QUICK = [
    ["bench_run.py", "--ticks", "40", "--scenario", "coalition-medium", "--scenario", "flow-hard",
     "--controller", "greedy", "--controller", "centralized"],
    ["bench_evaluate.py", "--quick", "-j", "2"],
    ["bench_validate.py", "--runs", "1"],
    ["bench_conform.py", "--quick"],
    ["bench_kstar_visited.py", "--indices", "1000", "--ticks", "30", "--scenario", "coalition-medium",
     "--controller", "greedy"],
    ["bench_marl.py", "--steps", "20", "--scenario", "coalition-medium"],
    ["bench_throughput.py", "--steps", "20", "--reps", "1", "--scenario", "coalition-medium", "--controller", "greedy"],
    ["bench_episodes.py", "--controller", "greedy", "--floor"],
    ["bench_step_parts.py", "--steps", "20", "--episodes", "1", "--reps", "1", "--scenario", "coalition-medium"],
]

if __name__ == "__main__":
    status = 0
    t0 = time.perf_counter()
    for args in QUICK:
        print(f"$ python benchmarks/{' '.join(args)}", flush=True)
        rc = subprocess.call([sys.executable, str(HERE / args[0]), *args[1:]])
        status = status or rc
    print(f"smoke benchmarks: {time.perf_counter() - t0:.1f} s")
    sys.exit(status)
