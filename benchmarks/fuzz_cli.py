"""Long hostile-input fuzz run of the whole CLI (F-LIMITS, F-EXIT-CODES): inputs tried and crashes.

Usage:  python benchmarks/fuzz_cli.py [--examples 200] [--commands run,check] [--no-table] [--json]

The bounded run is tests/test_fuzz_cli.py; this one uses the same strategies (tests/hostile_inputs.py)
with many more examples per command, plus every fault class of the exit-code table through the real
entry point (a fresh process each: special files, the peak memory of the children). A crash is an
escaped exception, a traceback, an exit code outside 0-2, a silent failure or a run over the time
limit. The target is 0 crashes; nothing here is asserted.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _common import agspec_cmd, children_peak_mib, emit

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from hypothesis import HealthCheck, given, settings  # noqa: E402

from hostile_inputs import (  # noqa: E402
    CONTENT,
    COMMANDS,
    FAMILIES,
    SPECIAL,
    TRACEBACK,
    argv,
    expected_exit,
    invoke,
    materialize,
    mutations,
)

LIMIT_S = 60.0  # one command on one input


def fuzz(command: str, examples: int, work: Path, crashes: list[str]) -> int:
    family = FAMILIES[COMMANDS[command][0]]
    tried = 0

    @settings(max_examples=examples, deadline=None, database=None,
              suppress_health_check=list(HealthCheck))
    @given(mutations(family))
    def prop(data: bytes) -> None:
        nonlocal tried
        tried += 1
        path = work / f"fuzz{family.suffix}"
        path.write_bytes(data)
        t0 = time.perf_counter()
        out = invoke(argv(command, path, work))
        seconds = time.perf_counter() - t0
        if out.crashed or TRACEBACK.search(out.output) or out.exit_code not in (0, 1, 2) or seconds > LIMIT_S \
                or (out.exit_code and not out.output.strip()):
            crashes.append(f"{command}: exit {out.exit_code} in {seconds:.1f} s on {data[:120]!r}")

    prop()
    return tried


def table(work: Path, crashes: list[str]) -> int:
    """Every command on every fault class, each in a fresh process (the real entry point)."""
    tried = 0
    for command in COMMANDS:
        family = FAMILIES[COMMANDS[command][0]]
        for kind in (*CONTENT, *SPECIAL):
            path = materialize(kind, family, work)
            if path is None:
                continue
            tried += 1
            try:
                proc = subprocess.run([*agspec_cmd(), *argv(command, path, work)], capture_output=True, text=True,
                                      timeout=LIMIT_S, stdin=subprocess.DEVNULL)
            except subprocess.TimeoutExpired:
                crashes.append(f"{command} on {kind}: no answer within {LIMIT_S} s")
                continue
            if proc.returncode != expected_exit(kind) or "Traceback" in proc.stderr:
                crashes.append(f"{command} on {kind}: exit {proc.returncode}: {proc.stderr[-300:]}")
    return tried


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--examples", type=int, default=200, help="hypothesis examples per command")
    ap.add_argument("--commands", default=",".join(sorted(COMMANDS)), help="comma-separated subset")
    ap.add_argument("--no-table", action="store_true", help="skip the subprocess run of every fault class")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    crashes: list[str] = []
    rows = []
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        for command in args.commands.split(","):
            before = len(crashes)
            start = time.perf_counter()
            tried = fuzz(command, args.examples, work, crashes)
            rows.append({"command": command, "inputs": tried, "crashes": len(crashes) - before,
                         "seconds": time.perf_counter() - start})
        start = time.perf_counter()
        tried = 0 if args.no_table else table(work, crashes)
        rows.append({"command": "(every fault class, subprocess)", "inputs": tried,
                     "crashes": sum(1 for c in crashes if " on " in c.split(":")[0]),
                     "seconds": time.perf_counter() - start})
    result = {"benchmark": "fuzz_cli", "inputs_tried": sum(r["inputs"] for r in rows), "crashes": len(crashes),
              "seconds": time.perf_counter() - t0, "peak_child_rss_mib": round(children_peak_mib(), 1),
              "examples_per_command": args.examples, "crash_samples": crashes[:20]}
    emit(result, rows, ("command", "inputs", "crashes", "seconds"), "hostile-input fuzzing of the CLI", args.json)
    for c in crashes[:20]:
        print("CRASH", c, file=sys.stderr)


if __name__ == "__main__":
    main()
