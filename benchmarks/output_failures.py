"""The whole F-OUTPUT-FAILURES table: every output of every command × every failing target.

Usage:  python benchmarks/output_failures.py [--jobs 2] [--only NAME] [--json]

The same rows and judge as tests/test_output_failures.py (tests/output_failures.py). Prints one line
per row that is wrong and the figures: rows tried, rows wrong, rows skipped (e.g. without chattr).
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from output_failures import OUTPUTS, cases, make_inputs, run_case, train_outputs  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--only", default=None, help="rows whose output name contains this")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    outputs = OUTPUTS + (train_outputs() if importlib.util.find_spec("torch") else ())
    table = [(o, t) for o, t in cases(outputs) if args.only is None or args.only in o.name]
    started = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="agspec-outputs-") as tmp:
        base = Path(tmp)
        inputs = make_inputs(base)
        with ThreadPoolExecutor(args.jobs) as pool:
            outcomes = list(pool.map(lambda row: run_case(row[0], row[1], base, inputs), table))
    skipped = [o for o in outcomes if o.problems and o.problems[0].startswith("skip:")]
    wrong = [o for o in outcomes if not o.ok and o not in skipped]
    for o in wrong:
        print(f"WRONG {o.output.name} | {o.target}: exit {o.rc}; {'; '.join(o.problems)}")
    figures = {"rows": len(outcomes), "wrong": len(wrong), "skipped": len(skipped),
               "outputs": len({o.output.name for o in outcomes}), "seconds": round(time.perf_counter() - started, 1)}
    print(json.dumps(figures) if args.json else
          f"{figures['rows']} rows ({figures['outputs']} outputs), {figures['wrong']} wrong, "
          f"{figures['skipped']} skipped, {figures['seconds']} s")
    return 1 if wrong else 0


if __name__ == "__main__":
    raise SystemExit(main())
