"""A run cut anywhere and resumed is the run never cut (spec/16-training.md, T-RESUME): a bounded search
over algorithms and cut points, and seeded resumption bugs that the comparison must catch.  The long
search over every cut point is benchmarks/fuzz_resume.py."""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

torch = pytest.importorskip("torch", reason="the trainer needs PyTorch: pip install 'agspec[train]'")
torch.set_num_threads(1)

from train_cuts import MUTANTS, cut_and_resume, cut_config, differences, mutant, outcome  # noqa: E402

from agspec.train.api import train  # noqa: E402

ROWS = 5  # budget 40, a row every 8 steps


@pytest.fixture(scope="module")
def uncut(tmp_path_factory):
    """The uncut run of each algorithm, computed once."""
    root = tmp_path_factory.mktemp("uncut")
    cache = {}

    def get(algorithm):
        if algorithm not in cache:
            config = cut_config(algorithm, root)
            train(config, root / algorithm)
            cache[algorithm] = (config, outcome(root / algorithm))
        return cache[algorithm]
    return get


@settings(max_examples=4, deadline=None, database=None, suppress_health_check=list(HealthCheck))
@given(algorithm=st.sampled_from(["ippo", "mappo", "qmix"]), cut_row=st.integers(1, ROWS - 1), cuts=st.integers(1, 2))
def test_any_cut_resumes_to_the_uncut_run(uncut, tmp_path_factory, algorithm, cut_row, cuts):  # T-RESUME
    config, expected = uncut(algorithm)
    got = cut_and_resume(config, tmp_path_factory.mktemp("cut") / "run", cut_row, cuts)
    assert differences(expected, got) == []


@pytest.mark.parametrize("name", MUTANTS)
def test_a_resumption_bug_is_caught(name, uncut, tmp_path):  # T-RESUME
    config, expected = uncut("ippo")
    with mutant(name):
        got = cut_and_resume(config, tmp_path / "run", cut_row=3)
    assert differences(expected, got) != []
