"""Every process agspec starts is gone when agspec is done (F-PROCESS-TEARDOWN): a bounded share of
benchmarks/fuzz_leaks.py (tests/process_leaks.py), one case per child kind, helper kind and exit path."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from process_leaks import HELPERS, KINDS, PATHS, run_case

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")

# each kind, each helper and each exit path at least once (the whole table: benchmarks/fuzz_leaks.py)
CASES = [(KINDS[i % len(KINDS)], HELPERS[i % len(HELPERS)], PATHS[i % len(PATHS)]) for i in range(7)]
CASES += [("policy-python", "group", "normal")]  # the repeat's fresh process in the caller's group


@pytest.mark.parametrize("kind, helper, path", CASES, ids=["-".join(c) for c in CASES])
def test_no_process_outlives_the_command(kind, helper, path, tmp_path: Path):
    wrong, _seconds, _code = run_case(kind, helper, path, tmp_path)
    assert wrong == []
