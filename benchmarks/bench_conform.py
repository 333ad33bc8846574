"""Conformance overhead: `agspec conform --impl reference` over plain runs of the same episodes.

Usage:  python benchmarks/bench_conform.py [--horizon 400] [--episodes 1] [--impl SPEC ...] [--reps N] [--no-live]
                                          [--quick] [--json]
        python benchmarks/bench_conform.py --full-suite [--baseline-python PY] [--json]

Both sides are cold processes, so start-up is included on both:
  conform:  agspec conform --impl reference --no-suite --episodes E --horizon T
            (F-CONFORM: each catalogue scenario of agspec.conform.items.EPISODE_SCENARIOS — the nine
            official ones and the three geometry-matched controls — at index 0, greedy plus E-1 seeded random)
  plain:    the same episodes (the same scenarios, read from this build) through
            agspec.evaluate.run_episode (what `agspec run` does), one process.
ratio = conform / plain in wall time (targets: ≤ 1.3 for the reference in process, ≤ 2 for `--impl "agspec serve"`,
whose per-tick protocol cost — encode, pipe, decode — is then part of the figure; ms/tick shows it), measured
against the plain runs of the same repetitions.  Peak memory of each is the child's max RSS.
The package's bytecode is compiled before the first measurement, as an installed package's is: with
PYTHONDONTWRITEBYTECODE set, every process would otherwise compile each module it imports from source,
a cost that grows with the number of modules a command imports rather than with its work.
If `agspec conform` does not exist in this build, the benchmark says so and exits 0.
``--full-suite`` instead measures a default `agspec conform --impl reference` (suite and episodes) —
wall time and peak RSS — for this build without golden traces, with an empty cache (cold: the
items record theirs) and with that cache (warm), and with a baseline (``--baseline-python`` or
$AGSPEC_BASELINE_PYTHON) for the baseline release too.
The episode benchmark measures each implementation three ways (F-GOLDEN): ``live`` (--golden-cache
off), ``cold`` (an empty cache, which the run fills) and ``warm`` (that cache): the targets are for
the warm runs, the ones a simulator author repeats.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

from _common import ROOT, agspec_cmd, baseline_cli, baseline_python, ratio_table


PLAIN = """
import sys
from agspec.catalogue import load_scenario_bundle
from agspec.evaluate import run_episode
from agspec.ir.instance import make_instance
ticks, episodes = int(sys.argv[1]), int(sys.argv[2])
for name in sys.argv[3:]:
    inst = make_instance(*load_scenario_bundle(name), index=0)
    run_episode(inst, "greedy", horizon=ticks)
    for k in range(1, episodes):
        run_episode(inst, "random", horizon=ticks, seed=k)
