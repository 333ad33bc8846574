"""What `agspec conform` checks does not shrink when it gets faster (F-CONFORM, F-REPORT).

The counts below were measured on the reference before the comparison fast path and the other speed
work: the same run must compare exactly as many states, events, observations and masks and evaluate
exactly as many invariant checks — over the in-process reference and over `agspec serve` alike.  A
speed-up that skipped a comparison or an invariant on some tick changes one of these numbers.
"""

from __future__ import annotations

import copy
import json
import math
import shutil

import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

from agspec.cli.main import cli
from agspec.conform.lockstep.compare import _canonical, _same_text, compare_reply
from agspec.formats.pointer import first_difference

SERVE = shutil.which("agspec")

# scenario -> (ticks, replies compared, invariant checks) for `--episodes 2 --horizon 20` (greedy + 1 random)
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
    result = CliRunner().invoke(cli, ["conform", "--impl", impl, "--no-suite", "--episodes", "2", "--horizon", "20",
                                      "-k", f"e-{scenario}-*", "--format", "json"], catch_exceptions=False)
    assert result.exit_code == 0, result.output[-2000:]
    footer = json.loads(result.output)["footer"]
    ticks, replies, checks = MEASURED[scenario]
    assert footer["ticks"] == ticks
    assert footer["replies_compared"] == footer["states_compared"] == replies
    assert footer["compared"] == {"events": replies, "state": replies, "observations": replies, "masks": replies}
    assert footer["invariant_checks"] == checks


# --------------------------------------------------------------------------- the fast equality is sound

JSON_SCALARS = st.none() | st.booleans() | st.integers(-3, 3) | st.floats(allow_nan=True, allow_infinity=True) | st.text(max_size=3)
JSON_VALUES = st.recursive(JSON_SCALARS, lambda inner: st.lists(inner, max_size=3)
                           | st.dictionaries(st.text(max_size=2), inner, max_size=3), max_leaves=12)


@settings(max_examples=400, deadline=None)
@given(JSON_VALUES, JSON_VALUES)
def test_fast_equality_never_hides_a_difference(e, a):
    """Equal bytes (or canonical text) only where the one comparison finds no difference: a boolean is
    not a number, NaN equals nothing, key order does not matter."""
    if _same_text(e, a):
        assert first_difference(e, a) is None
    finite = _canonical(e) is not None  # no NaN or infinity: the fast test decides equal copies itself
    assert _same_text(e, copy.deepcopy(e)) is finite


@pytest.mark.parametrize("e, a, same", [
    ([True], [1], False), ({"x": 0}, {"x": False}, False), ([math.nan], [math.nan], False),
    ({"a": 1, "b": [0.5]}, {"b": [0.5], "a": 1}, True), ([1.0], [1.0], True), ([math.inf], [math.inf], False),
])
def test_fast_equality_cases(e, a, same):
    assert _same_text(e, a) is same
    assert compare_reply(0, {"masks": e}, {"masks": a}, ["masks"]) is None or not same
