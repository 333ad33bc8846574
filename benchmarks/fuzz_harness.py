"""Hostile simulators against the harness's scoping, teardown and exploration: inputs tried, wrong verdicts.

Usage:  python benchmarks/fuzz_harness.py [--families scoping,teardown,coercion,liars] [--json]

Families (all built from tests/fakes/scripted_sim.py; the bounded versions are
tests/test_conform_scoping.py, tests/test_conform_teardown.py and tests/test_exploration.py):

* ``scoping`` (RES-GIVE-UP-SCOPE): every multiset of failure modes over three instances (an ``ok:
  false`` answer to load or reset, a crash at load or at a step, a line that is not JSON, none), each
  instance run three times with ``max_restarts`` 2 — wrong: an item on a correctly handled instance
  that does not pass, a failing item that does not report its own cause, a give-up before the
  instance failed ``max_restarts`` times;
* ``teardown`` (F-PROTOCOL-TEARDOWN): a process left behind holding the pipes (own session, one pipe,
  own group) × how the session ends (stop, crash, hang) — wrong: no answer within 30 s, or a
  process of the simulator still alive after the run;
* ``coercion`` (F-DIFF-ACTIONS): every way of mishandling illegal actions × five seeds of
  ``agspec diff`` — wrong: no divergence;
* ``liars`` (RES-CONFORM-HORIZON): a simulator wrong from epoch T on, T across the horizon — wrong:
  a default ``agspec conform`` run that does not fail.
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import sys
import tempfile
import time
from pathlib import Path

from _common import emit

TESTS = Path(__file__).resolve().parents[1] / "tests"
sys.path.insert(0, str(TESTS))

from click.testing import CliRunner  # noqa: E402

from agspec.cli.main import cli  # noqa: E402
from agspec.conform import runner  # noqa: E402
from agspec.conform.impl import SubprocessImpl  # noqa: E402
from scoping_cases import NAMES, scripted, small_items  # noqa: E402
from teardown_cases import DAEMONS, ENDS, run_case, tagged_processes  # noqa: E402

MODES = (None, ("load", "error:invalid_instance"), ("reset", "error:bad_seed"), ("load", "crash"),
         ("step", "crash"), ("step", "garbage"))


def scoping() -> tuple[int, list[str]]:
    tried, wrong = 0, []
    for modes in itertools.combinations_with_replacement(MODES, len(NAMES)):
        tried += 1
        plan = {name: {"cmd": m[0], "mode": m[1], "at": 1} for name, m in zip(NAMES, modes) if m}
        impl = SubprocessImpl(scripted("--fail", json.dumps(plan)), 15.0, max_restarts=2)
        try:
            summary = runner.run(small_items(repeat=3), "scripted", impl=impl, replays=0)
        finally:
            impl.close()
        for result, outcome in summary.results:
            mode = plan.get(result.item.title)
            earlier = int(result.item.id.rsplit("-", 1)[1])
            code = (result.failure or {}).get("code")
            if mode is None and outcome != "pass":
                wrong.append(f"{modes}: {result.item.id} on a handled instance: {outcome} {result.message}")
            elif mode is not None:
                restarts = not mode["mode"].startswith("error:")
                want = "gave_up" if restarts and earlier >= 2 else \
                    {"error": "error_reply", "crash": "exit", "garbage": "malformed_json"}[mode["mode"].split(":")[0]]
                if outcome != "error" or code != want:
                    wrong.append(f"{modes}: {result.item.id}: {outcome}/{code}, want error/{want}")
        print(f"scoping {modes}: {len(wrong)} wrong so far", file=sys.stderr, flush=True)
    return tried, wrong


def teardown() -> tuple[int, list[str]]:
    tried, wrong = 0, []
    for daemon, end in itertools.product(DAEMONS, ENDS):
        tried += 1
        tag = f"fuzz-teardown-{daemon}-{end}-{os.getpid()}"
        seconds, _ = run_case(daemon, end, tag)
        time.sleep(1.0)
        left = tagged_processes(tag)
        if seconds > 30 or left:
            wrong.append(f"{daemon}/{end}: {seconds:.1f} s, left {left}")
        print(f"teardown {daemon}/{end}: {seconds:.1f} s, left {len(left)}", file=sys.stderr, flush=True)
    return tried, wrong


def coercion() -> tuple[int, list[str]]:
    tried, wrong = 0, []
    for how, seed in itertools.product(("silent", "silent-range", "silent-masked", "wrong-action"), range(5)):
        tried += 1
        with tempfile.TemporaryDirectory() as tmp:
            result = CliRunner().invoke(cli, ["diff", "--impl", "reference", "--impl", scripted("--coercion", how),
                                              "--scenario", "flow-easy", "--small", "0", "--horizon", "30", "--seed",
                                              str(seed), "--shrink-budget", "0", "--format", "json", "-o",
                                              str(Path(tmp) / "out")])
        if result.exit_code != 1:
            wrong.append(f"{how} seed {seed}: exit {result.exit_code} (no divergence)")
        print(f"coercion {how} seed {seed}: exit {result.exit_code}", file=sys.stderr, flush=True)
    return tried, wrong


def liars() -> tuple[int, list[str]]:
    tried, wrong = 0, []
    for wrong_from in (1, 30, 60, 61, 100, 150, 200, 300, 350, 399):
        tried += 1
        with tempfile.TemporaryDirectory() as tmp:
            result = CliRunner().invoke(cli, ["conform", "--impl", scripted("--wrong-at", str(wrong_from)),
                                              "--no-suite", "--episodes", "1", "-k", "e-coalition-easy-greedy",
                                              "--golden-cache", "off", "--repro-dir", str(Path(tmp) / "r")])
        if result.exit_code != 1:
            wrong.append(f"wrong from epoch {wrong_from}: exit {result.exit_code}")
        print(f"liar from {wrong_from}: exit {result.exit_code}", file=sys.stderr, flush=True)
    return tried, wrong


FAMILIES = {"scoping": scoping, "teardown": teardown, "coercion": coercion, "liars": liars}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--families", default=",".join(FAMILIES))
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    rows, violations = [], []
    for name in args.families.split(","):
        t0 = time.perf_counter()
        tried, wrong = FAMILIES[name]()
        rows.append({"family": name, "tried": tried, "wrong": len(wrong), "seconds": time.perf_counter() - t0})
        violations += [f"{name}: {w}" for w in wrong]
    emit({"violations": violations}, rows, ("family", "tried", "wrong", "seconds"),
         f"harness families: {sum(r['tried'] for r in rows)} simulators, {len(violations)} wrong verdicts", args.json)
    return 1 if violations else 0


if __name__ == "__main__":
    sys.exit(main())
