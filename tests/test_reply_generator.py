"""Whatever a simulator sends is judged as the simulator's (F-PROTOCOL-LINES, F-PROTOCOL-SHAPE,
F-VALUES), and a golden trace never changes the verdict on any byte sequence (RES-GOLDEN-IDENTITY).

The generator (tests/reply_mutations.py) mutates the reference's own replies — types, numbers, keys,
encodings, whitespace, line structure — and every mutation runs through the Python API of
``agspec conform`` live and with a warm golden cache (tests/reply_judge.py): never a harness error or
an escaped exception, the report always complete and schema-valid, the same verdict for a mutation
that keeps the reply, the one right code where there is one, the golden verdict equal to the live
one.  benchmarks/fuzz_replies.py is the long run.
"""

from __future__ import annotations

import copy
import json
import random
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from agspec.cli.main import cli
from agspec.conform.impl.serve import Server
from agspec.formats import reply, shape
from agspec.formats.report import read_report

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from reply_judge import CLASSES, POSITIONS, item, judge, run, verdict, warm_cache  # noqa: E402
from reply_mutations import NAMED, dump, mutate  # noqa: E402

LINE_SIM = HERE / "fakes" / "line_sim.py"


@pytest.fixture(scope="module")
def cache(tmp_path_factory) -> str:
    directory = str(tmp_path_factory.mktemp("golden"))
    warm_cache(directory)
    return directory


@settings(max_examples=60, deadline=None, database=None, suppress_health_check=list(HealthCheck))
@given(klass=st.sampled_from(CLASSES), target=st.sampled_from(POSITIONS), seed=st.integers(0, 2**32 - 1))
def test_every_mutated_reply_is_judged_as_the_simulators(cache, klass, target, seed):
    mutation, wrong = judge(klass, target, seed, cache)
    assert not wrong, (mutation.label if mutation else None, wrong)


@pytest.mark.parametrize("name", sorted(NAMED))
def test_each_reviewed_instance_gets_its_protocol_error(tmp_path, cache, name):
    """The instances a review of hostile simulators found, each with its code, live and golden alike."""
    target, _, code = NAMED[name]
    live = run(target, f"named:{name}", 0, None, tmp_path / "live.jsonl")
    warm = run(target, f"named:{name}", 0, cache, tmp_path / "warm.jsonl")
    for summary, _, record in (live, warm):
        assert not isinstance(summary, Exception)
        assert record["outcome"] == "error" and record["failure"]["type"] == "protocol"
        assert record["failure"]["code"] == code, record["failure"]["message"]
        assert summary.exit_code == 3
    assert verdict(live[2]) == verdict(warm[2])
    _, problems = read_report(tmp_path / "live.jsonl")
    assert problems == []


def test_a_wrong_type_names_its_pointer(tmp_path):
    summary, _, record = run("step:2", "named:robot-null", 0, None, tmp_path / "r.jsonl")
    failure = record["failure"]
    assert failure["code"] == "bad_field" and failure["pointer"].startswith("/state/robots/")
    assert failure["pointer"] in failure["message"]


@pytest.mark.parametrize("name", ["surrogate-start-name", "blank-lines-10000"])
def test_through_the_cli_a_simulator_process_never_gets_exit_4(tmp_path, name):
    """The real transport (a process, its stdout read line by line) and the CLI: exit 3, a complete and
    valid report — never an internal error (exit 4) with an empty report."""
    target = NAMED[name][0]
    impl = f"{sys.executable} {LINE_SIM} --target {target} --klass named:{name}"
    report = tmp_path / "r.jsonl"
    result = CliRunner().invoke(cli, ["conform", "--impl", impl, "--no-suite", "--episodes", "1", "--horizon", "3",
                                      "-k", "flow-easy", "-o", str(report), "--format", "json",
                                      "--repro-dir", str(tmp_path)])
    assert result.exit_code == 3, result.output[-2000:]
    records, problems = read_report(report)
    assert problems == [] and records[-1]["type"] == "footer"
    failure = next(r for r in records if r["type"] == "case")["failure"]
    assert failure["code"] == NAMED[name][2]


