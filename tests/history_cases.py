"""Simulators whose answers depend on their process's history, and the judge of a run against one
(F-REPRO, F-CONFORM-NONDETERMINISM, F-CONFORM-HISTORY).

Shared by tests/test_conform_history.py (a bounded hypothesis run) and benchmarks/fuzz_history.py
(every combination).  ``FLAGS`` name the faults of tests/fakes/scripted_sim.py: state leaking across
loads or resets, a coin per process, always wrong, wrong only on a re-run, refusing a re-run.
"""

from __future__ import annotations

import json
import shlex
import sys
from pathlib import Path

from click.testing import CliRunner

from agspec.cli.main import cli
from agspec.conform import runner

HERE = Path(__file__).resolve().parent
SIM = HERE / "fakes" / "scripted_sim.py"
FLAGS = ("leak_load", "leak_reset", "coin", "wrong_at", "rerun_wrong", "refuse_rerun")


def sim_spec(flags: frozenset[str], coin_dir: Path) -> str:
    argv = [sys.executable, str(SIM)]
    if "leak_load" in flags:
        argv += ["--leak", "load"]
    elif "leak_reset" in flags:
        argv += ["--leak", "reset"]
    if "coin" in flags:
        argv += ["--coin", str(coin_dir)]
    if "wrong_at" in flags:
        argv += ["--wrong-at", "2"]
    if "rerun_wrong" in flags:
        argv.append("--rerun-wrong")
    if "refuse_rerun" in flags:
        argv.append("--refuse-rerun")
    return shlex.join(argv)


def conform(spec: str, cwd: Path, *extra: str) -> tuple[int, dict]:
    result = CliRunner().invoke(cli, ["conform", "--impl", spec, "--format", "json", "--golden-cache", "off",
                                      "--repro-dir", str(cwd / "repro"), *extra])
    assert result.exit_code in (0, 1, 3, 5), result.output[-3000:]
    return result.exit_code, json.loads(result.stdout)


def judge(flags: frozenset[str], tmp: Path) -> list[str]:
    """Run the simulator of ``flags``; the properties it violates (empty: none)."""
    spec = sim_spec(flags, tmp / "coin")
    code, out = conform(spec, tmp, "--no-suite", "--episodes", "2", "--horizon", "3",
                        "-k", "e-flow-easy-greedy or e-flow-easy-random-1 or e-coalition-easy-greedy")
    footer, wrong = out["footer"], []
    deterministic = "coin" not in flags
    if deterministic and code == runner.EXIT_NONDETERMINISTIC:
        wrong.append(f"called nondeterministic: {footer.get('nondeterministic')}")
    failing = [r for r in out["results"] if r["raw_outcome"] == "fail"]
    if code != runner.EXIT_NONDETERMINISTIC:
        for record in failing:
            path = record["failure"]["reproducer"]
            rc, again = conform(spec, tmp, "--replay", path)
            (replayed,) = again["results"]
            got = (replayed["raw_outcome"], (replayed.get("failure") or {}).get("tick"),
                   (replayed.get("failure") or {}).get("path"))
            want = ("fail", record["failure"]["tick"], record["failure"].get("path"))
            if got != want:
                wrong.append(f"reproducer of {record['id']} replays as {got}, the run had {want}")
    # the second episode fails at epoch 1 only because of the first (a leak, or the same instance again),
    # unless the simulator refuses to load it at all
    history = any(f in flags for f in ("leak_load", "leak_reset", "rerun_wrong")) and "refuse_rerun" not in flags
    if deterministic and history and footer.get("history_dependent") is None:
        wrong.append("a failure that needs the earlier episodes is not named history-dependent")
    if footer.get("history_dependent") is not None and not history:
        wrong.append(f"named history-dependent without a history: {footer['history_dependent']}")
    return wrong


__all__ = ["FLAGS", "sim_spec", "conform", "judge"]
