"""Reproducers reproduce; history is not nondeterminism (F-REPRO, F-CONFORM-NONDETERMINISM, F-CONFORM-HISTORY).

The generator: the simulators of tests/fakes/scripted_sim.py parametrized by what their answers
depend on — state leaking from one load to the next, or from one reset to the next; a coin per process
(random per process); always wrong; wrong only when an instance is loaded again (wrong only on a
re-run); refusing every load after the first of a process (refuses the re-run) — and their
combinations, run over catalogue episodes of which two share an instance.  The properties:

* a simulator whose answers are a function of the requests its process received is never called
  nondeterministic (exit 5);
* every reproducer the run printed, replayed as ``agspec conform --replay FILE`` (a fresh process),
  fails at the same tick and place as the item that wrote it;
* a failure that appears only after earlier episodes of the same process is named history-dependent
  (footer ``history_dependent``), and one that does not is not.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from agspec.conform import runner
from history_cases import FLAGS, conform, judge, sim_spec

@settings(max_examples=4, deadline=None, database=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(flags=st.frozensets(st.sampled_from(FLAGS), min_size=1, max_size=3))
def test_reproducers_reproduce_and_history_is_named(flags, tmp_path_factory):
    assert judge(flags, tmp_path_factory.mktemp("run")) == []


@pytest.mark.parametrize("flags", [frozenset({"leak_load"}), frozenset({"wrong_at", "refuse_rerun"}),
                                   frozenset({"coin"})])
def test_the_issue_instances(flags, tmp_path):
    """A leak across loads is history-dependent with a history reproducer; an always-wrong simulator that
    refuses a second load is an ordinary failure; a coin per process is nondeterministic."""
    assert judge(flags, tmp_path) == []
    code, out = conform(sim_spec(flags, tmp_path / "coin2"), tmp_path, "--no-suite", "--episodes", "2",
                        "--horizon", "3", "-k", "e-flow-easy-greedy or e-flow-easy-random-1")
    footer = out["footer"]
    if flags == {"leak_load"}:
        assert code == 1 and footer["history_dependent"]["id"] == "e-flow-easy-random-1"
        data = json.loads(Path(footer["history_dependent"]["reproducer"]).read_text())
        assert [r["cmd"] for r in data["history"]["requests"]][:2] == ["load", "reset"]
        assert "HISTORY-DEPENDENT" not in footer["verdict"] and "history-dependent" in footer["verdict"]
    elif flags == {"coin"}:
        assert code == runner.EXIT_NONDETERMINISTIC and footer["nondeterministic"]["fresh"] is True
    else:
        assert code == 1 and footer["nondeterministic"] is None and footer["history_dependent"] is None

