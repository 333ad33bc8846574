"""F-VALUES / RES-INTEGRAL-ACTIONS, the full run: every reader of an action or an integer (a policy's
joint action, a process policy's reply, requests to ``agspec serve``, traces, reproducers, results
bundles, IR files, training records) given its documents with every number re-spelt (verdict unchanged) and with an action that
is not one (refused, located).  The generator is tests/value_readers.py; tests/test_value_rule.py
runs a bounded share.

    python benchmarks/fuzz_values.py [--n 200] [--seed 0]

Figures (``--n 200 --seed 0``, 1431 cases; before: main at 5f8db07, run with PYTHONPATH at its tree):

    reader           tried  wrong before -> after
    agspec serve       205       205     ->   0   (2.0 refused as bad_actions; a respelt instance failed to load)
    bundle             205       174     ->   0   (integers read as floats)
    check_joint        205       200     ->   0   (0.0 is bad_action)
    process policy       6         1     ->   0   (a policy writing 2.0 got bad_action)
    reproducer         205       205     ->   0   (2.0 refused; refusals not located)
    trace              205         0     ->   0   (already read through the shape)
    IR file            200       200     ->   0   (a radius of 1.0 refused by the interpreter)
    training record    200       200     ->   0   (counts read as floats)
    total             1431      1185     ->   0
"""

from __future__ import annotations

import argparse
import collections
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from value_readers import Readers, cases  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=200, help="respellings of each reader's documents")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    start = time.perf_counter()
    tried, wrong = collections.Counter(), collections.Counter()
    examples: dict[str, str] = {}
    with tempfile.TemporaryDirectory() as tmp:
        readers = Readers(Path(tmp), ROOT / "tests" / "fakes")
        for reader, label, ok in cases(readers, args.n, args.seed):
            tried[reader] += 1
            if not ok:
                wrong[reader] += 1
                examples.setdefault(reader, label)
    for reader in sorted(tried):
        print(f"{reader:16} tried {tried[reader]:5}  wrong {wrong[reader]:5}  {examples.get(reader, '')}")
    print(f"total tried {sum(tried.values())}, wrong {sum(wrong.values())} ({time.perf_counter() - start:.1f} s)")
    return 1 if wrong else 0


if __name__ == "__main__":
    sys.exit(main())