"""


def episode_scenarios() -> tuple[str, ...]:
    """The scenarios of conform's catalogue episodes in the agspec these runs import (its own child
    process, so this one imports nothing of it)."""
    code = "from agspec.conform.items import EPISODE_SCENARIOS; print(' '.join(EPISODE_SCENARIOS))"
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    return tuple(out.stdout.split())


def compile_bytecode() -> None:
    """Compile the imported agspec's modules once, as installing a package does (both sides then read
    bytecode, whatever PYTHONDONTWRITEBYTECODE says)."""
    code = "import agspec, compileall, pathlib; compileall.compile_dir(pathlib.Path(agspec.__file__).parent, quiet=1)"
    subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, check=False)


def load_average() -> list[float] | None:
    import os

    try:
        return [round(x, 2) for x in os.getloadavg()]
    except OSError:
        return None


def _measure(cmd: list[str]) -> tuple[float, subprocess.CompletedProcess, float, float]:
    """Wall time, the peak RSS (MiB) and the CPU seconds (user + system) of this one child, from
    os.wait4's own rusage — which also counts the processes it started and waited for (a simulator
    process of ``--impl``).  CPU time is what load from other processes disturbs least."""
    import os
    import time

    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
        t0 = time.perf_counter()
        proc = subprocess.Popen(cmd, cwd=ROOT, stdout=out, stderr=err, text=True)
        _, status, usage = os.wait4(proc.pid, 0)
        seconds = time.perf_counter() - t0
        proc.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        done = subprocess.CompletedProcess(cmd, proc.returncode, out.read(), err.read())
    return seconds, done, usage.ru_maxrss / 1024, usage.ru_utime + usage.ru_stime


def full_suite(args) -> None:

    conform = ["conform", "--impl", "reference", "--format", "json"]
    rows = []
    baseline = baseline_python(args.baseline_python)
    if baseline:
        seconds, proc, peak, _ = _measure([*baseline_cli(baseline), *conform])
        rows.append({"side": "baseline", "golden": "", "wall_s": seconds, "exit_code": proc.returncode,
                     "peak_rss_mib": peak})
    with tempfile.TemporaryDirectory() as cache:
        # F-GOLDEN: the items record their golden traces (cold) and reuse them (warm)
        for mode, flag in (("off", "off"), ("cold", cache), ("warm", cache)):
            seconds, proc, peak, _ = _measure([*agspec_cmd(), *conform, "--golden-cache", flag])
            rows.append({"side": "new", "golden": mode, "wall_s": seconds, "exit_code": proc.returncode,
                         "peak_rss_mib": peak})
    if args.json:
        print(json.dumps({"benchmark": "conform-full-suite", "rows": rows}, indent=2))
        return
    ratio_table("agspec conform --impl reference (full suite): wall time and peak RSS", rows,
                [("side", "build"), ("golden", "golden cache"), ("wall_s", "wall s"), ("exit_code", "exit"),
                 ("peak_rss_mib", "peak RSS MiB")])


def _median(values: list[float]) -> float:
    import statistics

    return statistics.median(values)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--horizon", "--ticks", dest="horizon", type=int, default=400,
                    help="ticks per episode (conform's --horizon; --ticks is the earlier name)")
    ap.add_argument("--episodes", type=int, default=1)
    ap.add_argument("--scenario", action="append", default=None)
    ap.add_argument("--impl", action="append", default=None,
                    help='implementation under test (repeatable; default: reference and "agspec serve")')
    ap.add_argument("--reps", type=int, default=1, help="runs per row (median)")
    ap.add_argument("--no-live", action="store_true",
                    help="skip the live runs; the cold run happens once and the warm runs reuse its cache")
    ap.add_argument("--quick", action="store_true", help="2 scenarios x 40 ticks (CI smoke)")
    ap.add_argument("--full-suite", action="store_true", help="peak RSS and wall time of a default conform run")
    ap.add_argument("--baseline-python", default=None, help="Python of the baseline release's venv")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    impls = args.impl or ["reference", "agspec serve"]
    if args.quick:
        args.horizon, args.scenario = 40, args.scenario or ["coalition-medium", "flow-easy"]
        impls = args.impl or ["reference"]
    probe = subprocess.run([*agspec_cmd(), "conform", "--help"], capture_output=True, text=True)
    if probe.returncode != 0:
        print("agspec conform is not available in this build; conformance overhead not measured")
        return
    if args.full_suite:
        full_suite(args)
        return

    select = []
    if args.scenario:
        select = ["-k", " or ".join(f"e-{s}-*" for s in args.scenario)]
    # the plain runs play the episodes conform runs: the scenarios of this build's catalogue episodes
    scenarios = args.scenario or list(episode_scenarios())
    ticks_total = len(scenarios) * args.episodes * args.horizon
    plain_cmd = [sys.executable, "-c", PLAIN, str(args.horizon), str(args.episodes), *scenarios]
    compile_bytecode()
    load_before = load_average()
    # F-GOLDEN: live (no cache), cold (an empty cache: the run records), warm (the recorded traces reused).
    # Each repetition measures the plain runs and every conform run back to back, so a machine whose
    # speed drifts over minutes affects both sides of a ratio alike.
    plains = []
    measured = {impl: {"live": [], "cold": [], "warm": []} for impl in impls}
    with tempfile.TemporaryDirectory() as caches:
        for rep in range(args.reps):
            plains.append(_measure(plain_cmd))
            for k, impl in enumerate(impls):
                base = [*agspec_cmd(), "conform", "--impl", impl, "--no-suite", "--episodes", str(args.episodes),
                        "--horizon", str(args.horizon), "--format", "json", *select]
                modes = measured[impl]
                if not args.no_live:
                    modes["live"].append(_measure([*base, "--golden-cache", "off"]))
                cache = str(Path(caches) / f"{k}-{rep}")
                if rep == 0 or not args.no_live:  # with --no-live, the first repetition's cache serves the rest
                    modes["cold"].append(_measure([*base, "--golden-cache", cache]))
                modes["warm"].append(_measure([*base, "--golden-cache", str(Path(caches) / f"{k}-0") if args.no_live
                                               else cache]))
    plain_s, plain_peak = _median([p[0] for p in plains]), max(p[2] for p in plains)
    plain_cpu = _median([p[3] for p in plains])
    rows = [{"side": "plain run_episode", "mode": "", "wall_s": plain_s, "ratio": 1.0, "cpu_s": plain_cpu,
             "cpu_ratio": 1.0, "ms_per_tick": 1000 * plain_s / ticks_total,
             "exit_code": plains[0][1].returncode, "peak_rss_mib": plain_peak, "target": None}]
    failures = {}
    for impl in impls:
        for mode, runs in measured[impl].items():
            if not runs:
                continue
            wall, cpu = _median([r[0] for r in runs]), _median([r[3] for r in runs])
            code = runs[0][1].returncode
            rows.append({"side": f"conform --impl {impl}", "mode": mode, "wall_s": wall, "ratio": wall / plain_s,
                         "cpu_s": cpu, "cpu_ratio": cpu / plain_cpu,
                         "ms_per_tick": 1000 * wall / ticks_total, "exit_code": code,
                         "peak_rss_mib": max(r[2] for r in runs),
                         "target": (1.3 if impl == "reference" else 2.0) if mode == "warm" else None})
            if code != 0:
                failures[f"{impl} {mode}"] = runs[0][1].stderr[-2000:]
    # the protocol's own cost per tick (encode, pipe, decode): a process over the in-process reference
    by = {(r["side"], r["mode"]): r["ms_per_tick"] for r in rows}
    protocol_ms = {mode: by[("conform --impl agspec serve", mode)] - by[("conform --impl reference", mode)]
                   for mode in ("live", "warm") if ("conform --impl agspec serve", mode) in by
                   and ("conform --impl reference", mode) in by}
    result = {"benchmark": "conform", "ticks": args.horizon, "episodes_per_scenario": args.episodes,
              "scenarios": scenarios, "load_average": {"before": load_before, "after": load_average()}, "reps": args.reps, "plain_s": plain_s, "rows": rows,
              "protocol_ms_per_tick": protocol_ms}
    if failures:
        result["stderr"] = failures
    if args.json:
        print(json.dumps(result, indent=2))
        return
    ratio_table(f"conform over plain runs of the same episodes ({ticks_total} ticks; median of {args.reps})", rows,
                [("side", "run"), ("mode", "golden"), ("wall_s", "wall s"), ("ms_per_tick", "ms/tick"),
                 ("ratio", "ratio"), ("target", "target"), ("cpu_s", "CPU s"), ("cpu_ratio", "CPU ratio"),
                 ("exit_code", "exit"), ("peak_rss_mib", "peak RSS MiB")])
    print(f"load average (1, 5, 15 min) before: {result['load_average']['before']}, after: {result['load_average']['after']}")
    for mode, ms in protocol_ms.items():
        print(f"protocol cost per tick ({mode}; encode, pipe, decode and the process start-up = agspec serve minus in process): {ms:.2f} ms")


if __name__ == "__main__":
    main()
