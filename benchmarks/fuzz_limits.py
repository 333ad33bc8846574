"""Large and dense inputs against every command that reads files (F-LIMITS: bounded time and memory).

Usage:  python benchmarks/fuzz_limits.py [--values 12000000] [--limit-s 60] [--commands validate,check]
                                         [--shapes wide-array,many-lines] [--json]

Each command runs in a fresh process on each shape of its input family (tests/large_inputs.py) at
the given size — by default the size of a real attack: 12 million values, a 48 MB document — with
the default limits.  A violation is a run over ``--limit-s`` seconds, an exit code other than the
documented 0/1 (content) or 2, a traceback, or a refusal without a located message (``file:line``).
Prints per run the wall time, the peak RSS, the exit code and the first line of the message; the
target is 0 violations.  tests/test_large_inputs.py is the bounded version (limits lowered).
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _common import agspec_cmd, emit

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from large_inputs import COMMANDS, FAMILIES, SHAPES, build  # noqa: E402

TRACEBACK = re.compile(r"Traceback \(most recent call last\)")


def _high_water_mib(pid: int) -> float:
    """VmHWM (peak resident set) of a running process, in MiB (0 once it is gone)."""
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024
    except (OSError, ValueError, IndexError):
        pass
    return 0.0


def run_one(argv: list[str], limit_s: float) -> tuple[float, float, int | None, str]:
    """Wall seconds, peak RSS (MiB), exit code (None: killed at the limit) and output of one run."""
    out = tempfile.TemporaryFile()
    t0 = time.perf_counter()
    proc = subprocess.Popen([*agspec_cmd(), *argv], stdout=out, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL)
    code: int | None = None
    peak = 0.0
    while True:
        peak = max(peak, _high_water_mib(proc.pid))  # polled: ru_maxrss of a child counts its fork from us
        pid, status, _ = os.wait4(proc.pid, os.WNOHANG)
        if pid:
            code = os.waitstatus_to_exitcode(status)
            break
        if time.perf_counter() - t0 > limit_s:
            proc.kill()
            os.wait4(proc.pid, 0)
            break
        time.sleep(0.02)
    seconds = time.perf_counter() - t0
    proc.returncode = code if code is not None else -9
    out.seek(0)
    text = out.read(200_000).decode("utf-8", "replace")
    return seconds, peak, code, text


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--values", type=int, default=12_000_000, help="size parameter n of every shape")
    parser.add_argument("--limit-s", type=float, default=60.0)
    parser.add_argument("--commands", default=",".join(COMMANDS))
    parser.add_argument("--shapes", default=",".join(SHAPES))
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    rows, violations = [], []
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        for command in args.commands.split(","):
            family_name, template = COMMANDS[command]
            family = FAMILIES[family_name]
            for shape in args.shapes.split(","):
                data = build(family, shape, args.values)
                if data is None:
                    continue
                path = work / f"{shape}-{family.name}{family.suffix}"
                path.write_bytes(data)
                argv = [a.replace("{out}", str(work)).replace("{}", str(path)) for a in template]
                seconds, peak, code, text = run_one(argv, args.limit_s)
                path.unlink()
                first = next((line for line in text.splitlines() if str(path) in line or "error" in line), "")
                # located: file:line:col, file: /pointer, or the file itself for a fault of the whole file (its size)
                located = re.search(re.escape(str(path)) + r"(:\d+|: /|/|: )", text) is not None
                bad = []
                if code is None:
                    bad.append(f"no answer within {args.limit_s:g} s")
                elif code not in (0, 1, 2):
                    bad.append(f"exit {code}")
                if TRACEBACK.search(text):
                    bad.append("traceback")
                if code == 1 and not located:
                    bad.append("no file:line location")
                row = {"command": command, "shape": shape, "MB": round(len(data) / 1e6, 1), "seconds": seconds,
                       "peak_mib": round(peak), "exit": code, "violation": "; ".join(bad) or None,
                       "message": first[:100]}
                rows.append(row)
                if bad:
                    violations.append(f"{command} {shape}: {'; '.join(bad)}")
                print(f"{command:16} {shape:18} {row['MB']:7} MB {seconds:6.1f} s {row['peak_mib']:6} MiB "
                      f"exit {code} {row['violation'] or ''}", file=sys.stderr, flush=True)
    emit({"values": args.values, "limit_s": args.limit_s, "tried": len(rows), "violations": violations},
         rows, ("command", "shape", "MB", "seconds", "peak_mib", "exit", "violation"),
         f"large inputs: {len(rows)} runs, {len(violations)} violations", args.json)
    return 1 if violations else 0


if __name__ == "__main__":
    sys.exit(main())
