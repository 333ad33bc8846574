"""Differential testing and shrinking (agspec.conform.explore.diff, agspec.conform.explore.shrink, `agspec diff`).

The implementations under test are the reference (in process) and the protocol adapter of
tests/mutants/sim.py, with and without a seeded mutant.
"""

from __future__ import annotations

import json
import shlex
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

from agspec.cli.main import cli
from agspec.conform.explore import diff as D
from agspec.formats import actions
from agspec.conform.explore import shrink as S
from agspec.conform.cases import check_reference, lint_suite, load_suite

HERE = Path(__file__).resolve().parent
SIM = HERE / "mutants" / "sim.py"
INSTANCES = HERE / "mutants" / "instances"


def sim(mutant: str | None = None) -> str:
    cmd = [sys.executable, str(SIM)] + (["--mutant", mutant] if mutant else [])
    return shlex.join(cmd)


def subject(name: str) -> D.Subject:
    inst = json.loads((INSTANCES / name).read_text(encoding="utf-8"))
    return D.Subject(inst["id"], inst, inst["seeds"]["execution"])


@pytest.fixture
def pair_factory():
    opened = []

    def make(a: str, b: str, timeout: float = 5.0) -> D.Pair:
        pair = D.open_pair(a, b, timeout=timeout)
        opened.append(pair)
        return pair

    yield make
    for pair in opened:
        pair.close()


# --------------------------------------------------------------------------- no false alarms


def test_reference_vs_reference_finds_nothing(pair_factory):
    pair = pair_factory("reference", "reference")
    subjects = [subject("pair-1x2-flat.json"), subject("bench-3x2-flat.json")]
    subjects += D.catalogue_subjects("coalition-medium", [0])
    result = D.explore(pair, subjects, controllers=("random", "greedy"), seed=3, ticks=25, first_only=False)
    assert result.findings == []
    assert result.episodes == 6 and result.ticks >= 6 * 20  # vacuity guard: ticks were really compared


def test_reference_vs_unmutated_adapter_finds_nothing(pair_factory):
    """tests/mutants/sim.py without a mutant agrees with the reference tick by tick, observations and masks
    included, on catalogue and small generated instances."""
    pair = pair_factory("reference", sim())
    assert set(pair.parts()) >= {"state", "events", "observations", "masks", "done"}
    subjects = D.catalogue_subjects("flow-easy", [0]) + D.small_instances("coalition-easy", 2, seed=1)
    result = D.explore(pair, subjects, controllers=("random", "greedy"), seed=0, ticks=20, first_only=False)
    assert result.findings == []
    assert result.ticks >= len(subjects) * 2 * 15


def test_hypothesis_sequences_find_nothing_on_equal_implementations(pair_factory):
    pair = pair_factory("reference", "reference")
    found, tried = D.hypothesis_search(pair, [subject("duo-1x2-flat.json")], examples=15, ticks=10, seed=0)
    assert found is None and tried >= 15


# --------------------------------------------------------------------------- finding and shrinking


def test_mutant_divergence_is_shrunk_and_still_diverges(pair_factory):
    pair = pair_factory("reference", sim("wip-drift"))
    # legal actions only (F-DIFF-ACTIONS rate 0): the story below is the shrinker's from that episode
    result = D.explore(pair, [subject("solo-1x2-flat.json")], controllers=("random",), seed=0, ticks=30,
                       illegal_rate=0.0)
    assert len(result.findings) == 1
    run = result.findings[0].run
    assert run.divergence.where == "state" and run.divergence.pointer == "/wip"
    original = list(D.non_idle(run.script))

    shrunk = S.shrink(pair, subject("solo-1x2-flat.json").instance, 0, run.script, run.divergence)
    kept = list(D.non_idle(shrunk.script))
    assert len(kept) < len(original)
    assert shrunk.divergence.signature() == run.divergence.signature()
    # the minimal story: pick, process, hand to the output column, deliver
    kinds = [next(iter(a)) if isinstance(a, dict) else a for _, _, a in kept]
    assert kinds == ["pick", "support", "handoff", "receive", "deliver"]
    assert any(note.startswith("horizon") for note in shrunk.instance_notes)

    again = D.replay(pair, shrunk.instance, shrunk.execution_seed, shrunk.script, shrunk.ticks)
    assert again.divergence is not None
    assert again.divergence.signature() == run.divergence.signature()
    same = D.replay(pair_factory("reference", "reference"), shrunk.instance, 0, shrunk.script, shrunk.ticks)
    assert same.divergence is None


