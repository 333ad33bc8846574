"""RES-STREAM-INPUT: every reading strategy gets one verdict, live and against a golden cache (a bounded
copy of benchmarks/fuzz_stream.py; tests/stream_cases.py)."""

from __future__ import annotations

from pathlib import Path

import pytest

from stream_cases import STRATEGIES, judge


@pytest.mark.parametrize("strategy", STRATEGIES)
def test_a_reading_strategy_is_judged_alike_live_and_golden(strategy, tmp_path: Path):
    assert judge(strategy, tmp_path) == []
