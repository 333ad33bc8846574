"""CI smoke run of the benchmarks: a few short episodes, printing figures (never asserting times)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent

if __name__ == "__main__":
    cmd = [sys.executable, str(HERE / "bench_run.py"), "--ticks", "40", "--scenario", "coalition-medium",
           "--scenario", "flow-hard", "--controller", "greedy", "--controller", "centralized"]
    sys.exit(subprocess.call(cmd))
