"""Verdicts a simulator author can trust: never a false "conformant", never a false "nonconformant",
never a crashed harness (F-CONFORM-LEVELS, F-TRACE-STATE, F-PROTOCOL-UNSUPPORTED, F-PROTOCOL-ERRORS,
F-CONFORM-NONDETERMINISM and RES-EXIT-NONDETERMINISTIC, F-PROTOCOL-TEARDOWN, F-REPRO, F-TRACE-CHECK,
F-CONFORM-COVERAGE).

Seeded mutants live in tests/mutants/mutant_registry.py (test_mutants.py runs them all); this file
runs the honest simulators of the same registry (``sim.py --honest NAME``), which must pass at their
level, and checks each harness failure class directly.
"""

from __future__ import annotations

import json
import os
import shlex
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest
from click.testing import CliRunner

from agspec.cli.main import cli
from agspec.conform import runner
from agspec.formats import protocol
from agspec.conform.cases import load_suite
from agspec.conform.impl import PythonImpl, SubprocessImpl
from agspec.conform.items import catalogue_episodes, from_case

HERE = Path(__file__).resolve().parent
SIM = HERE / "mutants" / "sim.py"
sys.path.insert(0, str(HERE / "mutants"))

import mutant_registry as registry  # noqa: E402  (tests/mutants/mutant_registry.py)
from test_mutants import workload_item  # noqa: E402


def honest(name: str) -> str:
    return shlex.join([sys.executable, str(SIM), "--honest", name])


def mutant(name: str) -> str:
    return shlex.join([sys.executable, str(SIM), "--mutant", name])


@pytest.fixture(autouse=True)
def _in_tmp(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)


# =============================================================================================== levels


@pytest.mark.parametrize("name", list(registry.HONEST))
def test_honest_simulator_passes_its_workload_at_its_level(name):
    h = registry.HONEST[name]
    summary = runner.run([workload_item(h)], honest(name), timeout=15.0)
    assert summary.exit_code == 0, [(r.item.id, o, r.message) for r, o in summary.results]
    assert runner.level_name(summary.level) == h.level
    assert summary.footer()["conformant"] == (h.level == "full")  # plain "conformant" only at full level


@pytest.mark.parametrize("name", ["state-only", "events-only", "own-bookkeeping", "no-events"])
def test_partial_simulators_pass_the_whole_suite_and_episodes(name):
    """No false "nonconformant": a state-only engine (its handoffs start and complete in one tick, so
    their events exist only as state changes), an events-only engine and an engine with its own
    bookkeeping (diagnostic fields differ, behaviour is the same) pass every suite case and lockstep
    episode they can be judged on; what they cannot be judged on is skipped, never failed."""
    items = [from_case(c) for c in load_suite()] + catalogue_episodes(1, 30)
    summary = runner.run(items, honest(name), timeout=15.0, jobs=2)
    bad = [(r.item.id, o, r.message) for r, o in summary.results if o not in ("pass", "skip")]
    assert bad == []
    assert summary.exit_code == 0 and runner.level_name(summary.level) == registry.HONEST[name].level
    if name == "state-only":
        assert summary.invariant_checks > 1000  # invariants ran, on derived activities where events are absent
    assert summary.counts["pass"] >= 9  # at least the nine catalogue episodes


def test_events_only_state_lie_is_not_called_conformant():
    """The issue's false "conformant": declares events only and lies in an undeclared state."""
    spec = mutant("events-only-state-lie")
    item = workload_item(registry.MUTANTS["events-only-state-lie"])
    summary = runner.run([item], spec, timeout=15.0)
    footer = summary.footer()
    assert footer["level"] == "events" and footer["compared"]["state"] == 0 and footer["states_compared"] == 0
    assert footer["conformant"] is False and footer["verdict"] == "conformant at level events"
    strict = runner.run([item], spec, timeout=15.0, require=runner.parse_level("state"))
    assert strict.exit_code == 1 and strict.missing == ("state",)
    assert strict.verdict.startswith("insufficient level")


def test_require_through_the_cli():
    args = ["conform", "--impl", honest("events-only"), "--no-suite", "--episodes", "1", "--horizon", "5",
            "-k", "e-flow-easy-greedy", "--format", "json"]
    ok = CliRunner().invoke(cli, args + ["--require", "events"])
    assert ok.exit_code == 0, ok.output
    footer = json.loads(ok.stdout)["footer"]
    assert footer["level"] == "events" and footer["required"] == ["events"]
    assert CliRunner().invoke(cli, args + ["--require", "full"]).exit_code == 1
    assert CliRunner().invoke(cli, args + ["--require", "velocity"]).exit_code == 2