def test_shrinking_removes_noise_actions(pair_factory):
    """An episode padded with irrelevant actions shrinks back to the three actions that matter."""
    pair = pair_factory("reference", sim("dup-handoff"))
    inst = subject("pair-1x2-flat.json").instance
    script = [{"0,0": {"pick": "pick:0:A:0"}, "0,1": {"receive": "W"}}, {"0,1": {"receive": "W"}},
              {"0,0": "idle", "0,1": {"receive": "W"}}, {"0,0": {"handoff": "E"}, "0,1": {"receive": "W"}},
              {"0,0": {"receive": "E"}, "0,1": {"receive": "W"}}]
    run = D.replay(pair, inst, 0, script)
    assert run.divergence is not None and run.divergence.pointer == "/robots/0,0/holding"
    shrunk = S.shrink(pair, inst, 0, run.script, run.divergence)
    assert [(t, r, a) for t, r, a in D.non_idle(shrunk.script)] == [
        (0, "0,0", {"pick": "pick:0:A:0"}), (1, "0,0", {"handoff": "E"}), (1, "0,1", {"receive": "W"})]
    assert shrunk.ticks == 2


def test_hypothesis_search_finds_a_minimal_sequence(pair_factory):
    pair = pair_factory("reference", sim("dup-handoff"))
    found, tried = D.hypothesis_search(pair, [subject("pair-1x2-flat.json")], examples=200, ticks=10, seed=1)
    assert found is not None, f"no divergence in {tried} sequences"
    assert found.run.divergence.where == "state"
    assert found.run.divergence.pointer.endswith("/holding")
    # hypothesis' own shrinking: everything but the pick and the handoff pair is idle
    assert len(list(D.non_idle(found.run.script))) == 3


def test_crash_is_an_error_divergence(pair_factory):
    pair = pair_factory("reference", sim("crash"), timeout=3.0)
    sub = D.catalogue_subjects("flow-easy", [0])[0]
    run = D.lockstep(pair, sub.instance, sub.execution_seed, D.ControllerPolicy("greedy", 1), 10)
    d = run.divergence
    assert d is not None and d.where == "error" and d.side == "B" and d.tick == 3
    assert d.pointer.startswith("crash")


# --------------------------------------------------------------------------- the saved case


def test_saved_case_replays_in_the_suite_format(pair_factory, tmp_path):
    pair = pair_factory("reference", sim("role-reassign"))
    inst = subject("pair-1x2-flat.json").instance
    result = D.explore(pair, [subject("pair-1x2-flat.json")], controllers=("greedy",), seed=1, ticks=12)
    run = result.findings[0].run
    shrunk = S.shrink(pair, inst, 0, run.script, run.divergence)
    path = S.write_case(shrunk, tmp_path, "role", title="roles rotate mid-activity")
    cases = load_suite(tmp_path)
    assert len(cases) == 1 and cases[0].source == path
    assert check_reference(cases[0]) == []  # the expectation is the reference's value
    assert lint_suite(cases) == []
    exp = cases[0].expectations[0]
    assert exp["after_tick"] == shrunk.divergence.tick
    assert list(exp["state"]) == [shrunk.divergence.pointer]


# --------------------------------------------------------------------------- units


def test_ddmin_is_one_minimal():
    calls = []

    def needs_3_and_7(subset):
        calls.append(list(subset))
        return 3 in subset and 7 in subset

    assert S.ddmin(list(range(20)), needs_3_and_7) == [3, 7]
    assert S.ddmin([5], lambda s: True) == []
    assert len(calls) < 60


