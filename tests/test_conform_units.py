"""Units of the harness: JSON comparison (pointers, exact floats, tolerance), -k expressions, the
protocol's reply checks and error classes, the reference server's robustness, the schemas."""

from __future__ import annotations

import io
import json

import pytest
from jsonschema import Draft202012Validator

from agspec.formats import protocol
from agspec.conform.lockstep.compare import MISSING, compare_reply, first_difference
from agspec.conform.expect import Expected, apply
from agspec.conform.impl import PythonImpl, ReferenceImpl
from agspec.formats.protocol import ProtocolError
from agspec.conform.select import SelectError, compile_filter
from agspec.conform.impl.serve import Server, serve_stdio
from agspec.resources import schemas_dir


@pytest.fixture(scope="module")
def tiny_instance() -> dict:
    from agspec.resources import conformance_dir

    return json.loads((conformance_dir() / "instances" / "solo-1x2-wip1-flat.json").read_text(encoding="utf-8"))


# --------------------------------------------------------------------------- compare


def test_first_difference_pointer_and_order():
    a = {"robots": {"0,1": {"holding": "0:A", "q": [0.0, 1.5]}}, "t": 3, "a/b": 1}
    b = {"robots": {"0,1": {"holding": None, "q": [0.0, 1.5]}}, "t": 4, "a/b": 1}
    assert first_difference(a, b) == ("/robots/0,1/holding", "0:A", None)  # sorted keys: "a/b" < "robots" < "t"
    assert first_difference({"a/b": 1}, {"a/b": 2}) == ("/a~1b", 1, 2)
    assert first_difference([1, 2], [1, 2, 3]) == ("/2", MISSING, 3)
    assert first_difference({"x": 1}, {}) == ("/x", 1, MISSING)


def test_numbers_exact_unless_tolerance():
    assert first_difference(1, 1.0) is None  # the same JSON number
    assert first_difference(True, 1) == ("", True, 1)  # a boolean is not a number
    assert first_difference(0.1 + 0.2, 0.3) is not None
    assert first_difference(0.1 + 0.2, 0.3, tolerance=1e-12) is None
    assert first_difference([0.5], [0.6], tolerance=1e-12) == ("/0", 0.5, 0.6)


def test_compare_reply_order_and_more():
    exp = {"t": 3, "state": {"a": 1, "b": 2, "c": 3}, "events": [], "done": False}
    act = {"t": 3, "state": {"a": 9, "b": 8, "c": 3}, "events": [{"type": "release"}], "done": False}
    div = compare_reply(2, exp, act, ["t", "state", "events", "done"])
    assert (div.where, div.pointer, div.path, div.more) == ("state", "/a", "/state/a", ("/b",))
    assert compare_reply(2, exp, dict(act, state=exp["state"]), ["t", "state", "events"]).where == "events"
    assert compare_reply(2, exp, dict(exp), ["t", "state", "events", "done"]) is None


# --------------------------------------------------------------------------- -k


class _It:
    def __init__(self, id, title="", tags=(), rules=(), invariants=(), kind="case"):
        self.id, self.title, self.tags, self.rules, self.invariants, self.kind = id, title, tags, rules, invariants, kind
        self.location = None


def test_keyword_expressions():
    items = [_It("c-aaa111", "handoff completes", ("handoff",), ("R-HANDOFF",)),
             _It("e-flow-easy-greedy", "flow", kind="episode"),
             _It("e-flow-easy-random-1", "flow", kind="episode")]
    ids = lambda expr: [i.id for i in items if compile_filter(expr)(i)]  # noqa: E731
    assert ids("R-HANDOFF") == ["c-aaa111"]
    assert ids("r-handoff") == ["c-aaa111"]
    assert ids("flow and not random") == ["e-flow-easy-greedy"]
    assert ids("c-aaa*") == ["c-aaa111"]
    assert ids("episode") == ["e-flow-easy-greedy", "e-flow-easy-random-1"]
    assert ids("handoff, random") == ["c-aaa111", "e-flow-easy-random-1"]
    assert ids("(flow or handoff) and not greedy") == ["c-aaa111", "e-flow-easy-random-1"]
    for bad in ("flow and", "(flow", "or flow", "flow )"):
        with pytest.raises(SelectError):
            compile_filter(bad)


