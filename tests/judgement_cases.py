"""One judgement of failures for ``agspec conform`` and ``agspec diff`` (F-CONFORM-NONDETERMINISM,
F-CONFORM-HISTORY): the simulators of tests/history_cases.py and a wrapper wrong in every N-th reply of its
process, each run through both commands.

Shared by tests/test_judgement_agreement.py (a bounded share) and benchmarks/fuzz_judgement.py (every
simulator).  A simulator's verdict under a command is ``nondeterministic`` (exit 5), ``fails`` (exit 1: a failure
that recurs in a fresh process, alone or — named history-dependent — after its process's history),
``error`` (exit 3) or ``passes`` (exit 0).  Wrong: the two commands both see a failure and give other
verdicts on a deterministic simulator, or either calls a deterministic simulator nondeterministic, or a
failure is named history-dependent where the simulator keeps no history.  Where only one command's
episodes reach a failure (they send other actions) or one observed an error the other did not, the pair is
counted as not comparable, never as agreement; a simulator with a coin per process is caught with a
probability that depends on how many processes came before, so only the first two properties hold it.  Whether a
failure needs its history depends on where it fell (the first episode of a process has none), so the
label is checked against the simulator, not between the commands.
"""

from __future__ import annotations

import itertools
import json
import shlex
import sys
from pathlib import Path

from click.testing import CliRunner
from history_cases import FLAGS, sim_spec

from agspec.cli.main import cli

HERE = Path(__file__).resolve().parent
EVERY_NTH = HERE / "fakes" / "every_nth_sim.py"
HORIZON = 40
VERDICTS = {0: "passes", 1: "fails", 3: "error", 5: "nondeterministic"}


def simulators(max_flags: int = 2) -> list[tuple[str, frozenset[str] | int]]:
    """(name, what): combinations of history faults, and every-N-th-reply wrappers."""
    out: list[tuple[str, frozenset[str] | int]] = [(f"every-{n}th", n) for n in (50, 23)]
    for k in range(1, max_flags + 1):
        out += [("+".join(c), frozenset(c)) for c in itertools.combinations(FLAGS, k)]
    return out


def spec_of(what: frozenset[str] | int, tmp: Path) -> str:
    if isinstance(what, int):
        return shlex.join([sys.executable, str(EVERY_NTH), str(what)])
    return sim_spec(what, tmp / "coin")


def deterministic(what: frozenset[str] | int) -> bool:
    return isinstance(what, int) or "coin" not in what


def keeps_history(what: frozenset[str] | int) -> bool:
    """Whether the simulator's answers depend on what its process did before."""
    return isinstance(what, int) or bool(what & {"leak_load", "leak_reset", "rerun_wrong", "refuse_rerun"})


def conform_category(spec: str, tmp: Path) -> tuple[str, bool]:
    result = CliRunner().invoke(cli, ["conform", "--impl", spec, "--format", "json", "--golden-cache", "off",
                                      "--repro-dir", str(tmp / "repro"), "--no-suite", "--episodes", "2",
                                      "--horizon", str(HORIZON), "-k", "e-flow-easy"])
    code, footer = result.exit_code, json.loads(result.stdout)["footer"]
    return VERDICTS.get(code, f"exit {code}"), footer.get("history_dependent") is not None


def diff_category(spec: str, tmp: Path) -> tuple[str, bool]:
    result = CliRunner().invoke(cli, ["diff", "--impl", "reference", "--impl", spec, "--scenario", "flow-easy",
                                      "--indices", "0-1", "--horizon", str(HORIZON), "--format", "json",
                                      "-o", str(tmp / "diff"), "--hypothesis-examples", "0"])
    code, report = result.exit_code, json.loads(result.stdout)
    return VERDICTS.get(code, f"exit {code}"), any(f.get("history_dependent") for f in report.get("findings", []))


def judge(what: frozenset[str] | int, tmp: Path) -> tuple[list[str], bool]:
    """The wrong verdicts for one simulator, and whether both commands saw a failure (comparable)."""
    spec = spec_of(what, tmp)
    (c_cat, c_hist), (d_cat, d_hist) = conform_category(spec, tmp / "c"), diff_category(spec, tmp / "d")
    wrong = []
    if deterministic(what):
        wrong += [f"{cmd} calls a deterministic simulator nondeterministic"
                  for cmd, cat in (("conform", c_cat), ("diff", d_cat)) if cat == "nondeterministic"]
    if not keeps_history(what):
        wrong += [f"{cmd} names a failure history-dependent" for cmd, named in (("conform", c_hist), ("diff", d_hist))
                  if named]
    # a judgement is comparable where both commands judged a failure (an error — a refused or crashed
    # request — is observed, not judged) of a simulator whose answers are a function of its requests
    comparable = {c_cat, d_cat} <= {"fails", "nondeterministic"}
    if comparable and deterministic(what) and c_cat != d_cat:
        wrong.append(f"conform: {c_cat}; diff: {d_cat}")
    return wrong, comparable
