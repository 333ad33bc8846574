"""CAMP-EXECUTOR, F-EXIT-CODES: every command that takes ``--executor``, asked for Ray where Ray is not
installed, exits 2 with one message naming the missing extra and no traceback — whichever step of the
command starts the executor.  The table must name every such command, so a new one is tried too."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

import click
import pytest

from agspec.cli.main import COMMANDS, cli

pytestmark = pytest.mark.skipif(importlib.util.find_spec("ray") is not None,
                                reason="Ray is installed: there is no missing executor to report")

AGSPEC = [sys.executable, "-m", "agspec.cli.main"]
ARGV = {
    "check": ["check", "{trace}", "{trace}"],  # several traces: one is checked in process, with a note
    "conform": ["conform", "--impl", "reference", "--no-suite", "--horizon", "2"],
    "diff": ["diff", "--impl", "reference", "--impl", "reference", "--scenario", "flow-easy", "--indices", "0-0",
             "--horizon", "2"],
    "evaluate": ["evaluate", "--scenario", "flow-easy", "--indices", "0-0", "--controller", "greedy"],
    "train": ["train", "--campaign", "paper", "-o", "{tmp}/campaign"],
}


def _commands_with_an_executor() -> set[str]:
    ctx = click.Context(cli)
    return {name for name in COMMANDS
            if any(p.name == "executor" for p in cli.get_command(ctx, name).params)}


def test_the_table_names_every_command_with_an_executor():
    assert set(ARGV) == _commands_with_an_executor()


@pytest.mark.parametrize("command", sorted(ARGV))
def test_ray_missing_is_a_usage_error(command, tmp_path: Path):
    trace = tmp_path / "t.jsonl"
    if "{trace}" in ARGV[command]:
        subprocess.run([*AGSPEC, "run", "flow-easy", "--horizon", "2", "--trace", str(trace)], check=True,
                       capture_output=True)
    argv = [a.format(trace=trace, tmp=tmp_path) for a in ARGV[command]]
    proc = subprocess.run([*AGSPEC, *argv, "--executor", "ray"], capture_output=True, text=True, cwd=tmp_path,
                          timeout=300)
    assert "Traceback" not in proc.stderr, proc.stderr[-3000:]
    assert proc.returncode == 2, proc.stderr[-2000:]
    assert "pip install 'agspec[" in proc.stderr, proc.stderr[-2000:]


def test_one_trace_says_the_executor_is_not_used(tmp_path: Path):
    trace = tmp_path / "t.jsonl"
    subprocess.run([*AGSPEC, "run", "flow-easy", "--horizon", "2", "--trace", str(trace)], check=True,
                   capture_output=True)
    proc = subprocess.run([*AGSPEC, "check", str(trace), "--executor", "ray"], capture_output=True, text=True,
                          timeout=300)
    assert proc.returncode == 0 and "one trace is checked in this process" in proc.stderr, proc.stderr