class _Blind:
    """An adapter that declares nothing comparable: every item is skipped."""

    def handle(self, msg):
        reply = {"seq": msg["seq"], "ok": True}
        if msg["cmd"] == "start":
            reply.update(protocol=protocol.PROTOCOL, implementation={"name": "blind", "version": "0"},
                         capabilities={"observations": False, "masks": False, "privileged_state": False,
                                       "events": False})
        return reply


def test_vacuous_run_exits_3():
    item = workload_item(registry.HONEST["events-only"])
    summary = runner.run([item], "blind", impl=PythonImpl(_Blind, spec="blind"))
    assert summary.vacuous and summary.exit_code == 3 and summary.verdict == "vacuous"


# =============================================================================================== unsupported


def test_unsupported_is_a_skip_with_its_reason_and_no_restart():
    """Ten refusals used to exhaust the restarts and label later items crash/spawn."""
    custom = [from_case(c) for c in load_suite() if not c.instance["id"].startswith("ag32-")][:12]
    items = custom + catalogue_episodes(1, 4, ["flow-easy"])
    impl = SubprocessImpl(honest("official-only"), 15.0, max_restarts=2)
    try:
        summary = runner.run(items, "official-only", impl=impl)
    finally:
        impl.close()
    outcomes = [o for _, o in summary.results]
    assert outcomes[:12] == ["skip"] * 12 and outcomes[12] == "pass"
    assert impl.restarts == 0
    (reason, n), = summary.skips.items()
    assert n == 12 and "official" in reason
    assert summary.exit_code == 0 and summary.footer()["skips"] == {reason: 12}


def test_unsupported_only_where_an_instance_is_declined():
    with pytest.raises(protocol.Unsupported):
        protocol.check_reply("load", {"seq": 1, "ok": False, "error": {"code": "unsupported", "message": "no XOR"}})
    with pytest.raises(protocol.ProtocolError) as err:  # mid-episode it would hide a divergence
        protocol.check_reply("step", {"seq": 1, "ok": False, "error": {"code": "unsupported", "message": "x"}})
    assert err.value.code == "error_reply"


# =============================================================================================== malformed


@pytest.mark.parametrize("text, error", [
    ('{"t": NaN}', protocol.NonFinite), ('{"t": Infinity}', protocol.NonFinite),
    ('[-Infinity]', protocol.NonFinite), ("[" * 200_000 + "]" * 200_000, protocol.TooDeep),
    ("[" * 70 + "]" * 70, protocol.TooDeep),
])
def test_strict_decoder_rejects(text, error):
    with pytest.raises(error):
        protocol.loads(text)
    assert protocol.loads("[" * 60 + "]" * 60) is not None


class _NaN:
    def handle(self, msg):
        reply = _Blind().handle(msg)
        if msg["cmd"] == "start":
            reply["capabilities"] = {"observations": False, "masks": False, "privileged_state": True, "events": True}
        if msg["cmd"] == "reset":
            reply.update(t=0, state={"t": float("nan")}, events=[])
        return reply


def test_non_finite_in_an_in_process_reply_is_a_protocol_error(tmp_path):
    report = tmp_path / "r.jsonl"
    item = workload_item(registry.HONEST["events-only"])
    summary = runner.run([item], "nan", impl=PythonImpl(_NaN, spec="nan"), report_path=str(report))
    result, outcome = summary.results[0]
    assert outcome == "error" and result.failure["code"] == "non_finite" and result.failure["type"] == "protocol"
    lines = report.read_text().splitlines()
    assert json.loads(lines[-1])["type"] == "footer"  # the report is complete, not truncated at its header


def test_non_finite_in_traces_reproducers_and_expectations(tmp_path):
    from agspec.conform.repro import ReproError, load_reproducer
    from agspec.conform.expect import ExpectError, load_expectations
    from agspec.trace.read import read_trace

    trace = tmp_path / "t.jsonl"
    trace.write_text('{"type": "header", "x": NaN}\n')
    _, diags = read_trace(trace)
    assert any(d.code == "AG003" and "NaN" in d.message for d in diags)
    repro = tmp_path / "r.repro.json"
    repro.write_text('{"format": "agspec-repro/1", "execution_seed": Infinity}')
    with pytest.raises(ReproError, match="Infinity"):
        load_reproducer(repro)
    exp = tmp_path / "e.json"
    exp.write_text('{"c-1": {"outcome": "fail", "reason": NaN}}')
    with pytest.raises(ExpectError, match="NaN"):
        load_expectations(exp)


