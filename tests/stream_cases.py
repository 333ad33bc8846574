"""A simulator's way of reading its input is judged alike on every path (RES-STREAM-INPUT,
RES-GOLDEN-IDENTITY): reading strategies of tests/fakes/stream_sim.py run live (``--golden-cache off``) and
against a warm golden cache.

Shared by tests/test_stream_input.py and benchmarks/fuzz_stream.py.  Wrong: the two paths give other exit
codes or other outcomes, or a correct reader is not conformant.
"""

from __future__ import annotations

import json
import shlex
import sys
from pathlib import Path

from click.testing import CliRunner

from agspec.cli.main import cli

SIM = Path(__file__).resolve().parent / "fakes" / "stream_sim.py"
STRATEGIES = ("lines", "newline", "chunk", "fixed")
CORRECT = ("lines", "newline")
SELECT = ["--no-suite", "--episodes", "1", "--horizon", "12", "-k", "e-flow-easy-greedy or e-coalition-easy-greedy"]


def conform(impl: str, cache: str, tmp: Path) -> tuple[int, list[str]]:
    result = CliRunner().invoke(cli, ["conform", "--impl", impl, "--golden-cache", cache, "--format", "json",
                                      "--timeout", "2", "--repro-dir", str(tmp / "repro"), *SELECT])
    out = json.loads(result.stdout)
    return result.exit_code, [r.get("outcome") for r in out["results"]]


def judge(strategy: str, tmp: Path) -> list[str]:
    cache = tmp / "golden"
    code, _ = conform("reference", str(cache), tmp)  # warms the cache with the reference's replies
    assert code == 0
    impl = shlex.join([sys.executable, str(SIM), strategy])
    live, warm = conform(impl, "off", tmp), conform(impl, str(cache), tmp)
    wrong = []
    if live != warm:
        wrong.append(f"live: exit {live[0]} {live[1]}; golden: exit {warm[0]} {warm[1]}")
    if strategy in CORRECT and (live[0], warm[0]) != (0, 0):
        wrong.append(f"a correct reader is not conformant (live exit {live[0]}, golden exit {warm[0]})")
    if strategy in ("chunk", "fixed") and 0 in (live[0], warm[0]):
        wrong.append(f"a reader that drops requests passes (live exit {live[0]}, golden exit {warm[0]})")
    return wrong
