"""Long fuzz run of what a simulator sends (F-PROTOCOL-LINES, F-PROTOCOL-SHAPE, F-VALUES,
RES-GOLDEN-IDENTITY): mutated reply lines tried, and wrong verdicts found.

Usage:  python benchmarks/fuzz_replies.py [--examples 2000] [--seed 0] [--classes types,numbers,...]
                                          [--traces 0] [--json]

The bounded run is tests/test_reply_generator.py; this one draws many more mutations
(tests/reply_mutations.py: types, numbers, keys, encoding, whitespace, lines) of the replies to
start, load, reset and the first steps of a small greedy episode, runs each through the Python API
of ``agspec conform`` (report file included) live and with a warm golden cache
(tests/reply_judge.py), and counts the wrong verdicts: an exception, a ``harness`` failure, an
incomplete or schema-invalid report, a changed verdict for a mutation that keeps the reply, another
code than the one right code, a golden verdict other than the live one.  ``--traces N`` also re-spells
every number of a valid and of a violating trace N times each (F-VALUES) and counts the ``agspec
check`` verdicts that change.  The target is 0; nothing here is asserted.  Run it with another build's ``agspec`` first on ``PYTHONPATH`` to measure that
build (the mutations and the judge are this checkout's).
"""

from __future__ import annotations

import argparse
import collections
import random
import sys
import tempfile
import time
from pathlib import Path

from _common import emit

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from reply_judge import CLASSES, POSITIONS, judge, warm_cache  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--examples", type=int, default=2000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--classes", default=",".join(CLASSES))
    ap.add_argument("--show", type=int, default=3, help="wrong verdicts shown per class")
    ap.add_argument("--traces", type=int, default=0, help="re-spelt copies of a valid and a violating trace")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    classes = [c for c in args.classes.split(",") if c]
    rng = random.Random(args.seed)
    tried: collections.Counter = collections.Counter()
    found: collections.Counter = collections.Counter()
    kinds: collections.Counter = collections.Counter()
    shown: dict[str, list[str]] = collections.defaultdict(list)
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as cache:
        warm_cache(cache)
        for _ in range(args.examples):
            klass, target, seed = rng.choice(classes), rng.choice(POSITIONS), rng.randrange(2**32)
            mutation, wrong = judge(klass, target, seed, cache)
            tried[klass] += 1
            if wrong:
                found[klass] += 1
                for w in wrong:
                    kinds[w.split(":")[0]] += 1
                if len(shown[klass]) < args.show:
                    label = mutation.label if mutation else "?"
                    shown[klass].append(f"{target} {label[:60]!r} (seed {seed}): {wrong[0][:200]}")
    if args.traces:
        tried["trace-values"], found["trace-values"] = _traces(args.traces, rng, shown["trace-values"])
        classes = [*classes, "trace-values"]
    rows = [{"class": c, "tried": tried[c], "wrong": found[c]} for c in classes]
    rows.append({"class": "all", "tried": sum(tried.values()), "wrong": sum(found.values())})
    result = {"benchmark": "fuzz-replies", "examples": args.examples, "seed": args.seed,
              "seconds": round(time.perf_counter() - t0, 1), "rows": rows, "kinds": dict(kinds),
              "examples_wrong": dict(shown)}
    emit(result, rows, ["class", "tried", "wrong"], "mutated replies: tried and wrong verdicts", args.json)
    if not args.json:
        for klass, lines in shown.items():
            for line in lines:
                print(f"  {klass}: {line}")


def _traces(n: int, rng: random.Random, shown: list[str]) -> tuple[int, int]:
    """F-VALUES on traces: every number of a valid and of a violating trace re-spelt; the verdict of
    ``agspec check`` (its JSON record) must not change."""
    import json

    from click.testing import CliRunner

    from agspec.trace.check import check_file
    from agspec.cli.main import cli
    from reply_mutations import dump, respelt

    tried = wrong = 0
    with tempfile.TemporaryDirectory() as tmp:
        good = Path(tmp) / "good.jsonl"
        CliRunner().invoke(cli, ["run", "coalition-easy", "--horizon", "8", "--trace", str(good), "--observations",
                                 "--format", "json"], catch_exceptions=False)
        records = [json.loads(line) for line in good.read_text("utf-8").splitlines()]
        row = records[3]["state"]["shelves"][0]
        row[next(iter(row))] += 50  # a stock beyond the shelf capacity
        bad = Path(tmp) / "bad.jsonl"
        bad.write_text("".join(json.dumps(r) + "\n" for r in records), encoding="utf-8")
        for source in (good, bad):
            want = {k: v for k, v in check_file(None, str(source)).items() if k != "file"}
            lines = source.read_bytes().splitlines()
            for _ in range(n):
                seed = rng.randrange(2**32)
                mutated = Path(tmp) / "respelt.jsonl"
                share = random.Random(seed).choice([0.2, 1.0])
                mutated.write_bytes(b"\n".join(dump(respelt(json.loads(line), random.Random(seed), share))
                                                for line in lines) + b"\n")
                got = {k: v for k, v in check_file(None, str(mutated)).items() if k != "file"}
                tried += 1
                if got != want:
                    wrong += 1
                    if len(shown) < 3:
                        shown.append(f"{source.name} seed {seed}: ok {want.get('ok')} -> {got.get('ok')}; "
                                     f"{[v['message'][:80] for v in got.get('violations', [])][:1]}")
    return tried, wrong


if __name__ == "__main__":
    main()
