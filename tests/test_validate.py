"""Semantic checks on IR (agspec.ir.validate): exact codes and JSON Pointers for malformed input,
clean results for the official documents and for generated valid recipes.

Each malformed case starts from an official document, applies one mistake, and lists every
issue expected — (code, pointer, severity) — so the tests also prove that all problems of a
document are reported in one run.
"""

from __future__ import annotations

import copy
import json

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import ir_fixtures as F
from ir_fixtures import found, xor_recipe
from agspec.formats.diagnostics import Issue
from agspec.ir.instance import make_instance
from agspec.ir.validate import (
    errors,
    recipe_view,
    routes,
    terminal_token,
    validate_document,
    validate_instance,
    validate_profile,
    validate_recipe,
    validate_scenario,
)
from strategies_ir import valid_recipes

E, W = "error", "warning"


# ---------------------------------------------------------------------------------------------
# Recipes (RC-*)
# ---------------------------------------------------------------------------------------------


def _r(rid):
    return lambda: F.official_recipe(rid)


def _set(path, value):
    """Mutation: set the value at a JSON path (list of keys/indices)."""
    def apply(doc):
        target = doc
        for key in path[:-1]:
            target = target[key]
        target[path[-1]] = value
        return doc
    return apply


def _do(fn):
    def apply(doc):
        fn(doc)
        return doc
    return apply


