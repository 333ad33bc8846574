"""The long run of the hard-coding mutants: every mutant of tests/mutants/mutant_registry.py that reads an
official value instead of the instance's goes through the whole default run of `agspec conform` (CLI,
subprocess simulator), and the table says which item killed it (F-CONFORM-COVERAGE, the variant space).

    python benchmarks/hardcoded_values.py                 # every hard-coding mutant, default run
    python benchmarks/hardcoded_values.py -k rho          # mutants whose name contains "rho"
    python benchmarks/hardcoded_values.py --suite OLD/conformance -k rho --select "not geometry-matched"

The test suite (tests/test_mutants.py) runs each of them on the items of the default run whose
instance it reads differently, which decides the same verdict in a few seconds; this script shows the
default run itself deciding it.  Prints mutants tried, killed and surviving; exit 1 if one survives.
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
import tempfile
import time

from _common import ROOT, agspec_cmd, timed_run

sys.path.insert(0, str(ROOT / "tests" / "mutants"))

import mutant_registry as registry  # noqa: E402  (tests/mutants/mutant_registry.py)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-k", dest="names", action="append", default=[], help="only mutants whose name contains this")
    ap.add_argument("--suite", default=None, help="suite root (default: the shipped conformance/)")
    ap.add_argument("--select", default=None, help="an `agspec conform -k` expression (default: every item)")
    args = ap.parse_args(argv)
    mutants = [m for m in registry.MUTANTS.values() if m.reads is not None
               and (not args.names or any(n in m.name for n in args.names))]
    killed = 0
    t0 = time.perf_counter()
    print(f"{'mutant':<30} {'verdict':<16} {'exit':>4} {'seconds':>8}  first failing item")
    with tempfile.TemporaryDirectory() as tmp:
        for m in mutants:
            impl = shlex.join([sys.executable, str(ROOT / "tests" / "mutants" / "sim.py"), "--mutant", m.name])
            cmd = [*agspec_cmd(), "conform", "--impl", impl, "--format", "json", "-x", "--repro-dir", tmp,
                   "--golden-cache", f"{tmp}/golden", "--timeout", "15"]
            cmd += ["--suite", args.suite] if args.suite else []
            cmd += ["-k", args.select] if args.select else []
            seconds, proc = timed_run(cmd, cwd=ROOT)
            try:
                report = json.loads(proc.stdout)
            except json.JSONDecodeError:
                tail = proc.stderr.strip()[-200:]
                print(f"{m.name:<30} {'no report':<16} {proc.returncode:>4} {seconds:8.1f}  {tail}")
                continue
            footer = report["footer"]
            failing = next((r for r in report["results"] if r["outcome"] in ("fail", "error")), None)
            where = "-" if failing is None else (f"{failing['id']} ({failing['location']}) tick "
                                                 f"{failing['failure'].get('tick')}: "
                                                 f"{failing['failure'].get('path') or failing['failure'].get('code')}")
            killed += proc.returncode == 1
            print(f"{m.name:<30} {footer['verdict'][:16]:<16} {proc.returncode:>4} {seconds:8.1f}  {where}", flush=True)
    print(f"hard-coding mutants tried {len(mutants)}, killed by the run {killed}, survived {len(mutants) - killed} "
          f"({time.perf_counter() - t0:.0f} s)")
    return 0 if killed == len(mutants) else 1


if __name__ == "__main__":
    raise SystemExit(main())
