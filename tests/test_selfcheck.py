"""The reference obeys its own spec on generated valid scenarios (bounded self-check).

tests/strategies_scenarios.py draws whole scenarios across the space the DSL and IR accept and keeps
those `agspec validate` accepts; tests/reference_selfcheck.py checks each one: fmt fixpoint,
fingerprints, a trace under every reference controller and under random partly-illegal actions,
each checked as `agspec check` does (every INV-*, record count, footer), and one run repeated in a
fresh process (D-DETERMINISM). The long run is `python benchmarks/selfcheck.py --budget SECONDS`.
"""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings

from agspec.dsl.build import compile_text
from agspec.interp.model import Model
from agspec.ir import topology
from agspec.resources import catalogue_dir
from reference_selfcheck import check_bundle
from strategies_scenarios import bundle_errors, bundle_of, bundles, raw_bundles, realize

BOUNDED = settings(max_examples=5, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                         HealthCheck.filter_too_much])
LONG = settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                        HealthCheck.filter_too_much])


def _explain(tally) -> str:
    return "\n".join(f"{f.kind} [{f.run}] {f.detail[:400]}" for f in tally.findings[:12])


@BOUNDED
@given(bundles())
def test_reference_obeys_its_spec_on_generated_scenarios(tmp_path_factory, bundle):
    # D-TOPOLOGY, O-MASK, O-OBSERVATION, R-HANDOFF, R-ACTION-VALIDATION, F-DSL, F-FINGERPRINT
    tally = check_bundle(bundle, tmp_path_factory.mktemp("selfcheck"), horizon=25)
    assert tally.findings == [], f"{bundle.describe()}\n{_explain(tally)}\n" + "\n".join(bundle.texts.values())
    assert tally.runs == 5 and tally.ticks > 0  # four controllers and random actions, not vacuous


@pytest.mark.slow
@LONG
@given(bundles())
def test_reference_obeys_its_spec_on_many_generated_scenarios(tmp_path_factory, bundle):
    tally = check_bundle(bundle, tmp_path_factory.mktemp("selfcheck"), horizon=60)
    assert tally.findings == [], f"{bundle.describe()}\n{_explain(tally)}\n" + "\n".join(bundle.texts.values())


@settings(max_examples=1, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(bundles())
def test_a_run_is_byte_identical_in_a_fresh_process(tmp_path_factory, bundle):  # D-DETERMINISM
    tally = check_bundle(bundle, tmp_path_factory.mktemp("selfcheck"), horizon=20, controllers=("greedy",),
                         random_runs=0, cross_process="greedy")
    assert tally.findings == [], _explain(tally)


def test_the_validator_filter_keeps_most_draws():
    """The strategy covers valid scenarios, not mostly rejected ones: at least half of the raw draws
    pass `agspec validate` (benchmarks/selfcheck.py prints the rate of its runs)."""
    seen = {"drawn": 0, "valid": 0, "topologies": set()}

    @settings(max_examples=40, deadline=None, database=None, derandomize=True, suppress_health_check=list(HealthCheck))
    @given(raw_bundles())
    def draw(bundle):
        seen["drawn"] += 1
        if not bundle_errors(bundle):
            seen["valid"] += 1
            g = bundle.scenario["grid"]
            seen["topologies"].add((g["topology"], g["radius"]))

    draw()
    assert seen["valid"] >= seen["drawn"] / 2, seen
    assert len(seen["topologies"]) >= 4, seen  # several topology x radius pairs among 40 draws


def _ir(path: str) -> dict:
    _, built = compile_text((catalogue_dir() / path).read_text(encoding="utf-8"))
    return built.ir


def _line_bundle():
    """flow_serial_3 and solo_inspection on a 3 x 6 line grid (rows are separate lines, RES-TOPOLOGY-LINE)."""
    recipes = [_ir("recipes/flow_serial_3.ag"), _ir("recipes/solo_inspection.ag")]
    scenario = _ir("scenarios/flow-easy.ag")
    scenario.update(id="line-test", recipes=["flow_serial_3", "solo_inspection"],
                    grid={"rows": 3, "cols": 6, "topology": "line", "radius": 1})
    scenario["suite"] = {"official": False, "prefix": "lt", "generation_seed_base": 10000,
                         "execution_seed_base": 20000}
    bundle = bundle_of(recipes, _ir("profiles/abstract-v1.ag"), scenario)
    assert bundle_errors(bundle) == []
    return realize(bundle, 0)


def test_line_grid_reproduction_checks_clean(tmp_path):  # D-TOPOLOGY, RES-TOPOLOGY-LINE, R-HANDOFF
    # as `agspec run … --controller random --horizon 100 --trace t.jsonl` then `agspec check t.jsonl`
    tally = check_bundle(_line_bundle(), tmp_path, horizon=100, controllers=("random",), random_runs=0)
    assert tally.findings == [], _explain(tally)
    assert tally.ticks == 100


def test_the_selfcheck_catches_a_reference_that_ignores_the_topology(tmp_path, monkeypatch):
    """The check can fail: a reference whose G_handoff and G_obs are every cell's Moore neighbours
    whatever the topology (the old bug) breaks INV-LOCALITY, INV-MASKING and INV-OBSERVATION on the
    line-grid reproduction; the checker keeps the true relations."""
    bundle = _line_bundle()

    def moore_slots(self):
        return Model._slots(topology.handoff_graph(self.rows, self.cols, "moore", 1))

    monkeypatch.setattr(Model, "handoff_slots", property(moore_slots))
    monkeypatch.setattr(Model, "observation_slots", property(moore_slots))
    tally = check_bundle(bundle, tmp_path, horizon=60, controllers=(), random_runs=1)
    assert {"INV-LOCALITY", "INV-MASKING", "INV-OBSERVATION"} <= set(tally.kinds()), tally.kinds()