# Canonical operation order (sorted by id):
#   flow_serial_3: inspect 0, prepare 1, process 2        pair_assembly: pair_join 0
#   supported_insert: align_ab 0, supported_insert 1      parallel_branch_light: join_branches 0,
#   prepare_a 1, prepare_b 2                              solo_inspection: inspect 0
RECIPE_CASES = [
    ("duplicate-operation", _r("pair_assembly"),
     _do(lambda d: d["operations"].append(copy.deepcopy(d["operations"][0]))),
     {("AG301", "/operations/1/id", E)}),
    ("unknown-predecessor", _r("supported_insert"), _set(["operations", 1, "after"], ["align_abc"]),
     {("AG302", "/operations/1/after/0", E), ("AG305", "/operations/1/inputs/0", E)}),
    ("precedence-cycle", _r("flow_serial_3"), _set(["operations", 1, "after"], ["inspect"]),
     {("AG303", "/operations/1/after/0", E)}),
    ("self-loop", _r("solo_inspection"), _set(["operations", 0, "after"], ["inspect"]),
     {("AG303", "/operations/0/after/0", E)}),
    ("duplicate-raw", _r("solo_inspection"), _set(["raw"], ["A", "A"]),
     {("AG304", "/raw/1", E)}),
    ("missing-predecessor", _r("parallel_branch_light"), _set(["operations", 0, "after"], ["prepare_a"]),
     {("AG305", "/operations/0/inputs/1", E)}),
    ("unknown-token", _r("supported_insert"), _set(["operations", 1, "inputs"], ["BA"]),
     {("AG305", "/operations/1/inputs/0", E), ("AG306", "/operations/0/outputs/0", E),
      ("AG341", "/operations/1/roles/0/binds", E)}),
    ("dangling-intermediate", _r("parallel_branch_light"), _set(["operations", 0, "inputs"], ["PA"]),
     {("AG306", "/operations/2/outputs/0", E), ("AG341", "/operations/0/roles/1/binds", E)}),
    ("no-operations", _r("solo_inspection"), _set(["operations"], []),
     {("AG307", "/operations", E), ("AG310", "/raw/0", W)}),
    ("consumed-twice", _r("parallel_branch_light"), _set(["operations", 2, "inputs"], ["A"]),
     {("AG308", "/operations/2/inputs/0", E), ("AG310", "/raw/1", W)}),
    ("produced-twice", _r("flow_serial_3"), _set(["operations", 2, "outputs"], ["P1"]),
     {("AG309", "/operations/2/outputs/0", E), ("AG305", "/operations/0/inputs/0", E)}),
    ("output-shadows-raw", _r("pair_assembly"), _set(["operations", 0, "outputs"], ["B"]),
     {("AG309", "/operations/0/outputs/0", E), ("AG307", "/operations", E)}),
    ("unused-raw", _r("solo_inspection"), _set(["raw"], ["A", "Z"]),
     {("AG310", "/raw/1", W)}),
    ("two-outputs", _r("solo_inspection"), _set(["operations", 0, "outputs"], ["FINAL", "SCRAP"]),
     {("AG311", "/operations/0/outputs", E), ("AG306", "/operations/0/outputs/1", E)}),
    ("no-inputs", _r("flow_serial_3"), _set(["operations", 1, "inputs"], []),
     {("AG312", "/operations/1/inputs", E), ("AG310", "/raw/0", W)}),
    ("xor-one-alternative", _r("solo_inspection"), _set(["xor"], [{"id": "g", "alternatives": ["inspect"]}]),
     {("AG320", "/xor/0/alternatives", E)}),
    ("xor-unknown-alternative", xor_recipe, _set(["xor", 0, "alternatives"], ["glue", "welt"]),
     {("AG321", "/xor/0/alternatives/1", E),
      ("AG309", "/operations/3/outputs/0", E), ("AG308", "/operations/3/inputs/0", E)}),
    ("xor-different-outputs", xor_recipe, _set(["operations", 3, "outputs"], ["W"]),
     {("AG322", "/xor/0/alternatives/1", E), ("AG305", "/operations/2/inputs/0", E),
      ("AG306", "/operations/3/outputs/0", E)}),
    ("after-names-alternative", xor_recipe, _set(["operations", 2, "after"], ["glue"]),
     {("AG323", "/operations/2/after/0", E), ("AG305", "/operations/2/inputs/0", E)}),
    ("operation-in-two-groups", xor_recipe,
     _do(lambda d: d["xor"].append({"id": "route2", "alternatives": ["glue", "weld"]})),
     {("AG324", "/xor/1/alternatives/0", E), ("AG324", "/xor/1/alternatives/1", E)}),
    ("xor-name-clashes-with-operation", xor_recipe, _set(["xor", 0, "id"], "align"),
     {("AG325", "/xor/0/id", E), ("AG302", "/operations/2/after/0", E),
      ("AG308", "/operations/3/inputs/0", E), ("AG309", "/operations/3/outputs/0", E),
      ("AG305", "/operations/2/inputs/0", E)}),
    ("arity-reversed", _r("pair_assembly"), _set(["operations", 0, "arity"], [3, 2]),
     {("AG330", "/operations/0/arity", E)}),
    ("arity-zero", _r("solo_inspection"), _set(["operations", 0, "arity"], [0, 1]),
     {("AG330", "/operations/0/arity/0", E)}),
    ("arity-above-k-topo", _r("pair_assembly"),
     _do(lambda d: d["operations"][0].update(
         arity=[5, 5], roles=d["operations"][0]["roles"] + [{"name": f"h{k}"} for k in range(3)])),
     {("AG331", "/operations/0/arity/0", E)}),
    ("more-inputs-than-smallest-team", _r("supported_insert"), _set(["operations", 0, "arity"], [1, 2]),
     {("AG332", "/operations/0/inputs", E)}),
    ("role-count", _r("supported_insert"), _do(lambda d: d["operations"][1]["roles"].pop()),
     {("AG340", "/operations/1/roles", E)}),
    ("role-binds-non-input", _r("pair_assembly"), _set(["operations", 0, "roles", 1, "binds"], "C"),
     {("AG341", "/operations/0/roles/1/binds", E)}),
    ("input-bound-twice", _r("pair_assembly"), _set(["operations", 0, "roles", 1, "binds"], "A"),
     {("AG342", "/operations/0/roles/1/binds", E)}),
    ("duplicate-role", _r("pair_assembly"), _set(["operations", 0, "roles", 1, "name"], "holder_A"),
     {("AG343", "/operations/0/roles/1/name", E)}),
    ("duration-zero", _r("solo_inspection"), _set(["operations", 0, "duration"], 0),
     {("AG350", "/operations/0/duration", E)}),
    ("duration-fraction", _r("flow_serial_3"), _set(["operations", 2, "duration"], 2.5),
     {("AG350", "/operations/2/duration", E)}),
    ("weight-negative", _r("solo_inspection"), _set(["operations", 0, "weight"], -1.0),
     {("AG351", "/operations/0/weight", E)}),
    ("value-zero", _r("solo_inspection"), _set(["value"], 0),
     {("AG352", "/value", E)}),
    ("undeclared-resource", _r("solo_inspection"), _set(["operations", 0, "resources"], ["fixture"]),
     {("AG360", "/operations/0/resources/0", W)}),
    ("resource-capacity-zero", _r("solo_inspection"), _set(["resources"], {"fixture": 0}),
     {("AG361", "/resources/fixture", E)}),
    ("resource-listed-twice", _r("solo_inspection"),
     _do(lambda d: (d.update(resources={"fixture": 1}),
                    d["operations"][0].update(resources=["fixture", "fixture"]))),
     {("AG362", "/operations/0/resources/1", E)}),
]


