"""Long run of the failure-report generators (F-EVENT-DIFF, F-CONFORM-KNOWN, RES-ASSERTION-LEVEL):
inputs tried and misreports found, per class.

Usage:  python benchmarks/fuzz_reports.py [--examples 2000] [--levels 300] [--classes events,known,levels] [--json]

The bounded run is tests/test_conform_reports.py; this one uses the same strategies and oracles
(tests/report_edits.py) with many more examples:

* events — one edit (drop, insert, swap, value change) of a real reply's event list: is the edit
  named, and nothing else?
* known — the DIV-RELEASE-STOCK failure over drawn parts, with or without one more perturbation:
  is it named exactly when nothing else differs?
* levels — a suite case against the reference declaring a drawn subset of the parts: does it pass,
  with every assertion on a declared part checked, and is it skipped only when none is?

The oracles read only what every build exposes, so running this file with another build first on
``PYTHONPATH`` (``git archive REV | tar -x -C /tmp/old``, then ``PYTHONPATH=/tmp/old``) counts that
build's misreports.  The target is 0; nothing here is asserted.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from _common import emit

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from hypothesis import HealthCheck, given, settings  # noqa: E402

import report_edits as R  # noqa: E402


def fuzz(strategy, check, examples: int) -> tuple[int, list[str]]:
    tried, found = 0, []

    @settings(max_examples=examples, deadline=None, database=None, suppress_health_check=list(HealthCheck))
    @given(strategy)
    def prop(x) -> None:
        nonlocal tried
        tried += 1
        problem = check(x)
        if problem:
            found.append(problem)

    prop()
    return tried, found


def check_events(x):
    from agspec.conform.lockstep.compare import compare_reply

    expected, actual, edit = x
    return R.misnamed_edit(edit, compare_reply(0, {"events": expected}, {"events": actual}, ["events"]))


def check_known(x):
    return R.misnamed_stock(*x)


def check_levels(x):
    case, parts = x
    return R.misjudged_level(case, parts, R.run_level(case, parts))


CLASSES = {"events": (R.event_edits, check_events), "known": (R.stock_failures, check_known),
           "levels": (R.level_runs, check_levels)}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--examples", type=int, default=2000, help="examples per class (events, known)")
    parser.add_argument("--levels", type=int, default=300, help="examples of the levels class (each runs a case)")
    parser.add_argument("--classes", default="events,known,levels")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    import agspec

    rows = []
    for name in [c.strip() for c in args.classes.split(",") if c.strip()]:
        strategy, check = CLASSES[name]
        t0 = time.perf_counter()
        tried, found = fuzz(strategy(), check, args.levels if name == "levels" else args.examples)
        rows.append({"class": name, "tried": tried, "misreports": len(found), "seconds": round(time.perf_counter() - t0, 1),
                     "first": found[0] if found else ""})
    for r in rows:
        r["first"] = r["first"][:100]
    emit({"agspec": str(Path(agspec.__file__).parent), "classes": rows}, rows,
         ["class", "tried", "misreports", "seconds", "first"], f"failure-report misreports (agspec at "
         f"{Path(agspec.__file__).parent})", args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