def test_symbolic_actions_round_trip():
    obs = {"pick_options": [{"id": "pick:0:A:0"}, {"id": "pick:1:A:0"}],
           "operation_options": [{"id": "op:0:fit:0,0"}, {"id": "op:0:fit:0,0;0,1"}]}
    ids = actions.option_ids(obs)
    for action in (0, 1, 3, 36, 45, 51):
        assert actions.resolve(actions.symbolic(action, *ids), *ids) == action
    assert actions.symbolic(51, *ids) == {"support": "op:0:fit:0,0;0,1"}
    with pytest.raises(actions.IllegalAction):  # F-SYMBOLIC-ACTIONS: an option no longer offered
        actions.resolve({"support": "op:9:gone:0,0"}, *ids)
    assert D.generalize("/proposals/op:0:fit:0,0;0,1/expires_at") == "/proposals/*/expires_at"


def test_instance_reductions_validate():
    import copy

    inst = subject("solo-1x2-flat.json").instance
    reductions = list(S.instance_reductions(inst, 3))
    assert reductions and reductions[0][0] == "horizon 40 -> 4, products 11 -> 2"
    small = reductions[0][1]
    assert small["scenario"]["evaluation"]["horizon"] == 4 and len(small["realization"]["products"]) == 2
    assert small["id"].endswith("-shrunk")
    # a recipe of the mix that no remaining product uses is dropped
    two = copy.deepcopy(inst)
    two["recipes"]["solo2"] = {**copy.deepcopy(inst["recipes"]["solo"]), "id": "solo2"}
    two["scenario"]["recipes"] = ["solo", "solo2"]
    notes = dict(S.instance_reductions(two, 3))
    assert "recipes solo2 removed" in notes
    assert list(notes["recipes solo2 removed"]["recipes"]) == ["solo"]


def test_shrinking_reduces_the_instance_step_by_step(pair_factory):
    """Reductions compose: the horizon cut and the recipe removal are both kept."""
    import copy

    pair = pair_factory("reference", sim("wip-drift"))
    inst = copy.deepcopy(subject("solo-1x2-flat.json").instance)
    inst["recipes"]["solo2"] = {**copy.deepcopy(inst["recipes"]["solo"]), "id": "solo2"}
    inst["scenario"]["recipes"] = ["solo", "solo2"]
    run = D.lockstep(pair, inst, 0, D.ControllerPolicy("greedy", 0), 20)
    assert run.divergence is not None
    shrunk = S.shrink(pair, inst, 0, run.script, run.divergence)
    assert shrunk.instance["scenario"]["evaluation"]["horizon"] == shrunk.ticks
    assert list(shrunk.instance["recipes"]) == ["solo"]
    assert len(shrunk.instance_notes) == 2


# --------------------------------------------------------------------------- the CLI


def test_cli_no_divergence(tmp_path):
    result = CliRunner().invoke(cli, ["diff", "--impl", "reference", "--impl", sim(), "--scenario",
                                      str(INSTANCES / "pair-1x2-flat.json"), "--horizon", "15", "-o", str(tmp_path)])
    assert result.exit_code == 0, result.output
    assert "no divergence" in result.output
    assert not list(tmp_path.iterdir())


def test_cli_divergence_is_shrunk_printed_and_saved(tmp_path):
    result = CliRunner().invoke(cli, ["diff", "--impl", "reference", "--impl", sim("deliver-early"), "--scenario",
                                      str(INSTANCES / "solo-1x2-flat.json"), "--horizon", "20", "-o",
                                      str(tmp_path), "--controller", "greedy"])
    assert result.exit_code == 1, result.output
    out = result.output
    assert "minimal counterexample" in out and ("in the reply to step 3 (the joint action of epoch 3 \u2192 the state of epoch 4): "
                                                   "state /products/0/delivered_at") in out
    assert "expected (reference)" in out and "t=3    0,1    deliver" in out
    cases = list((tmp_path / "cases").glob("*.yaml"))
    repros = list(tmp_path.glob("*.repro.json"))
    assert len(cases) == 1 and len(repros) == 1
    data = json.loads(repros[0].read_text())
    assert data["format"] == "agspec-repro/1" and data["failure"]["pointer"] == "/products/0/delivered_at"

    # the harness replays both: the case as a suite, the reproducer with --replay
    runner = CliRunner()
    for impl, code in ((sim("deliver-early"), 1), ("reference", 0)):
        as_suite = runner.invoke(cli, ["conform", "--impl", impl, "--suite", str(tmp_path), "--episodes", "0",
                                       "--format", "json", "--repro-dir", str(tmp_path / "repro")])
        assert as_suite.exit_code == code, as_suite.output
        assert json.loads(as_suite.stdout)["footer"]["total"] == 1
        replayed = runner.invoke(cli, ["conform", "--impl", impl, "--replay", str(repros[0]), "--format", "json",
                                       "--repro-dir", str(tmp_path / "repro")])
        assert replayed.exit_code == code, replayed.output
    failure = json.loads(runner.invoke(cli, ["conform", "--impl", sim("deliver-early"), "--suite", str(tmp_path),
                                             "--episodes", "0", "--format", "json", "--repro-dir",
                                             str(tmp_path / "repro")]).stdout)["results"][0]["failure"]
    assert failure["path"] == "/state/products/0/delivered_at" and "INV-ACCOUNTING" in failure["ids"]


