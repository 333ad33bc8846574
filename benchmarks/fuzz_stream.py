"""A simulator's way of reading its input gets one verdict on every path (RES-STREAM-INPUT,
RES-GOLDEN-IDENTITY): reading strategies tried, verdicts that differ between live and golden runs.

Usage:  python benchmarks/fuzz_stream.py [--json]

Every strategy of tests/fakes/stream_sim.py (line by line, byte by byte to a newline, the first line of
each chunk, fixed-size reads of several sizes) runs against the harness live and with a warm golden
cache (tests/stream_cases.py).  The target is 0; tests/test_stream_input.py is the bounded version.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

from _common import emit

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from stream_cases import judge  # noqa: E402

STRATEGIES = ("lines", "newline", "chunk", "fixed-64", "fixed-512", "fixed-4096", "fixed-65536")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    rows, violations = [], []
    for strategy in STRATEGIES:
        with tempfile.TemporaryDirectory() as tmp:
            wrong = judge(strategy, Path(tmp))
        rows.append({"strategy": strategy, "wrong": "; ".join(wrong) or None})
        violations += [f"{strategy}: {w}" for w in wrong]
        print(f"{strategy:12} {'; '.join(wrong) or 'ok'}", file=sys.stderr, flush=True)
    emit({"tried": len(rows), "violations": violations}, rows, ("strategy", "wrong"),
         f"stream input: {len(rows)} reading strategies, {len(violations)} wrong", args.json)
    return 1 if violations else 0


if __name__ == "__main__":
    sys.exit(main())