def test_gave_up_is_its_own_category():
    """A simulator that crashes on an instance: after max_restarts failures there the harness gives up on
    that instance (RES-GIVE-UP-SCOPE), and says so."""
    impl = SubprocessImpl(mutant("crash"), 15.0, max_restarts=1)
    item = workload_item(registry.MUTANTS["crash"])
    try:
        summary = runner.run([item] * 4, "crash", impl=impl)
    finally:
        impl.close()
    codes = [f"{r.failure['type']}/{r.failure['code']}" for r, _ in summary.results]
    assert codes[0] == "crash/exit" and codes[-1] == "gave_up/gave_up"
    assert "gave up on instance" in summary.results[-1][0].message
    assert protocol.CODES["gave_up"][0] == "gave_up" and protocol.CODES["spawn"][0] == "crash"


# =============================================================================================== teardown


WRAPPER = textwrap.dedent('''
    import os, runpy, subprocess, sys
    child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(600)"])
    with open(sys.argv[1], "w") as fh:
        fh.write(f"{os.getpid()} {child.pid}")
    sys.argv = [sys.argv[2], "--mutant", "hang"]
    runpy.run_path(sys.argv[0], run_name="__main__")
''')


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    try:  # a zombie is dead
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().split(")")[-1].split()[0] != "Z"
    except OSError:
        return False