# --------------------------------------------------------------------------- the shape check itself


def _replies(ticks: int = 6):
    server = Server()
    server.handle({"cmd": "start", "seq": 1, "protocol": "agspec-protocol/1"})
    server.handle({"cmd": "load", "seq": 2, "instance": item().instance})
    out = [("reset", server.handle({"cmd": "reset", "seq": 3, "execution_seed": item().execution_seed}))]
    from agspec.controllers import make_controller

    ctl = make_controller("greedy", 0)
    ctl.reset(0)
    for t in range(ticks):
        acts = {r: int(a) for r, a in ctl.act(out[-1][1]["observations"], server.sim).items() if int(a)}
        out.append(("step", server.handle({"cmd": "step", "seq": 4 + t, "actions": acts})))
    return out


def test_the_references_replies_have_their_shape_untouched():
    """The in-process reference is not checked (trusted): its replies, decoded from its own lines,
    have their shape as they are (no F-VALUES rewriting needed)."""
    for cmd, value in _replies():
        decoded = reply.decode_line(dump(value))
        assert shape.checker(f"protocol/{cmd}.reply")(decoded)
        assert shape.conform(copy.deepcopy(decoded), f"protocol/{cmd}.reply") is None


@settings(max_examples=80, deadline=None, database=None, suppress_health_check=list(HealthCheck))
@given(seed=st.integers(0, 2**32 - 1), klass=st.sampled_from(["types", "keys", "numbers"]))
def test_the_fast_check_and_the_located_walk_agree(seed, klass):
    """shape.checker (closures) and the located walk decide alike: a value passes the fast check exactly
    when the walk finds no problem and rewrites nothing."""
    cmd, value = random.Random(seed).choice(_REPLIES)
    mutated = mutate(value, klass, random.Random(seed))
    try:
        decoded = reply.decode_line(mutated.data)
    except reply.LineError:
        return
    name = f"protocol/{cmd}.reply"
    before = json.dumps(decoded, sort_keys=True)
    fast = shape.checker(name)(decoded)
    problem = shape.conform(decoded, name)
    rewritten = json.dumps(decoded, sort_keys=True) != before
    assert fast == (problem is None and not rewritten), (mutated.label, problem)


_REPLIES = _replies(4)


def test_f_values_integral_numbers_are_integers_where_integers_are_required():
    cmd, value = _REPLIES[2]
    text = dump(value).replace(b'"released":', b'"released":1.0e0,"zz":', 1)
    decoded = reply.decode_line(text)
    assert shape.conform(decoded, f"protocol/{cmd}.reply") is None
    assert decoded["state"]["released"] == 1 and type(decoded["state"]["released"]) is int
    decoded["state"]["released"] = 1.5
    assert shape.conform(decoded, f"protocol/{cmd}.reply").pointer == "/state/released"
    decoded["state"]["released"] = float(2**53)
    assert shape.conform(decoded, f"protocol/{cmd}.reply").code == "bad_field"


@pytest.mark.parametrize("name", ["seq-leading-zeros", "seq-5000-zeros", "state-twice", "digits-5000"])
def test_a_golden_trace_recorded_in_process_gives_the_live_verdict(tmp_path, name):
    """Recorded from the trusted in-process reference (whose lines were never decoded, so the recorder
    passes each through the one decoder itself), the golden trace changes no verdict either."""
    from agspec.conform import runner
    from agspec.conform.impl import ReferenceImpl
    from agspec.conform.run_item import Options

    cache = str(tmp_path / "golden")
    reference = ReferenceImpl()
    try:
        recorded = runner.run([item()], "reference", impl=reference,
                              opts=Options(impl_spec="reference", golden_dir=cache))
    finally:
        reference.close()
    assert recorded.records[0]["outcome"] == "pass" and any(Path(cache).rglob("*.json"))
    target = NAMED[name][0]
    live = run(target, f"named:{name}", 0, None, tmp_path / "live.jsonl")
    warm = run(target, f"named:{name}", 0, cache, tmp_path / "warm.jsonl")
    assert verdict(live[2]) == verdict(warm[2]) and verdict(live[2])[2] == NAMED[name][2]
