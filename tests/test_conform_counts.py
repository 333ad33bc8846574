"""What `agspec conform` checks does not shrink when it gets faster (F-CONFORM, F-REPORT).

The counts below were measured on the reference before the comparison fast path and the other speed
work: the same run must compare exactly as many states, events, observations and masks and evaluate
exactly as many invariant checks — over the in-process reference and over `agspec serve` alike.  A
speed-up that skipped a comparison or an invariant on some tick changes one of these numbers.
"""

from __future__ import annotations

import json
import shutil

import pytest
from click.testing import CliRunner

from agspec.cli.main import cli

SERVE = shutil.which("agspec")

# scenario -> (ticks, replies compared, invariant checks) for `--episodes 2 --ticks 20` (greedy + 1 random)
MEASURED = {
    "coalition-medium": (40, 42, 4448),
    "concurrency-hard": (40, 42, 7350),
}


@pytest.fixture(autouse=True)
def _in_tmp(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)


@pytest.mark.parametrize("impl", ["reference", pytest.param("agspec serve", marks=pytest.mark.skipif(
    SERVE is None, reason="the agspec console script is not installed"))])
@pytest.mark.parametrize("scenario", sorted(MEASURED))
def test_same_run_same_counts(scenario, impl):
    result = CliRunner().invoke(cli, ["conform", "--impl", impl, "--no-suite", "--episodes", "2", "--ticks", "20",
                                      "-k", f"e-{scenario}-*", "--format", "json"], catch_exceptions=False)
    assert result.exit_code == 0, result.output[-2000:]
    footer = json.loads(result.output)["footer"]
    ticks, replies, checks = MEASURED[scenario]
    assert footer["ticks"] == ticks
    assert footer["replies_compared"] == footer["states_compared"] == replies
    assert footer["compared"] == {"events": replies, "state": replies, "observations": replies, "masks": replies}
    assert footer["invariant_checks"] == checks
