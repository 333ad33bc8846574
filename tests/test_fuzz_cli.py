"""Hostile-input fuzzing of the whole CLI (F-LIMITS, F-EXIT-CODES): hypothesis damages a valid seed
file of each family (truncation, bad UTF-8, duplicated spans, stray punctuation, a value swapped for
another type, NaN, a 5,000-digit number, deep nesting, a 2 MB string) and runs every command that
reads that family on it. The property: exit 0, 1 or 2 — never an escaped exception (exit 4 with a
traceback) — a message when it fails, within the time limit. A bounded run; `benchmarks/fuzz_cli.py`
is the long one.
"""

from __future__ import annotations

import resource

import pytest
from hypothesis import HealthCheck, given, settings

from hostile_inputs import COMMANDS, FAMILIES, TRACEBACK, argv, invoke, mutations

# a few examples per command: the whole file runs in well under a minute on one core
EXAMPLES = {"conform-expect": 4, "conform-replay": 6, "diff": 4, "render-record": 4}
SKIP = {"diff"}  # lockstep runs of mutated instances take seconds each; covered by the exit-code table
MEMORY_CEILING_MIB = 2048


def check(command: str, data: bytes, tmp_path) -> None:
    family = FAMILIES[COMMANDS[command][0]]
    path = tmp_path / f"fuzz{family.suffix}"
    path.write_bytes(data)
    out = invoke(argv(command, path, tmp_path))
    assert not out.crashed, out.output[-3000:]
    assert not TRACEBACK.search(out.output)
    assert out.exit_code in (0, 1, 2), out.output[-3000:]
    if out.exit_code:
        assert out.output.strip(), "a failing command must say why"


@pytest.mark.parametrize("command", sorted(set(COMMANDS) - SKIP))
def test_hostile_inputs_never_crash_a_command(command, tmp_path_factory):
    family = FAMILIES[COMMANDS[command][0]]

    @settings(max_examples=EXAMPLES.get(command, 12), deadline=30_000, derandomize=True, database=None,
              suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.large_base_example])
    @given(mutations(family))
    def prop(data: bytes) -> None:
        check(command, data, tmp_path_factory.mktemp(command))

    prop()
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    assert peak < MEMORY_CEILING_MIB, f"peak RSS {peak:.0f} MiB"