def test_cli_json_report_and_error_exit(tmp_path):
    result = CliRunner().invoke(cli, ["diff", "--impl", "reference", "--impl", sim("garbage"), "--scenario",
                                      "flow-easy", "--small", "0", "--horizon", "5", "-o", str(tmp_path),
                                      "--format", "json", "--shrink-budget", "5"])
    assert result.exit_code == 3, result.output
    report = json.loads(result.output)
    assert report["findings"][0]["divergence"]["where"] == "error"
    assert report["findings"][0]["divergence"]["pointer"] == "protocol/malformed_json"


def test_cli_usage_errors(tmp_path):
    runner = CliRunner()
    one = runner.invoke(cli, ["diff", "--impl", "reference"])
    assert one.exit_code == 2 and "exactly two" in one.output
    bad = runner.invoke(cli, ["diff", "--impl", "reference", "--impl", "reference", "--scenario", "no-such-scenario"])
    assert bad.exit_code == 2 and "no-such-scenario" in bad.output


# --------------------------------------------------------------------------- generated recipes


@pytest.fixture(scope="module")
def unmutated_pair():
    pair = D.open_pair("reference", sim())
    yield pair
    pair.close()


def _instance_for(recipe: dict) -> dict | None:
    """A small instance around a generated recipe: 2 x 3 grid, the flat profile, frequent releases."""
    import copy

    from agspec.ir.instance import make_instance
    from agspec.ir.schemas import validate_schema
    from agspec.ir.validate import errors, validate_instance

    base = subject("solo-1x2-flat.json").instance
    scenario = copy.deepcopy(base["scenario"])
    scenario.update(id="generated", grid={**scenario["grid"], "rows": 2, "cols": 3}, recipes=[recipe["id"]],
                    release={"interval": 3, "wip_cap": 2}, evaluation={"mode": "continuing", "horizon": 20})
    profile = {k: v for k, v in base["profile"].items() if k != "variant"}
    try:
        inst = make_instance(scenario, {recipe["id"]: recipe}, profile, generation_seed=5)
    except Exception:
        return None
    if errors(validate_schema(inst)) or errors(validate_instance(inst)):
        return None
    return inst


def test_generated_recipes_never_diverge_on_the_unmutated_adapter(unmutated_pair):
    """Property: on instances built around hypothesis-generated recipes (tests/strategies.py: XOR groups,
    resources, odd names needing JSON Pointer escapes), the subprocess adapter and the reference agree."""
    from hypothesis import HealthCheck, assume, given, settings
    from hypothesis import strategies as st

    from strategies import recipes

    @settings(max_examples=12, deadline=None, database=None, suppress_health_check=list(HealthCheck))
    @given(recipes(max_raw=2, max_ops=3), st.sampled_from(["random", "greedy"]), st.integers(0, 9))
    def check(recipe, controller, seed):
        inst = _instance_for(recipe)
        assume(inst is not None)
        run = D.lockstep(unmutated_pair, inst, 0, D.ControllerPolicy(controller, seed), 15)
        assert run.divergence is None, run.divergence.show()

    check()
