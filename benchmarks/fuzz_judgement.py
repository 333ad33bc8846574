"""``agspec conform`` and ``agspec diff`` judge the same simulator the same way (F-CONFORM-NONDETERMINISM,
F-CONFORM-HISTORY): simulators tried, comparable pairs, disagreements found.

Usage:  python benchmarks/fuzz_judgement.py [--max-flags 2] [--json]

Every simulator of tests/judgement_cases.py (the history faults of tests/history_cases.py, up to
``--max-flags`` at once, and wrappers of ``agspec serve`` wrong in every N-th reply of their process) runs
through both commands.  The target is 0 wrong; tests/test_judgement_agreement.py is the bounded version.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

from _common import emit

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from judgement_cases import judge, simulators  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max-flags", type=int, default=2)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    rows, violations, comparable = [], [], 0
    for name, what in simulators(args.max_flags):
        t0 = time.perf_counter()
        with tempfile.TemporaryDirectory() as tmp:
            wrong, both = judge(what, Path(tmp))
        comparable += both
        rows.append({"simulator": name, "seconds": round(time.perf_counter() - t0, 1), "comparable": both,
                     "wrong": len(wrong), "first": wrong[0][:100] if wrong else None})
        violations += [f"{name}: {w}" for w in wrong]
        print(f"{name:32} {'ok' if not wrong else wrong[0][:100]}{'' if both else ' (not comparable)'}",
              file=sys.stderr, flush=True)
    emit({"tried": len(rows), "comparable": comparable, "violations": violations}, rows,
         ("simulator", "seconds", "comparable", "wrong", "first"),
         f"judgement: {len(rows)} simulators, {comparable} seen failing by both commands, "
         f"{len(violations)} wrong verdicts", args.json)
    return 1 if violations else 0


if __name__ == "__main__":
    sys.exit(main())