def test_expectation_outcomes():
    fail = Expected("fail")
    assert [apply(raw, fail) for raw in ("pass", "fail", "error", "skip")] == ["xpass", "xfail", "error", "skip"]
    assert apply("fail", None) == "fail"


# --------------------------------------------------------------------------- protocol


def test_check_reply_classifies():
    with pytest.raises(ProtocolError) as e:
        protocol.check_reply("step", {"seq": 1, "ok": False, "error": {"code": "boom", "message": "no"}})
    assert (e.value.kind, e.value.code) == ("protocol", "error_reply") and "boom" in e.value.message
    with pytest.raises(ProtocolError) as e:
        protocol.check_reply("step", {"seq": 1, "ok": True, "t": 1, "events": [], "done": False})
    assert e.value.code == "missing_field" and "state" in e.value.message
    caps = {"privileged_state": False, "events": True}
    protocol.check_reply("step", {"seq": 1, "ok": True, "t": 1, "events": [], "done": False}, caps)
    with pytest.raises(ProtocolError) as e:
        protocol.check_reply("start", {"seq": 1, "ok": True, "protocol": "agspec-protocol/9", "implementation": {},
                                       "capabilities": {}})
    assert e.value.code == "handshake"


class _Echo:
    """An adapter answering with a configurable seq."""

    def __init__(self, seq_of):
        self.inner, self.seq_of = Server(), seq_of

    def handle(self, msg):
        reply = self.inner.handle(msg)
        if msg["cmd"] == "reset":
            reply["seq"] = self.seq_of(msg["seq"])
        return reply


@pytest.mark.parametrize("seq_of, code", [(lambda s: s - 1, "out_of_order"), (lambda s: str(s), "wrong_seq"),
                                          (lambda s: s + 100, "wrong_seq")])
def test_seq_must_be_echoed(seq_of, code, tiny_instance):
    impl = PythonImpl(lambda: _Echo(seq_of))
    impl.load(tiny_instance)
    with pytest.raises(ProtocolError) as e:
        impl.reset(None)
    assert e.value.code == code


def test_adapter_exception_is_a_crash_then_restart(tiny_instance):
    crashes = []

    class Boom(Server):
        def handle(self, msg):
            if msg["cmd"] == "reset" and not crashes:
                crashes.append(1)
                raise RuntimeError("kaput")
            return super().handle(msg)

    impl = PythonImpl(Boom)
    impl.load(tiny_instance)
    with pytest.raises(ProtocolError) as e:
        impl.reset(None)
    assert (e.value.kind, e.value.code) == ("crash", "exception") and "kaput" in e.value.stderr
    # the next request restarts the adapter and replays start + load (Bowtie-style)
    assert impl.reset(None)["t"] == 0 and impl.restarts == 1


def test_reference_impl_round(tiny_instance):
    with ReferenceImpl(validate=True) as impl:
        info = impl.start()
        assert info["capabilities"] == {"observations": True, "masks": True, "privileged_state": True, "events": True,
                                        "diagnostic_state": True}
        impl.load(tiny_instance)
        r = impl.reset(None)
        assert r["t"] == 0 and r["state"]["t"] == 0
        r = impl.step({"0,0": 999})  # out of range: coerced to idle (R-ACTION-VALIDATION)
        assert r["t"] == 1 and r["applied"]["0,0"] == 0
        assert {"type": "action_coerced", "robot": "0,0", "action": 999} in r["events"]


# --------------------------------------------------------------------------- the reference server