# SIGINT's exit status is click's (its Abort); the teardown is what matters here
@pytest.mark.parametrize("sig, code", [(signal.SIGTERM, 143), (signal.SIGINT, None), (signal.SIGHUP, 129)])
def test_killing_conform_tears_down_the_simulator_group(tmp_path, sig, code):
    wrapper = tmp_path / "wrapper.py"
    wrapper.write_text(WRAPPER)
    pids = tmp_path / "pids"
    impl = shlex.join([sys.executable, str(wrapper), str(pids), str(SIM)])
    agspec = Path(sys.executable).parent / "agspec"
    proc = subprocess.Popen([str(agspec), "conform", "--impl", impl, "--no-suite", "--episodes", "1", "--horizon", "6",
                             "-k", "e-flow-easy-greedy", "--timeout", "120"], cwd=tmp_path,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 60
        while not pids.exists() or not pids.read_text().strip():
            assert time.monotonic() < deadline and proc.poll() is None
            time.sleep(0.1)
        sim_pid, child_pid = map(int, pids.read_text().split())
        time.sleep(3)  # let it reach the hanging step
        proc.send_signal(sig)
        proc.wait(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == code if code is not None else proc.returncode != 0
    deadline = time.monotonic() + 10
    while (_alive(sim_pid) or _alive(child_pid)) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not _alive(sim_pid) and not _alive(child_pid)


def test_serve_exits_on_end_of_input():
    agspec = Path(sys.executable).parent / "agspec"
    proc = subprocess.run([str(agspec), "serve"], input=b'{"cmd":"start","seq":1,"protocol":"agspec-protocol/1"}\n',
                          capture_output=True, timeout=60)
    assert proc.returncode == 0 and json.loads(proc.stdout.splitlines()[0])["ok"] is True


# =============================================================================================== reproducers


def test_every_reproducer_is_printed_and_in_the_report(tmp_path, monkeypatch):
    where = tmp_path / "repros"
    monkeypatch.setenv("AGSPEC_REPRO_DIR", str(where))
    args = ["conform", "--impl", mutant("obs-leak"), "--no-suite", "--episodes", "1", "--horizon", "3",
            "-k", "e-flow-easy-greedy"]
    result = CliRunner().invoke(cli, args + ["--format", "json"])
    assert result.exit_code == 1
    (path,) = json.loads(result.stdout)["footer"]["reproducers"]
    assert Path(path).is_file() and Path(path).parent.parent == where  # F-REPRO: one directory per implementation
    table = CliRunner().invoke(cli, args)
    assert f"reproducer written: {path}" in table.stderr and f"reproducer: {path}" in table.stdout
    assert not (tmp_path / ".agspec").exists()


# =============================================================================================== nondeterminism


@pytest.fixture
def coin(tmp_path, monkeypatch):
    """A fresh coin for the nondeterministic mutant: its first process diverges, later ones do not."""
    monkeypatch.setenv(registry.COIN_ENV, str(tmp_path / "coin"))


def test_diff_reports_a_nondeterministic_implementation(coin):
    inst = HERE / "mutants" / "instances" / "pair-1x2-flat.json"
    result = CliRunner().invoke(cli, ["diff", "--impl", "reference", "--impl", mutant("nondeterministic"),
                                      "--scenario", str(inst), "--horizon", "8", "--small", "0",
                                      "--controller", "greedy", "--format", "json", "-o", "out"])
    assert result.exit_code == runner.EXIT_NONDETERMINISTIC, result.output
    (finding,) = json.loads(result.stdout)["findings"]
    evidence = finding["nondeterministic"]["original"]  # fresh replays, judged as conform judges (F-CONFORM-HISTORY)
    assert evidence["replays"] >= 2 and evidence["reproduced"] < evidence["replays"]


def test_conform_reports_a_nondeterministic_implementation(coin):
    result = CliRunner().invoke(cli, ["conform", "--impl", mutant("nondeterministic"), "--no-suite", "--episodes",
                                      "1", "--horizon", "8", "-k", "e-flow-easy-greedy"])
    assert result.exit_code == runner.EXIT_NONDETERMINISTIC, result.output
    assert "NONDETERMINISTIC IMPLEMENTATION" in result.stdout


# =============================================================================================== check


def _trace(tmp_path: Path) -> list[dict]:
    path = tmp_path / "t.jsonl"
    run = CliRunner().invoke(cli, ["run", "flow-easy", "--horizon", "30", "--trace", str(path), "--format", "json"])
    assert run.exit_code == 0
    return [json.loads(line) for line in path.read_text().splitlines()]


def _check(tmp_path: Path, records: list[dict]):
    path = tmp_path / "x.jsonl"
    path.write_text("".join(json.dumps(r, sort_keys=True, separators=(",", ":")) + "\n" for r in records))
    result = CliRunner().invoke(cli, ["check", str(path), "--format", "json"])
    return result.exit_code, json.loads(result.stdout)


def test_check_passes_an_honest_trace_with_its_horizon(tmp_path):
    records = _trace(tmp_path)
    assert records[0]["horizon"] == 30
    code, out = _check(tmp_path, records)
    assert code == 0 and out["whole_trace"] == []


def test_check_catches_a_footer_lie(tmp_path):
    records = _trace(tmp_path)
    records[-1]["metrics"]["delivered"] += 1
    code, out = _check(tmp_path, records)
    assert code == 1 and [d["code"] for d in out["whole_trace"]] == ["AG605"]
    assert out["whole_trace"][0]["pointer"] == "/metrics/delivered"


def test_check_catches_an_early_stop_with_a_consistent_footer(tmp_path):
    records = _trace(tmp_path)
    cut = records[:-6] + [records[-1]]
    cut[-1]["ticks"] = len(cut) - 2
    cut[-1]["metrics"] = {}  # consistent: no metric to contradict
    code, out = _check(tmp_path, cut)
    assert code == 1 and [d["code"] for d in out["whole_trace"]] == ["AG608"]


def test_recomputed_metrics_equal_the_reference_footer_on_every_scenario():
    import io

    from agspec.catalogue import OFFICIAL_SCENARIOS, load_scenario_bundle
    from agspec.evaluate import run_episode
    from agspec.ir.instance import make_instance
    from agspec.trace.verify import recompute
    from agspec.formats.trace import TraceWriter

    for name in OFFICIAL_SCENARIOS:
        inst = make_instance(*load_scenario_bundle(name), index=0)
        buf = io.StringIO()
        run_episode(inst, "random", horizon=120, trace=TraceWriter(buf))
        records = [json.loads(line) for line in buf.getvalue().splitlines()]
        footer = records[-1]["metrics"]
        for key, value in recompute(records).items():
            assert footer[key] == pytest.approx(value) if isinstance(value, float) else footer[key] == value, key


# =============================================================================================== coverage


def test_the_suite_covers_every_field_action_class_event_type_and_value_class():
    """F-CONFORM-COVERAGE: a rounded 1/3 must meet a suite case that shows 1/3."""
    from agspec.conform.coverage.values import entries, value_coverage

    cov = value_coverage([from_case(c) for c in load_suite()])
    assert cov["uncovered"] == []
    assert set(cov["values"]) == set(entries())
    for cls in ("support_fraction_1/3", "support_fraction_2/3", "support_fraction_1/4", "xor_choice",
                "resource_at_capacity", "expiry_at_exact_tick"):
        assert cov["values"][f"value:{cls}"], cls


def test_value_classes_are_detected_and_missing_ones_reported():
    from agspec.conform.coverage.values import observe_run

    # R-SUPPORT-LIFECYCLE: a record open at its expires_at epoch (0) expires into epoch 1
    states = [{"t": 0, "products": [], "proposals": {"c": {"expires_at": 0, "supporters": ["0,0"]}}},
              {"t": 1, "products": [{"xor": {"g": "a"}}], "proposals": {}}]
    events = [{"type": "admission_failed", "candidate": "c", "reason": "expired"},
              {"type": "blocked", "cause": "resource"}]
    obs = [{"0,0": {"operation_options": [{"support": 1 / 3}]}}, {"0,0": {"operation_options": [{"support": 0.33}]}}]
    seen = observe_run(states, events, obs, [])
    assert {"value:expiry_at_exact_tick", "value:xor_choice", "value:resource_at_capacity",
            "value:support_fraction_1/3", "event:blocked"} <= seen
    assert not any(s.startswith("value:support_fraction_33") for s in seen)  # 0.33 is no fraction class
    # a record still eligible at epoch 1 that is gone at 1 did not expire on its clock
    early = [{**states[0], "proposals": {"c": {"expires_at": 1, "supporters": ["0,0"]}}}, states[1]]
    assert "value:expiry_at_exact_tick" not in observe_run(early, events, obs, [])


def test_a_run_reports_the_rules_it_exercised():
    items = catalogue_episodes(1, 5, ["flow-easy"])
    summary = runner.run(items, "reference")
    assert "R-PICK" in summary.rules_exercised and "R-RELEASE" in summary.rules_exercised
    assert "R-DELIVERY" not in summary.rules_exercised  # nothing is delivered in 5 ticks
    assert summary.footer()["rules_exercised"] == summary.rules_exercised


def test_diff_states_the_level_it_compared():
    """`agspec diff` against an events-only simulator says "no divergence" only at level events."""
    inst = HERE / "mutants" / "instances" / "pair-1x2-flat.json"
    result = CliRunner().invoke(cli, ["diff", "--impl", "reference", "--impl", mutant("events-only-state-lie"),
                                      "--scenario", str(inst), "--horizon", "8", "--small", "0",
                                      "--controller", "greedy", "--format", "json", "-o", "out"])
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout)["level"] == "events"


# =============================================================================================== symbolic actions


def test_an_illegal_symbolic_action_is_one_behaviour_in_conform_and_diff():
    """F-SYMBOLIC-ACTIONS: an option not offered makes the script invalid in conform and in diff alike
    (never idle on one side and an exception on the other)."""
    from agspec.conform.explore import diff as D
    from agspec.conform.impl import ReferenceImpl
    from agspec.conform.items import Item
    from agspec.conform.run_item import Options, run_item

    inst = json.loads((HERE / "mutants" / "instances" / "pair-1x2-flat.json").read_text(encoding="utf-8"))
    seed = inst["seeds"]["execution"]
    script = ({"0,0": {"support": "op:0:no-such-operation:0,0"}},)
    item = Item(id="illegal", kind="replay", title="illegal", instance=inst, execution_seed=seed, ticks=1,
                actions=script)
    res = run_item(item, ReferenceImpl(), Options())
    assert res.outcome == "error" and "invalid" in res.message
    pair = D.open_pair("reference", "reference")
    try:
        run = D.replay(pair, inst, seed, list(script), 1)
    finally:
        pair.close()
    assert run.invalid and run.divergence is None and run.actions == []


# --------------------------------------------------------------------------- reply pipes


SERVE = [sys.executable, "-c", "from agspec.cli.main import main; main()", "serve"]


@pytest.mark.skipif(not hasattr(__import__("fcntl"), "F_GETPIPE_SZ"), reason="pipe sizes are Linux-only")
def test_the_reply_pipe_holds_several_pipelined_replies():
    """~100 KB replies: a 64 KiB pipe would block the simulator on every pipelined reply (F-GOLDEN)."""
    import fcntl

    impl = SubprocessImpl(SERVE, timeout=20.0)
    try:
        impl.start()
        assert fcntl.fcntl(impl.proc.stdout.fileno(), fcntl.F_GETPIPE_SZ) == SubprocessImpl.PIPE_BYTES
    finally:
        impl.close()


def test_a_pipe_size_the_os_refuses_falls_back_to_the_default_pipe(monkeypatch):
    real = subprocess.Popen
    refused = []

    def popen(*args, **kwargs):
        if "pipesize" in kwargs:
            refused.append(kwargs["pipesize"])
            raise PermissionError(1, "Operation not permitted")
        return real(*args, **kwargs)

    monkeypatch.setattr(subprocess, "Popen", popen)
    impl = SubprocessImpl(SERVE, timeout=20.0)
    try:
        assert impl.start()["protocol"] == protocol.PROTOCOL and refused == [SubprocessImpl.PIPE_BYTES]
    finally:
        impl.close()
    missing = SubprocessImpl(["/nonexistent/simulator"], timeout=5.0)
    with pytest.raises(protocol.ProtocolError) as info:
        missing.start()
    assert info.value.code == "spawn"