@pytest.mark.parametrize("name, make, mutate, expected", RECIPE_CASES, ids=[c[0] for c in RECIPE_CASES])
def test_malformed_recipe_reports_exact_codes_and_pointers(name, make, mutate, expected):
    assert found(validate_recipe(mutate(make()))) == expected


def test_at_least_20_distinct_malformed_recipe_codes():
    codes = {code for *_, expected in RECIPE_CASES for code, _, _ in expected}
    assert len(codes) >= 20


@pytest.mark.parametrize("rid", F.OFFICIAL_RECIPE_IDS)
def test_official_recipes_validate_clean(rid):  # paper, "Official recipe parameters"
    assert validate_recipe(F.official_recipe(rid)) == []


def test_xor_fixture_is_valid_and_has_two_routes():  # RC-XOR
    recipe = xor_recipe()
    assert validate_recipe(recipe) == []
    assert routes(recipe_view(recipe)) == [{"route": "glue"}, {"route": "weld"}]
    assert terminal_token(recipe) == "FINAL"


def test_cycle_message_names_the_path_and_blames_the_edge_without_material():  # RC-PRECEDENCE
    recipe = F.official_recipe("flow_serial_3")
    recipe["operations"][1]["after"] = ["inspect"]  # prepare after inspect
    [issue] = validate_recipe(recipe)
    assert issue.message == "precedence cycle: prepare -> process -> inspect -> prepare"
    assert "`inspect`" in issue.hint and "`prepare`" in issue.hint


def test_route_specific_finding_names_the_route():  # RC-MATERIAL per XOR route
    recipe = xor_recipe()
    recipe["operations"][2]["after"] = ["glue"]
    by_code = {i.code: i for i in validate_recipe(recipe)}
    assert by_code["AG305"].message.endswith("(on the route where `route` chooses `weld`)")
    assert "(on the route where" not in by_code["AG323"].message  # wrong on every route


def test_missing_predecessor_hint_names_the_producer():  # style: errors a person can act on
    recipe = F.official_recipe("parallel_branch_light")
    recipe["operations"][0]["after"] = ["prepare_a"]
    [issue] = validate_recipe(recipe)
    assert issue.message == ("operation `join_branches` consumes `PB`, which `prepare_b` produces, "
                             "but `prepare_b` is not a predecessor of `join_branches`")
    assert issue.hint == "add `after prepare_b` to `join_branches`"


def test_unknown_predecessor_suggests_a_close_name():
    recipe = F.official_recipe("supported_insert")
    recipe["operations"][1]["after"] = ["align_abc"]
    issue = next(i for i in validate_recipe(recipe) if i.code == "AG302")
    assert "did you mean `align_ab`?" in issue.message


def test_k_topo_argument_bounds_the_minimum_team():  # RC-ARITY with a grid's k_topo
    recipe = F.official_recipe("pair_assembly")
    assert found(validate_recipe(recipe, k_topo=1)) == {("AG331", "/operations/0/arity/0", E)}
    assert validate_recipe(recipe, k_topo=2) == []


def test_variable_arity_needs_roles_for_the_largest_team():  # RC-ROLES, supported_insert [2,4]
    recipe = F.official_recipe("supported_insert")
    recipe["operations"][1]["arity"] = [2, 3]
    assert found(validate_recipe(recipe)) == {("AG340", "/operations/1/roles", E)}


def test_every_issue_has_a_hint_and_a_pointer():
    for name, make, mutate, _ in RECIPE_CASES:
        for issue in validate_recipe(mutate(make())):
            assert issue.hint, (name, issue)
            assert issue.pointer.startswith("/"), (name, issue)