def test_server_never_crashes_on_garbage(tiny_instance):
    lines = ["{not json", "[1,2]", json.dumps({"cmd": "start"}), json.dumps({"seq": 1}),
             json.dumps({"cmd": "dance", "seq": 2}),
             json.dumps({"cmd": "start", "seq": 3, "protocol": "agspec-protocol/0"}),
             json.dumps({"cmd": "reset", "seq": 4, "execution_seed": None}),
             json.dumps({"cmd": "load", "seq": 5, "instance": {"kind": "instance"}}),
             json.dumps({"cmd": "load", "seq": 6, "instance": tiny_instance}),
             json.dumps({"cmd": "step", "seq": 7, "actions": {}}),
             json.dumps({"cmd": "reset", "seq": 8, "execution_seed": "x"}),
             json.dumps({"cmd": "reset", "seq": 9, "execution_seed": 5}),
             json.dumps({"cmd": "step", "seq": 10, "actions": [1]}),
             json.dumps({"cmd": "step", "seq": 11, "actions": {"9,9": 0}}),
             json.dumps({"cmd": "step", "seq": 12, "actions": {"0,0": "pick"}}),
             json.dumps({"cmd": "step", "seq": 13, "actions": {"0,0": 0}}),
             json.dumps({"cmd": "stop", "seq": 14}),
             json.dumps({"cmd": "start", "seq": 15, "protocol": "agspec-protocol/1"})]  # after stop: not read
    out = io.StringIO()
    assert serve_stdio(io.StringIO("\n".join(lines) + "\n"), out) == 0
    replies = [json.loads(line) for line in out.getvalue().splitlines()]
    codes = [r["error"]["code"] if not r["ok"] else "ok" for r in replies]
    assert codes == ["bad_json", "bad_request", "bad_request", "unknown_cmd", "unknown_cmd", "unsupported_protocol",
                     "not_loaded", "invalid_instance", "ok", "not_reset", "bad_request", "ok", "bad_actions",
                     "bad_actions", "bad_actions", "ok", "ok"]
    for reply in replies:
        kind = "error" if not reply["ok"] else None
        if kind:
            assert protocol.validate("protocol/error", reply) == []



def test_the_reference_server_remembers_an_instance_s_schema_check_only_for_that_very_document(tiny_instance):
    """The load check is remembered per process (conform.impl.serve.schema_errors); documents whose JSON text
    may coincide — 12, 12.0 and true; NaN and null; a key 1 and "1" — each still get their own verdict."""
    import copy

    from agspec.ir.schemas import validate_schema

    def with_horizon(value):
        doc = copy.deepcopy(tiny_instance)
        doc["scenario"]["evaluation"]["horizon"] = value
        return doc

    keyed = copy.deepcopy(tiny_instance)
    keyed["seeds"][1] = keyed["seeds"].pop(next(iter(keyed["seeds"])))
    docs = [tiny_instance, with_horizon(None), with_horizon(float("nan")), with_horizon(12.5), with_horizon(True),
            with_horizon(12), with_horizon("12"), keyed, tiny_instance, with_horizon(None)]
    server = Server()
    server.handle({"cmd": "start", "seq": 1, "protocol": protocol.PROTOCOL})
    for seq, doc in enumerate(docs, 2):
        errors = [i for i in validate_schema(copy.deepcopy(doc)) if i.severity == "error"]
        reply = server.handle({"cmd": "load", "seq": seq, "instance": copy.deepcopy(doc)})
        if errors:
            assert reply["error"]["code"] == "invalid_instance"
            assert reply["error"]["message"].endswith(f"{errors[0].message} [{errors[0].code}]")
        else:
            assert reply["ok"] is True, reply


# --------------------------------------------------------------------------- schemas


@pytest.mark.parametrize("path", sorted(str(p.relative_to(schemas_dir())) for p in
                                        list(schemas_dir().glob("protocol/*.schema.json"))
                                        + [schemas_dir() / "trace.schema.json", schemas_dir() / "report.schema.json",
                                           schemas_dir() / "expectations.schema.json"]))
def test_schemas_are_draft_2020_12(path):
    doc = json.loads((schemas_dir() / path).read_text(encoding="utf-8"))
    assert doc["$schema"] == "https://json-schema.org/draft/2020-12/schema"
    Draft202012Validator.check_schema(doc)


def test_every_command_has_request_and_reply_schemas():
    for cmd in protocol.COMMANDS:
        protocol.validator(f"protocol/{cmd}.request")
        protocol.validator(f"protocol/{cmd}.reply")
    assert protocol.validate_request(protocol.reset(1, None)) == []
    assert protocol.validate_request({"cmd": "reset", "seq": 1})[0].code == "AG201"
