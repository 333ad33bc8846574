"""Peak memory of `agspec validate` on valid instance files of growing size (F-LIMITS-POSITIONS).

Usage:  python benchmarks/bench_memory.py [--horizons 10000,50000,100000,200000] [--json]

Each instance is a realization of coalition-medium with a longer horizon (more products), written as
JSON; each validation is a fresh process whose own peak RSS is read back. The figures are the
least-squares line through (file MB, peak MiB): the slope (MiB of memory per MB of input: the
constant of the linear growth) and the intercept (the interpreter and agspec's imports). Nothing
is asserted; the target is a slope of at most 20 MiB per MB (the positional JSON parse, kept for
documents up to 256 KiB, costs about 200).
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _common import emit

# runs the CLI in this process and reports its own peak RSS (KiB on Linux) on stderr's last line
PROBE = ("import resource, sys\n"
         "from agspec.cli.main import main\n"
         "try:\n    main(sys.argv[1:])\n"
         "finally:\n    print('PEAK', resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, file=sys.stderr)\n")


def instance_file(horizon: int, where: Path) -> Path:
    from agspec.catalogue import load_scenario_bundle
    from agspec.ir.instance import make_instance

    scenario, recipes, profile = load_scenario_bundle("coalition-medium")
    scenario = {**scenario, "evaluation": {**scenario["evaluation"], "horizon": horizon}}
    path = where / f"coalition-medium-h{horizon}.json"
    path.write_text(json.dumps(make_instance(scenario, recipes, profile, index=0)), encoding="utf-8")
    return path


def measure(path: Path) -> tuple[float, float, int]:
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", PROBE, "validate", str(path)], capture_output=True, text=True)
    seconds = time.perf_counter() - t0
    peak_kib = int(proc.stderr.rsplit("PEAK", 1)[1].split()[0])
    return seconds, peak_kib / 1024, proc.returncode


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--horizons", default="10000,50000,100000,200000")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for horizon in (int(h) for h in args.horizons.split(",")):
            path = instance_file(horizon, Path(tmp))
            seconds, peak, code = measure(path)
            rows.append({"horizon": horizon, "file_mb": path.stat().st_size / 1e6, "peak_mib": peak,
                         "seconds": seconds, "exit_code": code})
    fit = statistics.linear_regression([r["file_mb"] for r in rows], [r["peak_mib"] for r in rows])
    result = {"benchmark": "memory", "command": "agspec validate INSTANCE.json", "rows": rows,
              "slope_mib_per_mb": fit.slope, "intercept_mib": fit.intercept, "target_slope_mib_per_mb": 20}
    emit(result, rows, ("horizon", "file_mb", "peak_mib", "seconds", "exit_code"),
         f"peak memory of validate: {fit.slope:.1f} MiB per MB + {fit.intercept:.0f} MiB", args.json)


if __name__ == "__main__":
    main()