JSON = st.recursive(
    st.none() | st.booleans() | st.integers(-3, 5) | st.floats(allow_nan=True) | st.text(max_size=4),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=4), inner, max_size=3),
    max_leaves=8,
)


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(rid=st.sampled_from(F.OFFICIAL_RECIPE_IDS), data=st.data())
def test_validators_never_crash_on_garbage(rid, data):  # no tracebacks for user errors
    recipe = F.official_recipe(rid)
    op = data.draw(st.integers(0, len(recipe["operations"]) - 1))
    key = data.draw(st.sampled_from(["inputs", "outputs", "after", "arity", "roles", "resources",
                                     "duration", "weight", "id"]))
    recipe["operations"][op][key] = data.draw(JSON)
    top = data.draw(st.sampled_from(["raw", "xor", "resources", "value", "operations"]))
    if data.draw(st.booleans()):
        recipe[top] = data.draw(JSON)
    issues = validate_recipe(recipe)
    assert all(isinstance(i, Issue) for i in issues)


def _paths(doc, prefix=()):
    yield prefix
    if isinstance(doc, dict):
        for key, value in doc.items():
            yield from _paths(value, (*prefix, key))
    elif isinstance(doc, list):
        for k, value in enumerate(doc):
            yield from _paths(value, (*prefix, k))


def _documents():
    return {
        "recipe": lambda: F.official_recipe("standard_abc"),
        "xor-recipe": xor_recipe,
        "profile": F.abstract_v1,
        "scenario": lambda: F.official_scenarios()["coalition-hard"],
        "instance": lambda: make_official_instance("coalition-easy", index=3),
    }


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(kind=st.sampled_from(sorted(_documents())), data=st.data())
def test_validate_document_never_crashes_on_any_replaced_value(kind, data):  # no tracebacks
    doc = _documents()[kind]()
    for _ in range(data.draw(st.integers(1, 3))):
        paths = [p for p in _paths(doc) if p and p[0] != "kind"]
        path = data.draw(st.sampled_from(paths))
        target = doc
        for key in path[:-1]:
            target = target[key]
        target[path[-1]] = data.draw(JSON)
    issues = validate_document(doc, F.official_resolver())
    assert all(isinstance(i, Issue) for i in issues)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(valid_recipes())
def test_generated_valid_recipes_have_no_issues(recipe):  # RC-* accept every valid recipe
    assert validate_recipe(recipe) == []
    json.dumps(recipe)  # plain JSON


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(valid_recipes(max_xor=0), st.data())
def test_dropping_a_material_predecessor_is_reported(recipe, data):  # RC-MATERIAL
    ops = recipe["operations"]
    producer = {op["outputs"][0]: op["id"] for op in ops}
    needed = [(k, op["after"].index(producer[t])) for k, op in enumerate(ops)
              for t in op["inputs"] if t in producer]
    if not needed:
        return
    k, m = data.draw(st.sampled_from(needed))
    dropped = ops[k]["after"].pop(m)
    pointers = {(i.code, i.pointer) for i in validate_recipe(recipe)}
    consumed = [n for n, t in enumerate(ops[k]["inputs"]) if producer.get(t) == dropped]
    # Unless another predecessor still leads to the producer, the input is reported.
    assert any(("AG305", f"/operations/{k}/inputs/{n}") in pointers for n in consumed) or any(
        p for p in ops[k]["after"])


# ---------------------------------------------------------------------------------------------
# Profiles (PR-*)
# ---------------------------------------------------------------------------------------------


PROFILE_CASES = [
    ("spacing-zero", _set(["spacing"], 0), {("AG401", "/spacing", E)}),
    ("speed-negative", _set(["speed"], -1.0), {("AG401", "/speed", E)}),
    ("rho-negative", _set(["rho_conf"], -0.1), {("AG402", "/rho_conf", E)}),
    ("retreat-above-one", _set(["retreat_fraction"], 1.5), {("AG403", "/retreat_fraction", E)}),
    ("reach-too-short-for-diagonal-handoff", _set(["reach"], 0.6), {("AG404", "/reach", E)}),
    ("pick-duration-zero", _set(["durations", "pick"], 0), {("AG405", "/durations/pick", E)}),
    ("variant-unknown-key", _set(["variants", "bad"], {"spaceing": 1.2}),
     {("AG406", "/variants/bad/spaceing", E)}),
    ("variant-breaks-handoff", _set(["variants", "wide"], {"spacing": 3.0}),
     {("AG404", "/variants/wide/spacing", E)}),
    ("variant-negative-rho", _set(["variants", "neg"], {"rho_conf": -1}),
     {("AG402", "/variants/neg/rho_conf", E)}),
    ("variant-unknown-duration", _set(["variants", "slow"], {"durations": {"weld": 3}}),
     {("AG406", "/variants/slow/durations/weld", E)}),
]


