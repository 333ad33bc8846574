"""F-CONFORM-COVERAGE, the variant space: every option value a simulator must read is caught by the
default run of `agspec conform` — some item fails a simulator that reads the official value instead —
and, for the values of a field, by a suite case's own expectations."""

from __future__ import annotations

import copy
import json

import pytest

from agspec.catalogue import load_scenario_bundle
from agspec.conform.coverage import variants as V
from agspec.conform.cases import load_suite
from agspec.conform.items import default_run, from_case
from agspec.ir import topology, variants
from agspec.resources import conformance_dir

ROOT = conformance_dir()
TOPOLOGY = [e.id for e in V.entries() if e.kind == "relation"]


def instance(name: str) -> dict:
    return json.loads((ROOT / "instances" / f"{name}.json").read_text(encoding="utf-8"))


def entry(ident: str) -> V.Entry:
    return next(e for e in V.entries() if e.id == ident)


@pytest.fixture(scope="module")
def suite():
    return load_suite()


@pytest.fixture(scope="module")
def covered(suite):
    """The variant coverage of the default run, each entry settled by its first covering item."""
    return V.variant_coverage(default_run(suite), enough=1)


# ------------------------------------------------------------------------------------------ the universe


def test_entries_derive_from_the_variant_table_the_official_profile_and_d_topology():  # F-CONFORM-COVERAGE
    ids = {e.id for e in V.entries()}
    assert len(ids) == len(V.entries())
    for option in variants.OPTIONS:  # S-RULE-VARIANTS: every implemented value
        for value in option.supported:
            assert f"variant:{'.'.join(option.path)}={str(value).lower()}" in ids
    _, _, profile = load_scenario_bundle("flow-easy")
    for name, overrides in profile["variants"].items():  # PR-VARIANT: every value that differs from the base
        for key, value in overrides.items():
            assert (f"profile:{key}={value}" in ids) == (value != profile[key]), name
    switches = {o.name for o in variants.OPTIONS if o.document == "profile"}
    for key, value in profile.items():  # PR-ABSTRACT-V1: every field is an entry, a switch or behaviour-free
        if key in V.NO_BEHAVIOUR or key in switches:
            continue
        keys = [f"{key}.{k}" for k in value] if isinstance(value, dict) else [key]
        for k in keys:
            assert any(i.startswith(f"profile:{k}=") or i.startswith(f"profile:{k}!=") for i in ids), k
    assert len(TOPOLOGY) == 3 * len(topology.TOPOLOGIES) * len(V.RADII) == 18  # D-TOPOLOGY


def test_applies_and_counterfactual_read_and_replace_one_value():
    inst = instance("twostep-2x2-high")
    high, low = entry("profile:rho_conf=0.4"), entry("profile:rho_conf=0.12")
    assert V.applies(high, inst) and not V.applies(low, inst)
    cf = V.counterfactual(high, inst)
    assert cf["profile"]["rho_conf"] == 0.25 and inst["profile"]["rho_conf"] == 0.4  # a copy, one value
    assert {k: v for k, v in cf["profile"].items() if k != "rho_conf"} == \
           {k: v for k, v in inst["profile"].items() if k != "rho_conf"}
    lock = entry("scenario:coordination.switch_lock>=2")
    assert V.applies(lock, instance("duo-1x2-lock2-flat")) and not V.applies(lock, instance("duo-1x2-flat"))
    batch = V.counterfactual(entry("scenario:evaluation.mode=batch"), instance("solo-1x2-batch2-flat"))
    assert batch["scenario"]["evaluation"] == {"mode": "continuing", "horizon": 20}
    zero = instance("xor0-2x2-flat")
    assert V.applies(entry("scenario:resources.zero"), zero) and V.applies(entry("scenario:resources.override"), zero)
    assert V.counterfactual(entry("scenario:resources.zero"), zero)["scenario"]["resources"] == {"press": 1}
    assert V.counterfactual(entry("scenario:resources.override"), zero)["scenario"]["resources"] == {}
    assert V.counterfactual(entry("release_lost:wip_cap"), zero) is None  # a witness needs no counterfactual


def test_a_relation_is_replaced_by_the_first_topology_that_changes_it_on_the_grid():  # D-TOPOLOGY, RES-RADIUS
    two = instance("insert4-2x2-flat")  # Moore radius 1
    for relation in V.RELATIONS:
        cf = V.counterfactual(entry(f"topology:{relation}/moore/1"), two)
        assert (cf["scenario"]["grid"]["topology"], cf["scenario"]["grid"]["radius"]) == ("von_neumann", 1)
    line = instance("duo-1x2-flat")  # on one row every topology of radius 1 is the same relation
    assert V.counterfactual(entry("topology:G_manip/moore/1"), line) is None
    wide = copy.deepcopy(instance("reach-1x3-paper"))  # Moore radius 2 on 1x3: G_obs is the radius-1 one
    assert V.counterfactual(entry("topology:G_obs/moore/2"), wide) is None
    assert V.counterfactual(entry("topology:G_manip/moore/2"), wide)["scenario"]["grid"]["radius"] == 1


