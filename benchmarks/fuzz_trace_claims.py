"""Long run of the lying-header generator (F-TRACE-CLAIMS): honest traces, every header mutant, wrong passes.

Usage:  python benchmarks/fuzz_trace_claims.py [--horizon 20] [--scenarios a,b] [--instances a.json,…]
                                               [--sample N] [--seed S] [--shipped] [--json]

Sources: honest traces written by the command line, ``agspec run SCENARIO --controller greedy
--trace t.jsonl --horizon N``, of official scenarios (index 0: flow-easy, coalition-medium,
concurrency-hard, or ``--scenarios``), of a geometry-matched one (suite index, not official) and of
conformance instances (hand-made, one in batch mode), and with ``--shipped`` the traces of
conformance/traces/ (random and parallel-aware, 60-90 ticks). Each source must pass ``agspec check``
(no false alarm); then every mutant of its header (tests/trace_claims.py), or ``--sample`` of them,
is judged by what ``agspec check`` runs. Counted: mutants tried, those that change a checkable
claim and passed (wrong passes, the target is 0), those that change nothing checkable (the spec's
F-CLAIM-UNCHECKED table) and were still refused, and the unasserted ones (a field of an unofficial
instance that is the trace's own definition, re-fingerprinted; a diagnostic state field).

Figures (2 shared cores; the default sources, horizon 5):
``python benchmarks/fuzz_trace_claims.py --horizon 5 --sample 100`` — 600 mutants; before
F-TRACE-CLAIMS (`agspec check` judged the invariants and the whole trace only, and dropped what
`agspec trace validate` reported) 103 passed wrongly (the stored instance edited with or without
its fingerprint, a fingerprint one digit off, the spec version, a controller's information, a
robot deleted from s_0), after 0; 0 false alarms both times.
``python benchmarks/fuzz_trace_claims.py --horizon 5 --sample 300 --seed 1`` — 1800 mutants: 0 passed
wrongly, 0 false alarms, 0 refused though unchecked, 658 unasserted (1017 s). All the mutants of the
default sources: 6108, about 0.5 s each.
``python benchmarks/fuzz_trace_claims.py --horizon 5 --scenarios flow-easy --instances
conformance/instances/solo-1x2-batch2-flat.json`` — every mutant of the two, 1464: 0 passed wrongly,
0 false alarms (181 s); the 2 refused though unchecked were the deletion of a hand-made instance's
required `id`, the schema's to refuse (the oracle now leaves deletions of required fields unasserted).
"""

from __future__ import annotations

import argparse
import collections
import json
import random
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _common import ROOT, agspec_cmd, emit

sys.path.insert(0, str(ROOT / "tests"))

from trace_claims import expected_to_fail, judge, mutants, split  # noqa: E402

OFFICIAL = ("flow-easy", "coalition-medium", "concurrency-hard")
MATCHED = ("geometry-matched-low",)
INSTANCES = ("solo-1x2-batch2-flat.json", "pair-2x2-official.json")


def sources(args: argparse.Namespace, tmp: Path):
    names = args.scenarios.split(",") if args.scenarios else list(OFFICIAL + MATCHED)
    inst = args.instances.split(",") if args.instances else [str(ROOT / "conformance" / "instances" / i)
                                                             for i in INSTANCES]
    for target in names + inst:
        out = tmp / (Path(target).stem + ".jsonl")
        proc = subprocess.run(agspec_cmd() + ["run", target, "--controller", "greedy", "--trace", str(out),
                                              "--horizon", str(args.horizon)], capture_output=True, text=True)
        if proc.returncode:
            raise SystemExit(f"agspec run {target} failed: {proc.stderr[-400:]}")
        yield Path(target).stem, out.read_text(encoding="utf-8")
    for path in sorted((ROOT / "conformance" / "traces").glob("*.jsonl")) if args.shipped else ():
        yield path.stem, path.read_text(encoding="utf-8")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--horizon", type=int, default=20)
    ap.add_argument("--scenarios", default="")
    ap.add_argument("--instances", default="")
    ap.add_argument("--sample", type=int, default=0, help="mutants drawn per source (0: all of them)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--shipped", action="store_true", help="also the traces of conformance/traces/ (slow)")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    started = time.perf_counter()
    rows, wrong, false_alarms, over = [], [], [], []
    missed: collections.Counter = collections.Counter()
    with tempfile.TemporaryDirectory() as tmp:
        for label, text in sources(args, Path(tmp)):
            header, rest = split(text)
            problems = judge(header, rest, Path(tmp))
            if problems:
                false_alarms.append(f"{label}: {problems[0]}")
            ticks = sum(1 for line in rest if json.loads(line).get("type") == "tick")
            terminated = isinstance(header.get("horizon"), int) and ticks < header["horizon"]
            counts = collections.Counter()
            pool = list(mutants(header))
            if args.sample and args.sample < len(pool):
                pool = random.Random(f"{args.seed}:{label}").sample(pool, args.sample)
            for m in pool:
                want = expected_to_fail(m, header, terminated)
                failed = bool(judge(m.header, rest, Path(tmp)))
                counts["tried"] += 1
                if want is True and not failed:
                    counts["passed_wrongly"] += 1
                    missed[m.pointer.split("/")[1] + ("/" + m.pointer.split("/")[2] if m.pointer.count("/") > 1
                                                      else "")] += 1
                    wrong.append(f"{label}: {m.label}")
                elif want is False and failed:
                    counts["refused_unchecked"] += 1
                    over.append(f"{label}: {m.label}")
                elif want is None:
                    counts["unasserted"] += 1
                    counts["unasserted_refused"] += failed
                else:
                    counts["checkable" if want else "unchecked"] += 1
            rows.append({"source": label, "mutants": counts["tried"], "passed_wrongly": counts["passed_wrongly"],
                         "refused_unchecked": counts["refused_unchecked"], "unasserted": counts["unasserted"],
                         "unasserted_refused": counts["unasserted_refused"]})
    result = {"sources": len(rows), "mutants": sum(r["mutants"] for r in rows), "passed_wrongly": len(wrong),
              "false_alarms": len(false_alarms), "refused_unchecked": len(over),
              "unasserted": sum(r["unasserted"] for r in rows), "missed_fields": dict(missed.most_common()),
              "examples": wrong[:20] + false_alarms[:10] + over[:10], "seconds": round(time.perf_counter() - started, 1)}
    emit(result, rows, ("source", "mutants", "passed_wrongly", "refused_unchecked", "unasserted", "unasserted_refused"),
         f"lying headers: {result['mutants']} mutants of {len(rows)} honest traces, {len(wrong)} passed wrongly, "
         f"{len(false_alarms)} false alarms, {len(over)} refused though unchecked", args.json)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