@pytest.mark.parametrize("name, mutate, expected", PROFILE_CASES, ids=[c[0] for c in PROFILE_CASES])
def test_malformed_profile_reports_exact_codes_and_pointers(name, mutate, expected):
    assert found(validate_profile(mutate(F.abstract_v1()))) == expected


def test_official_profile_and_resolved_variants_validate_clean():
    assert validate_profile(F.abstract_v1()) == []
    for variant in F.abstract_v1()["variants"]:
        assert validate_profile(F.resolved_profile(variant)) == []


def test_handoff_reach_limit_is_spacing_times_sqrt2_over_2():  # PR-HANDOFF-REACH, G-HANDOFF-POINT
    profile = F.abstract_v1()
    profile["reach"] = 0.7072
    assert found(validate_profile(profile)) == {("AG404", "/variants/spacing-1.25/spacing", E)}
    del profile["variants"]
    assert validate_profile(profile) == []
    profile["reach"] = 0.7070
    [issue] = validate_profile(profile)
    assert issue.code == "AG404" and "0.7071" in issue.message


# ---------------------------------------------------------------------------------------------
# Scenarios (S-*)
# ---------------------------------------------------------------------------------------------


def _sc(**kw):
    return lambda: F.scenario(**kw)


SCENARIO_CASES = [
    ("one-column", _sc(), _set(["grid", "cols"], 1), {("AG410", "/grid/cols", E)}),
    ("zero-rows", _sc(), _set(["grid", "rows"], 0), {("AG410", "/grid/rows", E)}),
    ("unknown-topology", _sc(), _set(["grid", "topology"], "hex"), {("AG411", "/grid/topology", E)}),
    ("radius-zero", _sc(), _set(["grid", "radius"], 0), {("AG411", "/grid/radius", E)}),
    ("unknown-recipe", _sc(), _set(["recipes"], ["supported_insrt"]), {("AG412", "/recipes/0", E)}),
    ("recipe-twice", _sc(), _set(["recipes"], ["supported_insert", "supported_insert"]),
     {("AG413", "/recipes/1", W)}),
    ("unknown-profile", _sc(), _set(["profile", "id"], "abstract-v2"), {("AG414", "/profile/id", E)}),
    ("unknown-variant", _sc(), _set(["profile", "variant"], "conflict-extreme"),
     {("AG415", "/profile/variant", E)}),
    ("wip-cap-zero", _sc(), _set(["release", "wip_cap"], 0), {("AG416", "/release/wip_cap", E)}),
    ("interval-zero", _sc(), _set(["release", "interval"], 0), {("AG416", "/release/interval", E)}),
    ("horizon-zero", _sc(), _set(["evaluation", "horizon"], 0), {("AG416", "/evaluation/horizon", E)}),
    ("batch-size-zero", _sc(), _set(["evaluation"], {"mode": "batch", "batch_size": 0, "timeout": 400}),
     {("AG416", "/evaluation/batch_size", E)}),
    ("switch-lock-negative", _sc(), _set(["coordination", "switch_lock"], -1),
     {("AG417", "/coordination/switch_lock", E)}),
    ("probability-above-one", _sc(), _set(["shelves", "extra_access_probability"], 1.5),
     {("AG418", "/shelves/extra_access_probability", E)}),
    ("mass-range-reversed", _sc(), _set(["products", "mass"], [2.0, 0.5]), {("AG419", "/products/mass", E)}),
    ("empty-mix", _sc(), _set(["recipes"], []), {("AG420", "/recipes", E)}),
    ("four-robots-on-a-line", _sc(recipes=("standard_abc",), rows=6, cols=8, topology="line"), lambda d: d,
     {("AG421", "/recipes/0", E)}),
    ("resource-capacity-negative", _sc(), _set(["resources"], {"fixture": -1}),
     {("AG422", "/resources/fixture", E)}),
]


@pytest.mark.parametrize("name, make, mutate, expected", SCENARIO_CASES, ids=[c[0] for c in SCENARIO_CASES])
def test_malformed_scenario_reports_exact_codes_and_pointers(name, make, mutate, expected):
    assert found(validate_scenario(mutate(make()), F.official_resolver())) == expected