def test_relation_views_hold_only_what_the_relation_decides():
    reply = {"observations": {"0,0": {"neighbours": [1], "operation_options": [2]}},
             "masks": {"0,0": list(range(114))}, "events": [{"type": "handoff_started"}, {"type": "admitted"}]}
    assert V.relation_view("G_obs", reply) == {"0,0": [1]}
    handoff = V.relation_view("G_handoff", reply)
    assert handoff[0] == {"0,0": list(range(34, 50))} and handoff[1] == [{"type": "handoff_started"}]
    manip = V.relation_view("G_manip", reply)
    assert manip[0] == {"0,0": [2]} and manip[1] == {"0,0": list(range(50, 114))}
    assert V.relation_view("G_handoff", reply, events_only=True) == [{}, [{"type": "handoff_started"}]]
    # a difference in a view is reported as a pointer into the reply
    assert V.relation_path("G_obs", "/0,0/3/robot") == "/observations/0,0/neighbours/3/robot"
    assert V.relation_path("G_handoff", "/0/0,0/5") == "/masks/0,0/39"  # HANDOFF0 + 5
    assert V.relation_path("G_manip", "/1/1,1/0") == "/masks/1,1/50"  # OP0
    assert V.relation_path("G_manip", "/0/0,0/1/id") == "/observations/0,0/operation_options/1/id"


# ------------------------------------------------------------------------------------------ discrimination


def test_the_rho_conf_case_catches_a_simulator_with_the_official_value_and_says_where(suite):
    (case,) = [c for c in suite if c.instance.get("id") == "conf-twostep-2x2-high"]
    found = V.item_coverage(from_case(case), [entry("profile:rho_conf=0.4")])
    finding = found["profile:rho_conf=0.4"]
    assert finding.asserted and finding.tick == 13  # the epoch where fin is blocked (conflict-high) or admitted


def test_not_over_eager_a_value_the_run_never_depends_on_is_not_covered(suite):
    """role_target_offset is 0.12 (official) on pair-1x2-official and its shelf capacity 6 is the official
    one: neither entry applies, nothing is covered; a conflict variant that the run never brings to a
    decision is not covered either (the geometry-matched episodes at 60 ticks: rho_conf decides later)."""
    (case,) = [c for c in suite if c.instance.get("id") == "conf-pair-1x2-official"]
    found = V.item_coverage(from_case(case), [entry("profile:role_target_offset!=0.12"),
                                              entry("scenario:shelves.capacity!=6")])
    assert found == {}
    from agspec.conform.items import catalogue_episodes

    (episode,) = catalogue_episodes(1, 60, ["geometry-matched-high"])
    assert V.item_coverage(episode, [entry("profile:rho_conf=0.4")]) == {}


def test_every_variant_case_asserts_a_value_other_than_the_official_one(suite):
    """Each case tagged `variant` is discriminating: its own expectations fail for a simulator that reads
    the official value of some entry its instance sets (not only its lockstep comparison)."""
    by_id = {e.id: e for e in V.entries()}

    def other_than_official(e: V.Entry) -> bool:  # the default of a switch is the official value
        if e.kind not in V.ASSERTED_KINDS:
            return False
        return e.group != "variant" or e.value != variants.BY_NAME[e.pointer.rsplit("/", 1)[-1]].default

    tagged = [c for c in suite if "variant" in c.tags]
    assert len(tagged) >= 16
    for case in tagged:
        found = V.item_coverage(from_case(case))
        asserted = [i for i, f in found.items() if f.asserted and other_than_official(by_id[i])]
        assert asserted, f"{case.location}: {case.title}: no value other than the official one is asserted"


# ------------------------------------------------------------------------------------------ the default run


def test_the_default_run_covers_every_variant_entry(covered):
    """An uncovered entry fails here by name (F-CONFORM-COVERAGE); the D-TOPOLOGY rows are checked one by
    one below."""
    uncovered = [e for e in covered["uncovered"] if e not in TOPOLOGY]
    assert uncovered == [], f"uncovered variant-space entries: {', '.join(uncovered)}"
    assert covered["unreachable"] == V.UNREACHABLE
    for ident, row in covered["variants"].items():
        if ident not in covered["uncovered"]:
            assert row["items"] and all(i in row["findings"] for i in row["items"])


@pytest.mark.parametrize("ident", TOPOLOGY)
def test_the_default_run_covers_each_d_topology_relation(ident, covered):  # D-TOPOLOGY
    assert ident not in covered["uncovered"], f"uncovered: {ident}"
