#!/usr/bin/env python3
"""Regenerate the reference traces of the conformance suite (conformance/traces/*.jsonl).

Each trace is written by the reference interpreter through the ordinary command line,
``agspec run SCENARIO --index K --controller C --horizon H --trace FILE`` (F-TRACE), on an official
catalogue instance with a short horizon chosen so that the first delivery happens inside it.
The cases in conformance/cases/traces.yaml replay the applied actions of these files and expect
every state and event in them.

    python conformance/tools/make_traces.py           # rewrite the traces
    python conformance/tools/make_traces.py --check   # fail if a trace would change
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import sys
import tempfile
from pathlib import Path

from agspec.cli.main import main as agspec

HERE = Path(__file__).resolve().parent
OUT = HERE.parent / "traces"

# (file stem, scenario, index, controller, horizon)
TRACES = [
    ("coalition-medium-s00-greedy-h90", "coalition-medium", 0, "greedy", 90),  # first delivery at t = 86
    ("concurrency-hard-s00-parallel-aware-h85", "concurrency-hard", 0, "parallel-aware", 85),  # at t = 82
    ("flow-hard-s00-random-h60", "flow-hard", 0, "random", 60),
]


def run(scenario: str, index: int, controller: str, horizon: int, path: Path) -> None:
    argv = ["run", scenario, "--index", str(index), "--controller", controller, "--horizon", str(horizon),
            "--trace", str(path), "--format", "json"]
    try:
        with contextlib.redirect_stdout(io.StringIO()):  # the metrics JSON is not needed here
            agspec(argv)
    except SystemExit as exc:
        if exc.code not in (0, None):
            raise SystemExit(f"agspec {' '.join(argv)} failed with exit code {exc.code}")


def comparable(path: Path) -> list:
    """Trace records without the implementation version (which changes with every release)."""
    out = []
    for line in path.read_text(encoding="utf-8").splitlines():
        rec = json.loads(line)
        rec.pop("implementation", None)
        rec.pop("spec_version", None)
        out.append(rec)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true")
    args = ap.parse_args(argv)
    OUT.mkdir(parents=True, exist_ok=True)
    stale = []
    for stem, scenario, index, controller, horizon in TRACES:
        target = OUT / f"{stem}.jsonl"
        if args.check:
            with tempfile.TemporaryDirectory() as tmp:
                fresh = Path(tmp) / target.name
                run(scenario, index, controller, horizon, fresh)
                if not target.is_file() or comparable(fresh) != comparable(target):
                    stale.append(target.name)
            continue
        run(scenario, index, controller, horizon, target)
        print(f"wrote {target.relative_to(HERE.parent.parent)} ({target.stat().st_size // 1024} KiB)", file=sys.stderr)
    if stale:
        print("stale or missing: " + ", ".join(stale), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
