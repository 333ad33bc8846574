"""F-OUTPUT-FAILURES (spec/09-formats.md): every output of every command, on every failure of the place
it goes, ends with exit 2 (0 for a closed pipe), one located message, no traceback and no half-written
result. The table and its judge are in tests/output_failures.py; benchmarks/output_failures.py runs it
whole with its figures.  The quick tier runs a covering sample of the table (every output and every
failure at least once, tests/tiers.py); the extended tier the rest of it."""

from __future__ import annotations

import importlib.util

import pytest

from output_failures import OUTPUTS, cases, make_inputs, run_case, train_outputs
from tiers import sample_params

TABLE = cases(OUTPUTS + (train_outputs() if importlib.util.find_spec("torch") else ()))


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    base = tmp_path_factory.mktemp("outputs")
    return base, make_inputs(base)


@pytest.mark.parametrize(("output", "target"), sample_params(TABLE, [f"{o.name}|{t}" for o, t in TABLE],
                                                              key=lambda case: (case[0].name, case[1])))
def test_output_failure(output, target, inputs):
    base, files = inputs
    outcome = run_case(output, target, base, files)
    if outcome.problems and outcome.problems[0].startswith("skip:"):
        pytest.skip(outcome.problems[0])
    assert outcome.ok, f"{output.name} -> {target} ({outcome.path}): " + "; ".join(outcome.problems) + \
        "\n" + outcome.stderr[-1500:]
