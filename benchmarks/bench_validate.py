"""Cold-CLI wall time of `agspec validate catalogue/*/*.ag` (median of N runs) and its peak memory.

Usage:  python benchmarks/bench_validate.py [--runs 5] [--json]
Target (issue 5): ≤ 0.5 s.  Each run is a fresh process, so imports are included.  Figures depend on the
machine; nothing here is asserted.
"""

from __future__ import annotations

import argparse
import statistics
from pathlib import Path

from _common import agspec_cmd, children_peak_mib, emit, timed_run

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    files = sorted(str(p.relative_to(ROOT)) for p in (ROOT / "catalogue").glob("*/*.ag"))
    cmd = [*agspec_cmd(), "validate", *files]
    times, codes = [], []
    for _ in range(args.runs):
        seconds, proc = timed_run(cmd, cwd=ROOT)
        times.append(seconds)
        codes.append(proc.returncode)
    # the interpreter's own start-up, for comparison: `python -c pass`
    import sys

    bare = statistics.median(timed_run([sys.executable, "-c", "pass"])[0] for _ in range(args.runs))
    row = {"command": "agspec validate catalogue/*/*.ag", "files": len(files), "runs": args.runs,
           "median_s": statistics.median(times), "min_s": min(times), "max_s": max(times),
           "python_startup_s": bare, "exit_codes": sorted(set(codes)), "peak_rss_mib": round(children_peak_mib(), 1),
           "target_s": 0.5}
    emit({"benchmark": "validate", **row}, [row],
         ("command", "files", "median_s", "min_s", "max_s", "python_startup_s", "peak_rss_mib"),
         "agspec validate, cold CLI", args.json)


if __name__ == "__main__":
    main()
