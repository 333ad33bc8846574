"""S-FEASIBILITY: scenario realizability under the geometry profile (agspec.interp.realizability)."""

from __future__ import annotations

import copy

import pytest
from hypothesis import HealthCheck, given, settings

import ir_fixtures as F
from ir_fixtures import found, xor_recipe
from agspec.interp import geometry
from agspec.interp import realizability as RZ
from agspec.interp.realizability import check_realizability, validate_scenario_full
from agspec.ir.validate import validate_recipe
from strategies_ir import valid_recipes

E, W = "error", "warning"


def profile(variant=None, **overrides):
    prof = F.resolved_profile(variant)
    prof.update(overrides)
    return prof


def check(recipes, *, rows=5, cols=6, topology="moore", variant=None, prof=None, extra=None, **scenario_kw):
    """Realizability of a scenario over ``recipes`` (official ids or recipe IR dicts)."""
    docs = {r if isinstance(r, str) else r["id"]: (F.official_recipe(r) if isinstance(r, str) else r)
            for r in recipes}
    docs.update(extra or {})
    sc = F.scenario(tuple(docs), rows=rows, cols=cols, topology=topology, variant=variant)
    sc.update(scenario_kw)
    return check_realizability(sc, docs, prof or profile(variant))


# ---------------------------------------------------------------------------------------------
# Official documents are realizable
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("sid", sorted(F.official_scenarios()))
def test_official_scenarios_are_realizable(sid):  # paper: the official suite is feasible
    assert validate_scenario_full(F.official_scenarios()[sid], F.official_resolver()) == []


@pytest.mark.parametrize("variant", [None, "conflict-low", "conflict-high", "spacing-0.75", "spacing-1.00"])
def test_official_recipes_are_realizable_under_the_declared_variants(variant):
    assert check(F.OFFICIAL_RECIPE_IDS, rows=6, cols=8, variant=variant) == []


def test_spacing_125_makes_the_4_robot_supported_insert_inadmissible():  # AG457, G-ROLE-TARGET
    # One holder; the member diagonal to it targets 1.25*sqrt(2) - 0.12 = 1.648 > reach 1.5.
    assert found(check(["supported_insert"], variant="spacing-1.25")) == {("AG457", "/recipes/0", W)}
    assert check(["standard_abc"], rows=6, cols=8, variant="spacing-1.25") == []  # two holders: fine


def test_von_neumann_grids_realize_every_recipe_within_k_topo():
    assert check([r for r in F.OFFICIAL_RECIPE_IDS if r != "standard_abc"], topology="von_neumann") == []


# ---------------------------------------------------------------------------------------------
# Topology coupling (D-KTOPO) and material reachability (AG454)
# ---------------------------------------------------------------------------------------------


def test_operation_needing_4_robots_on_a_line_grid_is_rejected():  # AG421 via the full check
    sc = F.scenario(("standard_abc",), rows=6, cols=8, topology="line")
    assert found(validate_scenario_full(sc, F.official_resolver())) == {("AG421", "/recipes/0", E)}
    # check_realizability alone leaves kmin > k_topo to validate_scenario (one report per mistake)
    assert check(["standard_abc"], rows=6, cols=8, topology="line") == []


def test_line_grid_cannot_join_materials_stocked_on_different_rows():  # AG454
    [issue] = check(["pair_assembly"], rows=6, cols=8, topology="line")
    assert (issue.code, issue.pointer, issue.severity) == ("AG454", "/recipes/0", E)
    assert "`pair_join` can never gather its inputs `A`, `B`" in issue.message
    assert "when `A` comes from shelf row 0 and `B` comes from shelf row 1" in issue.message


def test_line_grid_with_one_row_stocks_everything_in_that_row():
    assert check(["pair_assembly", "parallel_branch_light"], rows=1, cols=6, topology="line") == []


def test_line_grid_serial_recipes_are_realizable():  # one raw type: every row is a full line
    assert check(["solo_inspection", "flow_serial_5"], rows=4, cols=6, topology="line") == []


def test_join_after_branches_on_a_line_grid_is_reported_at_the_join():  # in-tree propagation
    [issue] = check(["parallel_branch_light"], rows=2, cols=5, topology="line")
    assert issue.code == "AG454" and "`join_branches`" in issue.message


# ---------------------------------------------------------------------------------------------
# Boundary interfaces (AG450, AG451, AG456) and the handoff chain (AG452)
# ---------------------------------------------------------------------------------------------


def test_short_reach_cannot_pick_deliver_or_hand_off():  # G-SHELF-POINT, G-OUTPUT-POINT
    issues = check(["solo_inspection"], prof=profile(reach=0.4))
    assert found(issues) == {("AG450", "/recipes/0", E), ("AG451", "/profile", E), ("AG456", "/profile", W)}
    shelf = next(i for i in issues if i.code == "AG450")
    assert "shelf rows 0, 1, 2, 3, 4" in shelf.message


def test_reach_below_spacing_cannot_deliver():  # output point one spacing right of the base
    issues = check(["solo_inspection"], prof=profile(reach=0.9))
    assert found(issues) == {("AG451", "/profile", E)}


def test_diagonal_handoffs_out_of_reach_are_a_warning():  # AG456
    # reach 0.6: orthogonal handoff points (0.5 away) are reachable, diagonal ones (0.707) are not;
    # the output point (1.0 away) is out of reach too.
    issues = check(["solo_inspection"], prof=profile(reach=0.6))
    assert found(issues) == {("AG451", "/profile", E), ("AG456", "/profile", W)}
    handoff = next(i for i in issues if i.code == "AG456")
    assert handoff.message.startswith("40 neighbour pairs") and "(0, 0) and (1, 1)" in handoff.message


