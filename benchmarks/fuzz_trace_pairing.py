"""Long run of the lying-trace generator (F-TRACE-PAIRING): reference traces, mutants, wrong passes.

Usage:  python benchmarks/fuzz_trace_pairing.py [--horizon 400] [--mutants 60] [--seed 0]
                                                 [--scenarios a,b] [--controllers greedy,random] [--json]

Sources: every catalogue scenario under every reference controller (up to ``--horizon`` ticks), every
instance of conformance/instances/ under greedy and under seeded random actions with 20 % masked or
out-of-range ones, and the traces of conformance/traces/. Each source must pass `agspec check`
(the checker is not over-eager: a failing source is reported as ``false alarms``); then
``--mutants`` lying traces are drawn from it (tests/trace_lies.py: an event dropped, doubled,
delayed, advanced or altered, or a state changed without its event, the footer rewritten to match)
and each must fail. The target is 0 wrong passes and 0 false alarms; nothing here is asserted.
The bounded run is tests/test_trace_pairing.py.
"""

from __future__ import annotations

import argparse
import collections
import json
import random
import sys
import time

from _common import ROOT, emit

sys.path.insert(0, str(ROOT / "tests"))

from trace_lies import judge, mutants, reference_trace  # noqa: E402

from agspec.catalogue import load_instance  # noqa: E402
from agspec.controllers import CONTROLLERS  # noqa: E402
from agspec.formats.trace import read_records  # noqa: E402


def sources(args: argparse.Namespace):
    """(label, records) of every valid trace the run starts from."""
    scenarios = args.scenarios.split(",") if args.scenarios else sorted(
        p.stem for p in (ROOT / "catalogue" / "scenarios").glob("*.ag"))
    controllers = args.controllers.split(",") if args.controllers else list(CONTROLLERS)
    for name in scenarios:
        inst = load_instance(name, 0, None)
        for ctl in controllers:
            yield f"{name} {ctl}", reference_trace(inst, ctl, args.horizon)
    for path in sorted((ROOT / "conformance" / "instances").glob("*.json")):
        inst = json.loads(path.read_text(encoding="utf-8"))
        yield f"{path.stem} greedy", reference_trace(inst, "greedy", args.horizon)
        yield f"{path.stem} illegal", reference_trace(inst, "illegal", args.horizon, illegal=0.2, seed=args.seed)
    for path in sorted((ROOT / "conformance" / "traces").glob("*.jsonl")):
        yield path.stem, read_records(path)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--horizon", type=int, default=400)
    ap.add_argument("--mutants", type=int, default=60, help="mutants drawn per source trace")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--scenarios", default="")
    ap.add_argument("--controllers", default="")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    rng = random.Random(args.seed)
    started = time.perf_counter()
    rows, false_alarms, wrong = [], [], []
    by_class: collections.Counter = collections.Counter()
    missed: collections.Counter = collections.Counter()
    ticks = 0
    for label, records in sources(args):
        ticks += sum(1 for r in records if r.get("type") == "tick")
        problems = judge(records)
        if problems:
            false_alarms.append(f"{label}: {problems[0]}")
        tried = passed = 0
        for m in mutants(records, rng, args.mutants):
            tried += 1
            by_class[f"{m.op}:{m.event}"] += 1
            if not judge(m.records):
                passed += 1
                missed[f"{m.op}:{m.event}"] += 1
                wrong.append(f"{label}: {m.label}")
        rows.append({"source": label, "ticks": sum(1 for r in records if r.get("type") == "tick"),
                     "reference_ok": not problems, "mutants": tried, "passed_wrongly": passed})
    result = {"sources": len(rows), "ticks": ticks, "mutants": sum(r["mutants"] for r in rows),
              "passed_wrongly": len(wrong), "false_alarms": len(false_alarms), "classes": dict(sorted(by_class.items())),
              "missed_classes": dict(sorted(missed.items())), "examples": wrong[:20] + false_alarms[:20],
              "seconds": round(time.perf_counter() - started, 1)}
    emit(result, rows, ("source", "ticks", "reference_ok", "mutants", "passed_wrongly"),
         f"lying traces: {result['mutants']} mutants of {len(rows)} reference traces ({ticks} ticks), "
         f"{len(wrong)} passed wrongly, {len(false_alarms)} false alarms", args.json)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
