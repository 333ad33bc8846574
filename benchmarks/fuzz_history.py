"""Every combination of history faults against `agspec conform` (F-REPRO, F-CONFORM-NONDETERMINISM,
F-CONFORM-HISTORY): simulators tried and wrong verdicts found.

Usage:  python benchmarks/fuzz_history.py [--max-flags 3] [--json]

Runs the simulators of tests/fakes/scripted_sim.py for every combination of up to ``--max-flags`` of
the faults in tests/history_cases.py (state leaking across loads or resets, a coin per process, always
wrong, wrong only on a re-run, refusing a re-run) and judges each run: a deterministic simulator
called nondeterministic, a printed reproducer that does not fail the same way when replayed with
``agspec conform --replay``, a failure that needs earlier episodes not named history-dependent (or
one named so without any).  The target is 0; tests/test_conform_history.py is the bounded version.
"""

from __future__ import annotations

import argparse
import itertools
import sys
import tempfile
import time
from pathlib import Path

from _common import emit

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from history_cases import FLAGS, judge  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max-flags", type=int, default=3)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    rows, violations = [], []
    for n in range(1, args.max_flags + 1):
        for combo in itertools.combinations(FLAGS, n):
            flags = frozenset(combo)
            t0 = time.perf_counter()
            with tempfile.TemporaryDirectory() as tmp:
                wrong = judge(flags, Path(tmp))
            rows.append({"flags": "+".join(combo), "seconds": time.perf_counter() - t0, "wrong": len(wrong),
                         "first": wrong[0][:100] if wrong else None})
            violations += [f"{'+'.join(combo)}: {w}" for w in wrong]
            print(f"{'+'.join(combo):40} {'ok' if not wrong else wrong[0][:100]}", file=sys.stderr, flush=True)
    emit({"tried": len(rows), "violations": violations}, rows, ("flags", "seconds", "wrong", "first"),
         f"history faults: {len(rows)} simulators, {len(violations)} wrong verdicts", args.json)
    return 1 if violations else 0


if __name__ == "__main__":
    sys.exit(main())