@pytest.mark.parametrize("sid", sorted(F.official_scenarios()))
def test_official_scenarios_validate_clean(sid):
    assert validate_scenario(F.official_scenarios()[sid], F.official_resolver()) == []


@pytest.mark.parametrize("sid", sorted(F.official_scenarios()))
def test_a_changed_copy_of_an_official_scenario_that_still_claims_official_is_warned(sid):  # S-OFFICIAL, AG424
    scenario = copy.deepcopy(F.official_scenarios()[sid])
    if not scenario.get("suite", {}).get("official"):
        pytest.skip("the geometry-matched control does not claim to be official")
    scenario["release"]["wip_cap"] += 1
    assert found(validate_scenario(scenario, F.official_resolver())) == {("AG424", "/suite/official", W)}
    scenario["suite"]["official"] = False
    assert validate_scenario(scenario, F.official_resolver()) == []


def test_operation_needing_4_robots_on_a_line_grid_is_rejected():  # S-FEASIBILITY, D-KTOPO
    sc = F.scenario(recipes=("standard_abc",), rows=6, cols=8, topology="line")
    [issue] = validate_scenario(sc, F.official_resolver())
    assert (issue.code, issue.pointer) == ("AG421", "/recipes/0")
    assert "`stabilize_insert` needs at least 4 robots" in issue.message
    assert "at most 2 (k_topo)" in issue.message


def test_k_topo_follows_this_grid_not_the_default():  # a 1-row Moore grid has k_topo 2
    sc = F.scenario(recipes=("supported_insert", "pair_assembly"), rows=1, cols=6)
    assert validate_scenario(sc, F.official_resolver()) == []
    sc["recipes"].append("standard_abc")
    assert found(validate_scenario(sc, F.official_resolver())) == {("AG421", "/recipes/2", E)}


# ---------------------------------------------------------------------------------------------
# Instances (I-*)
# ---------------------------------------------------------------------------------------------


def make_official_instance(sid="coalition-medium", index=1000):
    scenarios = F.official_scenarios()
    return make_instance(scenarios[sid], F.official_recipes(), F.abstract_v1(), index=index)


def _first_product_where(pred):
    def apply(inst):
        k = next(k for k, p in enumerate(inst["realization"]["products"]) if pred(p))
        return inst, k
    return apply


def _mutate_source_row(inst):
    # supported_insert on 5 rows: A on rows 0, 2, 4; B on rows 1, 3.
    inst["realization"]["products"][0]["source_rows"]["A"] = 1
    return inst


def _widen_access(inst):
    inst["realization"]["shelf_access"][0]["robot_rows"] = [0, 1, 3]
    return inst


def _shift_due(inst):
    inst["realization"]["products"][0]["due_offset"] += 1
    return inst


