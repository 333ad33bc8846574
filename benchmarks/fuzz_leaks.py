"""Every process agspec starts is gone when agspec is done (F-PROCESS-TEARDOWN): child kinds × helper
kinds × exit paths, leaks found.

Usage:  python benchmarks/fuzz_leaks.py [--json] [--agspec-python PY]

The table of tests/process_leaks.py: a simulator under test, a policy process and a Python policy (with its
fresh-process repeat) each leave a helper behind (in their process group, in a session of their own holding
their pipes, double-forked and detached), and the command ends normally, on the child's error, on a
timeout, by SIGINT or by SIGTERM.  The target is 0; tests/test_process_leaks.py is the bounded version.
"""

from __future__ import annotations

import argparse
import itertools
import sys
import tempfile
from pathlib import Path

from _common import emit

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from process_leaks import HELPERS, KINDS, PATHS, run_case  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--agspec-python", default=None, help="the interpreter of another agspec install (a baseline)")
    args = parser.parse_args()
    rows, violations = [], []
    for kind, helper, path in itertools.product(KINDS, HELPERS, PATHS):
        with tempfile.TemporaryDirectory() as tmp:
            wrong, seconds, code = run_case(kind, helper, path, Path(tmp), args.agspec_python)
        rows.append({"child": kind, "helper": helper, "exit_path": path, "exit": code, "seconds": round(seconds, 1),
                     "wrong": "; ".join(wrong) or None})
        violations += [f"{kind}/{helper}/{path}: {w}" for w in wrong]
        print(f"{kind:14} {helper:9} {path:8} exit {code}  {'; '.join(wrong) or 'ok'}", file=sys.stderr, flush=True)
    emit({"tried": len(rows), "violations": violations}, rows, ("child", "helper", "exit_path", "exit", "seconds", "wrong"),
         f"process leaks: {len(rows)} runs, {len(violations)} wrong", args.json)
    return 1 if violations else 0


if __name__ == "__main__":
    sys.exit(main())
