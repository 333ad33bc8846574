"""``agspec conform`` and ``agspec diff`` give a failure one judgement (F-CONFORM-NONDETERMINISM,
F-CONFORM-HISTORY): a bounded share of benchmarks/fuzz_judgement.py (tests/judgement_cases.py)."""

from __future__ import annotations

from pathlib import Path

import pytest

from judgement_cases import judge

# a history-dependent wrapper and a leaking simulator (the whole set: benchmarks/fuzz_judgement.py)
CASES = [("every-50th", 50), ("leak_load", frozenset({"leak_load"}))]


@pytest.mark.parametrize("name, what", CASES, ids=[c[0] for c in CASES])
def test_conform_and_diff_judge_a_simulator_alike(name, what, tmp_path: Path):
    wrong, comparable = judge(what, tmp_path)
    assert wrong == []
    assert comparable  # each of these fails under both commands: the comparison is not vacuous


def test_a_simulator_with_a_coin_per_process_is_never_called_deterministic_wrongly(tmp_path: Path):
    """A coin per process: whichever verdict each command reaches, none is wrong (no history named)."""
    wrong, _ = judge(frozenset({"coin"}), tmp_path)
    assert wrong == []