def test_product_made_where_no_handoff_chain_reaches_the_output(monkeypatch):  # AG452
    real = geometry.output_point

    def only_row_0(row, cols, spacing):  # rows >= 1 get an output point out of reach
        return real(row, cols, spacing) if row == 0 else (cols * spacing + 10.0, row * spacing)

    monkeypatch.setattr(geometry, "output_point", only_row_0)
    [issue] = check(["solo_inspection"], rows=3, cols=4, topology="line")
    assert (issue.code, issue.pointer) == ("AG452", "/recipes/0")
    assert "`FINAL` can never reach the output column when `A` comes from shelf row 1" in issue.message


# ---------------------------------------------------------------------------------------------
# Operation candidates (AG453, AG457) and XOR routes
# ---------------------------------------------------------------------------------------------


def single_holder_team_of_4(recipe: dict, op_index: int) -> dict:
    op = recipe["operations"][op_index]
    op["arity"] = [4, 4]
    op["roles"] = op["roles"] + [{"name": f"helper_{k}"} for k in range(4 - len(op["roles"]))]
    return recipe


def test_operation_without_admissible_candidate_is_an_error():  # AG453
    recipe = single_holder_team_of_4(F.official_recipe("supported_insert"), 1)
    assert validate_recipe(recipe) == []
    [issue] = check([recipe], variant="spacing-1.25")
    assert (issue.code, issue.pointer, issue.severity) == ("AG453", "/recipes/0", E)
    assert "`supported_insert` has no geometrically admissible execution candidate" in issue.message


def test_inadmissible_xor_alternative_is_a_warning_when_a_sibling_works():  # RC-XOR + AG453
    recipe = single_holder_team_of_4(xor_recipe(), 3)  # weld needs 4 robots around one holder
    [issue] = check([recipe], variant="spacing-1.25")
    assert (issue.code, issue.severity) == ("AG453", W)
    assert "`weld`" in issue.message and "another XOR alternative" in issue.message


def test_all_xor_alternatives_inadmissible_is_an_error():
    recipe = single_holder_team_of_4(single_holder_team_of_4(xor_recipe(), 1), 3)
    issues = check([recipe], variant="spacing-1.25")
    assert {(i.code, i.severity) for i in issues} == {("AG453", E)}
    assert len(issues) == 2


def test_canonical_role_assignment():  # R-ROLE-ASSIGNMENT
    recipe = F.official_recipe("supported_insert")
    view_op = next(op for op in RZ.V.recipe_view(recipe).ops if op.id == "supported_insert")
    spec = RZ._op_spec(view_op)
    members = ((0, 0), (0, 1), (1, 1))
    roles = RZ.assign_roles(spec, members, {"AB": (1, 1)})
    assert roles == [((0, 0), "inserter"), ((0, 1), "stabilizer"), ((1, 1), "holder")]
    assert RZ._receiver(spec, members, ((1, 1),)) == (1, 1)


# ---------------------------------------------------------------------------------------------
# Resources (AG455)
# ---------------------------------------------------------------------------------------------


def with_fixture(declare_in_recipe=None):
    recipe = F.official_recipe("pair_assembly")
    recipe["operations"][0]["resources"] = ["fixture"]
    if declare_in_recipe is not None:
        recipe["resources"] = {"fixture": declare_in_recipe}
    return recipe


def test_resource_with_capacity_zero_in_the_scenario_blocks_the_operation():
    issues = check([with_fixture(1)], resources={"fixture": 0})
    assert found(issues) == {("AG455", "/resources/fixture", E)}


def test_undeclared_resource_blocks_the_operation():
    issues = check([with_fixture()])
    assert found(issues) == {("AG455", "/recipes/0", E)}
    assert "neither the recipe nor the scenario declares" in issues[0].message


def test_declared_resources_are_fine():
    assert check([with_fixture(1)]) == []
    assert check([with_fixture()], resources={"fixture": 2}) == []


# ---------------------------------------------------------------------------------------------
# Robustness and properties
# ---------------------------------------------------------------------------------------------


def test_invalid_inputs_are_left_to_their_validators():
    bad = F.official_recipe("pair_assembly")
    bad["operations"][0]["inputs"] = ["A", "Q"]
    assert check([bad]) == []  # AG305 etc. come from validate_recipe
    sc = F.scenario(("pair_assembly",), cols=1)
    assert check_realizability(sc, F.official_recipes(), profile()) == []  # AG410
    assert check(["pair_assembly"], prof=profile(spacing=0)) == []  # AG401


def test_full_check_stops_after_structural_errors():
    sc = F.scenario(("pair_assembly",), topology="line", rows=6, cols=8)
    sc["release"]["wip_cap"] = 0
    assert found(validate_scenario_full(sc, F.official_resolver())) == {("AG416", "/release/wip_cap", E)}


def test_large_grids_stay_fast():
    import time

    start = time.perf_counter()
    assert check(F.OFFICIAL_RECIPE_IDS, rows=40, cols=40) == []
    assert time.perf_counter() - start < 5.0


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(valid_recipes())
def test_generated_valid_recipes_are_realizable_on_the_default_grid(recipe):
    # Under abstract-v1 every team of a 2x2 Moore block reaches its role targets (max 1.294).
    assert check([recipe]) == []


def test_scenario_ir_is_not_mutated():
    sc = F.scenario(("pair_assembly",))
    before = copy.deepcopy(sc)
    check_realizability(sc, F.official_recipes(), profile())
    assert sc == before
