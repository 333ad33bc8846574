"""The thread budget's default against the best explicit `--threads` (spec/14-campaigns.md CAMP-THREADS,
RES-THREADS-ONE), in one run.

Usage:  python benchmarks/bench_threads.py [--checkpoint RUN_DIR] [--indices 1000-1001] [--reps 3] [--limit 300] [--json]

Trains a tiny IPPO checkpoint (`agspec train --algorithm ippo --scenario flow-easy --steps 800
--threads 1`) unless ``--checkpoint`` names one, then times `agspec evaluate --policy RUN_DIR
--scenario flow-easy --controller greedy --indices … --repeat 0` as a fresh process, for -j 1 and
-j cores, with the default budget and with each explicit `--threads 1..cores`.  The ratio is the
default's wall time over the best explicit one's of the same -j (goal: ≤ 1.2).  A command that runs
past ``--limit`` seconds is stopped and reported as at least the limit.  Each condition runs
``--reps`` times, interleaved with the others after one untimed warm-up; the median is reported.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import tempfile
import time
from pathlib import Path

from _common import agspec_cmd, emit

from agspec import threads


def train(out: Path) -> Path:
    run = out / "ippo-run"
    cmd = [*agspec_cmd(), "train", "--algorithm", "ippo", "--scenario", "flow-easy", "--seed", "0", "--steps", "800",
           "--threads", "1", "--set", "validation.indices=[]", "--format", "json", "-o", str(run)]
    subprocess.run(cmd, check=True, capture_output=True, text=True)
    return run


def evaluate(run: Path, indices: str, jobs: int, n: int | None, out: Path, limit: float) -> dict:
    cmd = [*agspec_cmd(), "evaluate", "--policy", str(run), "--scenario", "flow-easy", "--controller", "greedy",
           "--indices", indices, "--repeat", "0", "-j", str(jobs), "--format", "json", "-o", str(out)]
    if n is not None:
        cmd += ["--threads", str(n)]
    started = time.perf_counter()
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=limit)
    except subprocess.TimeoutExpired:
        return {"jobs": jobs, "threads": n, "per_process": n, "wall_s": limit, "stopped": True}
    wall = time.perf_counter() - started
    if proc.returncode != 0:
        raise SystemExit(f"evaluate failed ({proc.returncode}): {proc.stderr[-2000:]}")
    budget = json.loads(out.read_text())["threads"]
    return {"jobs": jobs, "threads": n, "per_process": budget["per_process"], "wall_s": round(wall, 2),
            "stopped": False}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--checkpoint", type=Path, default=None, help="a trained run directory (default: train one)")
    ap.add_argument("--indices", default="1000-1001", help="final-test indices evaluated per command")
    ap.add_argument("--limit", type=float, default=300.0, help="seconds after which one command is stopped")
    ap.add_argument("--reps", type=int, default=3, help="repetitions per condition; the median is reported")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    cores = threads.cores()
    with tempfile.TemporaryDirectory(prefix="agspec-bench-threads-") as tmp:
        run = args.checkpoint or train(Path(tmp))
        bundle = Path(tmp) / "bundle.json"
        evaluate(run, args.indices, 1, None, bundle, args.limit)  # warm-up: imports and files in the page cache
        conditions = [(jobs, n) for jobs in dict.fromkeys((1, cores)) for n in (None, *range(1, cores + 1))]
        times: dict[tuple[int, int | None], list[dict]] = {c: [] for c in conditions}
        for rep in range(args.reps):  # interleaved, the order rotated each repetition: load drifts hit all alike
            k = rep % len(conditions)
            for jobs, n in conditions[k:] + conditions[:k]:
                times[(jobs, n)].append(evaluate(run, args.indices, jobs, n, bundle, args.limit))
        rows = []
        for c, got in times.items():
            walls = sorted(r["wall_s"] for r in got)
            rows.append({**got[0], "wall_s": walls[len(walls) // 2], "walls": [r["wall_s"] for r in got],
                         "stopped": any(r["stopped"] for r in got)})
    summary = []
    for jobs in dict.fromkeys((1, cores)):
        mine = [r for r in rows if r["jobs"] == jobs]
        default = next(r for r in mine if r["threads"] is None)
        best = min((r for r in mine if r["threads"] is not None), key=lambda r: r["wall_s"])
        summary.append({"jobs": jobs, "default_threads": default.get("per_process"), "default_s": default["wall_s"],
                        "best_threads": best["threads"], "best_s": best["wall_s"],
                        "ratio": round(default["wall_s"] / best["wall_s"], 3)})
    result = {"cores": cores, "indices": args.indices, "runs": rows, "summary": summary}
    emit(result, rows, ("jobs", "threads", "per_process", "wall_s", "walls", "stopped"),
         f"agspec evaluate of a tiny IPPO checkpoint, flow-easy {args.indices}, {cores} cores", args.json)
    if not args.json:
        for s in summary:
            print(f"-j {s['jobs']}: default ({s['default_threads']} thread) {s['default_s']:.2f} s, best --threads "
                  f"{s['best_threads']} {s['best_s']:.2f} s, ratio {s['ratio']:.3f} (goal <= 1.2)")

if __name__ == "__main__":
    main()
