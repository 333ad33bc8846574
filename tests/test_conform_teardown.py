"""Teardown is bounded whatever the simulator does (F-PROTOCOL-TEARDOWN), and a worker a simulator
killed is the simulator's fault (F-PROTOCOL-ERRORS ``harness_killed``, CAMP-FAULTS).

The generator: simulators of tests/fakes/scripted_sim.py that leave a process behind holding their
pipes — in a session of their own holding both pipes, only stdout or only stderr, or in their own
process group, each ignoring SIGTERM — crossed with how the session ends (a clean stop, a crash of
the simulator, a timeout).  The property: ``conform`` answers within a bound far below the 600 s the
left-behind process lives, and no process the simulator started survives the run.
"""

from __future__ import annotations

import json
import os
import shlex
import sys
import time
from pathlib import Path

import pytest
from click.testing import CliRunner
from teardown_cases import run_case, tagged_processes

from agspec.cli.main import cli

HERE = Path(__file__).resolve().parent
SIM = HERE / "fakes" / "scripted_sim.py"
BOUND_S = 30.0  # far below the 600 s a left-behind process lives; the teardown itself takes < 1 s


# (how the daemon holds the pipes, how the session ends): each holder and each end at least once here;
# benchmarks/fuzz_harness.py runs the whole product (teardown_cases.DAEMONS x ENDS)
CASES = [("session", "stop"), ("session", "hang"), ("stdout", "crash"), ("stderr", "hang"), ("group", "crash"),
         ("stderr", "stop")]


@pytest.mark.parametrize("daemon, end", CASES)
def test_a_simulator_that_leaves_a_process_holding_its_pipes_is_torn_down_in_bounded_time(daemon, end, tmp_path):
    tag = f"teardown-{daemon}-{end}-{os.getpid()}"
    seconds, outcome = run_case(daemon, end, tag)
    assert seconds < BOUND_S, seconds
    assert outcome == ("pass" if end == "stop" else "error")
    deadline = time.monotonic() + 5
    while tagged_processes(tag) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert tagged_processes(tag) == []  # the simulator and what it left behind are gone


def test_a_simulator_that_kills_its_worker_is_blamed(tmp_path, monkeypatch):
    """-j 2: the simulator kills its parent, the harness worker; the item is the simulator's crash."""
    monkeypatch.chdir(tmp_path)
    spec = shlex.join([sys.executable, str(SIM), "--kill-parent"])
    result = CliRunner().invoke(cli, ["conform", "--impl", spec, "--no-suite", "--episodes", "1", "--horizon", "3",
                                      "-k", "e-flow-easy-greedy or e-coalition-easy-greedy", "-j", "2",
                                      "--retries", "0", "--format", "json", "--golden-cache", "off"])
    assert result.exit_code == 3, result.output
    results = json.loads(result.stdout)["results"]
    assert len(results) == 2
    for record in results:
        failure = record["failure"]
        assert (failure["type"], failure["code"]) == ("crash", "harness_killed"), failure
        assert "must not signal or exit the harness" in failure["message"]