INSTANCE_CASES = [
    ("scenario-kind", _set(["scenario", "kind"], "recipe"), {("AG501", "/scenario/kind", E)}),
    ("recipe-key-mismatch", _do(lambda d: d["recipes"]["supported_insert"].update(id="supported")),
     {("AG502", "/recipes/supported_insert/id", E)}),
    ("recipe-missing", _do(lambda d: d["recipes"].pop("supported_insert")),
     {("AG503", "/scenario/recipes/0", E)}),
    ("profile-variant-mismatch", _set(["profile", "variant"], "conflict-high"), {("AG504", "/profile/variant", E)}),
    ("profile-unresolved", _set(["profile", "variants"], {}), {("AG504", "/profile/variants", E)}),
    ("raw-types", _set(["realization", "raw_types"], ["B", "A"]),
     {("AG505", "/realization/raw_types", E), ("AG515", "/realization/shelves/0/stock", W)}),
    ("shelf-row", _set(["realization", "shelves", 2, "row"], 7), {("AG506", "/realization/shelves/2/row", E)}),
    ("stock-above-capacity", _set(["realization", "shelves", 0, "stock", "A"], 9),
     {("AG507", "/realization/shelves/0/stock/A", E)}),
    ("stock-unknown-token", _set(["realization", "shelves", 0, "stock", "Q"], 1),
     {("AG507", "/realization/shelves/0/stock/Q", E)}),
    ("access-out-of-reach", _widen_access, {("AG508", "/realization/shelf_access/0/robot_rows/2", E)}),
    ("access-without-own-row", _set(["realization", "shelf_access", 1, "robot_rows"], [2]),
     {("AG508", "/realization/shelf_access/1/robot_rows", E)}),
    ("product-recipe", _set(["realization", "products", 3, "recipe"], "pair_assembly"),
     {("AG509", "/realization/products/3/recipe", E)}),
    ("product-id", _set(["realization", "products", 2, "id"], 7), {("AG510", "/realization/products/2/id", E)}),
    ("product-count", _do(lambda d: d["realization"]["products"].pop()), {("AG511", "/realization/products", E)}),
    ("source-row", _mutate_source_row, {("AG512", "/realization/products/0/source_rows/A", E)}),
    ("source-row-missing", _do(lambda d: d["realization"]["products"][0]["source_rows"].pop("B")),
     {("AG512", "/realization/products/0/source_rows", E)}),
    ("mass-out-of-range", _set(["realization", "products", 0, "mass"], 2.5),
     {("AG513", "/realization/products/0/mass", E)}),
    ("due-offset", _shift_due, {("AG513", "/realization/products/0/due_offset", E)}),
    ("layout-deviates", _set(["realization", "shelves", 0, "stock", "A"], 3),
     {("AG515", "/realization/shelves/0/stock", W)}),
    ("embedded-recipe-error", _set(["recipes", "supported_insert", "operations", 0, "duration"], 0),
     {("AG350", "/recipes/supported_insert/operations/0/duration", E)}),
    ("embedded-scenario-error", _set(["scenario", "release", "wip_cap"], 0),
     {("AG416", "/scenario/release/wip_cap", E)}),
]


@pytest.mark.parametrize("name, mutate, expected", INSTANCE_CASES, ids=[c[0] for c in INSTANCE_CASES])
def test_malformed_instance_reports_exact_codes_and_pointers(name, mutate, expected):
    assert found(validate_instance(mutate(make_official_instance()))) == expected


@pytest.mark.parametrize("sid", sorted(F.official_scenarios()))
def test_generated_official_instances_validate_clean(sid):
    assert validate_instance(make_official_instance(sid, index=0)) == []


def test_batch_instance_product_count_is_the_batch_size():  # P-RELEASE
    sc = F.scenario(recipes=("pair_assembly",))
    sc["evaluation"] = {"mode": "batch", "batch_size": 7, "timeout": 400}
    inst = make_instance(sc, F.official_recipes(), F.abstract_v1(), generation_seed=5)
    assert validate_instance(inst) == []
    inst["realization"]["products"].append(copy.deepcopy(inst["realization"]["products"][-1]))
    assert ("AG511", "/realization/products", E) in found(validate_instance(inst))


# ---------------------------------------------------------------------------------------------
# Dispatch
# ---------------------------------------------------------------------------------------------


def test_validate_document_dispatches_on_kind():
    resolver = F.official_resolver()
    assert validate_document(F.official_recipe("pair_assembly"), resolver) == []
    assert validate_document(F.abstract_v1(), resolver) == []
    assert validate_document(F.official_scenarios()["flow-easy"], resolver) == []
    assert validate_document(make_official_instance(), resolver) == []
    bad = F.official_recipe("pair_assembly")
    bad["value"] = -1
    assert [i.code for i in validate_document(bad, resolver)] == ["AG352"]
    with pytest.raises(ValueError):
        validate_document({"kind": "banana"}, resolver)


def test_scenario_without_resolver_reports_unresolved_names():
    issues = validate_document(F.scenario(), None)
    assert found(issues) == {("AG412", "/recipes/0", E), ("AG414", "/profile/id", E)}


def test_errors_filters_warnings():
    recipe = F.official_recipe("solo_inspection")
    recipe["raw"].append("Z")
    assert errors(validate_recipe(recipe)) == []


def test_catalogue_recipes_load_and_validate_clean():  # through the DSL, once it exists
    load = pytest.importorskip("agspec.load")
    from agspec.resources import catalogue_dir

    paths = sorted((catalogue_dir() / "recipes").glob("*.ag"))
    if not paths or not hasattr(load, "load_document"):
        pytest.skip("catalogue recipes or loader not available yet")
    for path in paths:
        loaded = load.load_document(path)
        ir = loaded[0] if isinstance(loaded, tuple) else getattr(loaded, "ir", loaded)
        assert validate_recipe(ir) == [], path.name
