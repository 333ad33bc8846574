"""F-VALUES: a number is its value — ``6``, ``6.0``, ``6e0`` and ``60E-1`` get one verdict from the
comparison, the invariants, the expectations and ``agspec check``.

Generators: every number of an honest simulator's replies, and of a valid (or a violating) trace,
re-spelt at random (tests/reply_mutations.py ``respelt``); the verdict must not change.
"""

from __future__ import annotations

import json
import random
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from agspec.trace.check import check_file
from agspec.cli.main import cli
from agspec.conform import runner
from agspec.conform.run_item import Options
from agspec.formats import shape as shape_module
from agspec.formats.shape import ShapeError, compile_shape
from agspec.formats.trace import read_records, values_of
from agspec.resources import schemas_dir

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE / "fakes"))

from line_sim import LineSim  # noqa: E402
from reply_judge import item  # noqa: E402
from reply_mutations import dump, respelt  # noqa: E402


def _trace(directory: Path, name: str, *flags: str) -> Path:
    path = directory / name
    result = CliRunner().invoke(cli, ["run", "coalition-easy", "--horizon", "6", "--trace", str(path), *flags,
                                      "--format", "json"], catch_exceptions=False)
    assert result.exit_code == 0, result.output
    return path


@pytest.fixture(scope="module")
def traces(tmp_path_factory) -> dict[str, Path]:
    """A valid trace with observations, and one whose shelf stock breaks INV-CONSERVATION's bounds."""
    directory = tmp_path_factory.mktemp("values")
    good = _trace(directory, "good.jsonl", "--observations")
    records = [json.loads(line) for line in good.read_text("utf-8").splitlines()]
    row = records[4]["state"]["shelves"][0]
    row[next(iter(row))] += 50
    bad = directory / "bad.jsonl"
    bad.write_text("".join(json.dumps(r) + "\n" for r in records), encoding="utf-8")
    return {"good": (good, _verdict(good)), "bad": (bad, _verdict(bad))}


def _verdict(path: Path) -> dict:
    record = check_file(None, str(path))
    return {k: v for k, v in record.items() if k != "file"}


@settings(max_examples=8, deadline=None, database=None, suppress_health_check=list(HealthCheck))
@given(seed=st.integers(0, 2**32 - 1), which=st.sampled_from(["good", "bad"]), share=st.sampled_from([0.2, 1.0]))
def test_respelt_numbers_keep_the_check_verdict(traces, tmp_path_factory, seed, which, share):
    rng = random.Random(seed)
    source, verdict = traces[which]
    lines = source.read_bytes().splitlines()
    respelt_lines = [dump(respelt(json.loads(line), rng, share)) for line in lines]
    path = tmp_path_factory.mktemp("respelt") / "t.jsonl"
    path.write_bytes(b"\n".join(respelt_lines) + b"\n")
    assert _verdict(path) == verdict
    assert verdict["ok"] == (which == "good")


def test_integer_counters_written_as_floats_pass_the_invariants(traces, tmp_path):
    """The issue's instance: 6.0 units on a shelf row and float counters are integers (no INV violation)."""
    records = [json.loads(line) for line in traces["good"][0].read_text("utf-8").splitlines()]
    for rec in records:
        state = rec.get("state")
        if state:
            for k in ("released", "delivered", "wip", "lost_releases"):
                state[k] = float(state[k])
            state["shelves"] = [{tok: float(n) for tok, n in row.items()} for row in state["shelves"]]
    path = tmp_path / "floats.jsonl"
    path.write_text("".join(json.dumps(r) + "\n" for r in records), encoding="utf-8")
    assert '"released": 1.0' in path.read_text("utf-8")
    verdict = _verdict(path)
    assert verdict["ok"] and verdict["exit"] == 0, verdict["violations"][:3]
    assert type(read_records(path)[1]["state"]["released"]) is int


def test_an_honest_simulator_writing_every_number_respelt_conforms(tmp_path):
    """Every reply of the reference with all its numbers re-spelt (integers as 6.0, 6e0, 60E-1 ...) is the
    same reply: the run passes, live and with a golden trace."""
    cache = str(tmp_path / "golden")
    for golden_dir in (None, cache, cache):  # live; cold (records); warm
        sim = LineSim("*", lambda reply: _all_respelt(reply))
        try:
            summary = runner.run([item()], "line-sim", impl=sim, opts=Options(impl_spec="line-sim", golden_dir=golden_dir))
        finally:
            sim.close()
        assert [o for _, o in summary.results] == ["pass"], summary.records[0].get("failure")
        assert summary.records[0]["checks"]["invariant_checks"] > 0


def _all_respelt(reply):
    from reply_mutations import Mutation

    return Mutation("values", "all", dump(respelt(reply, random.Random(len(json.dumps(reply))))), same=True)


SHAPED = ["trace"] + sorted(f"protocol/{p.name.removesuffix('.schema.json')}"
                            for p in (schemas_dir() / "protocol").glob("*.reply.schema.json"))


@pytest.mark.parametrize("name", SHAPED)
def test_every_shaped_schema_compiles_without_an_opaque_union(name):  # F-PROTOCOL-SHAPE, F-VALUES
    """A union (anyOf / oneOf / not over value descriptions) would make its position opaque, and F-VALUES
    would silently stop below it (events written `6.0` stayed floats under `anyOf [events, null]`)."""
    compile_shape.cache_clear()
    compile_shape(name)


def test_an_opaque_union_in_a_shaped_schema_is_refused():  # F-PROTOCOL-SHAPE
    node = {"type": "object", "properties": {"events": {"anyOf": [{"type": "array", "items": {"type": "integer"}},
                                                                   {"type": "null"}]}}}
    with pytest.raises(ShapeError):
        shape_module._compile(node)
    only_required = {"type": "object", "not": {"anyOf": [{"required": ["horizon"]}]}}
    shape_module._compile(only_required)  # which members are required says nothing about values


def test_event_numbers_written_as_floats_are_integers_after_reading(traces):  # F-VALUES
    source, _ = traces["good"]
    records = [json.loads(line) for line in source.read_text("utf-8").splitlines()]
    record = next(r for r in records if r["type"] == "tick" and any(
        isinstance(v, int) and not isinstance(v, bool) for e in r["events"] for v in e.values()))
    ints = [(n, k) for n, e in enumerate(record["events"]) for k, v in e.items()
            if isinstance(v, int) and not isinstance(v, bool)]
    for n, k in ints:
        record["events"][n][k] = float(record["events"][n][k])
    values_of(record)
    assert all(type(record["events"][n][k]) is int for n, k in ints)
