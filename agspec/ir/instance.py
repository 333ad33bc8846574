"""Instance realization: scenario + recipes + profile + seeds -> self-contained instance IR.

The instance records, explicitly, every random draw of the realization that the original
AssemblyGrid v1 release evaluates for a suite index, so that any implementation can replay it
without our random number generator (spec chapter 08, I-REALIZATION).

Generation stream (I-RNG-STREAM): ``random.Random(generation_seed)`` of CPython 3.11 (MT19937).
Evaluator convention (I-CONSTRUCT-THEN-RESET, resolution from the original release): the
environment is constructed (= reset #1) and then reset once more without a seed (reset #2, the
scored episode), both continuing the same stream. The draws therefore are

    [shelf access of reset #1][product 0 of reset #1][shelf access of reset #2][products 0, 1, ...]

and only the reset #2 draws are recorded.

* S-SHELF-LAYOUT: row r stocks raw_types[r mod n_raw]; each raw type k is also stocked on row
  k mod M; every stocked token starts at shelf capacity.
* S-SHELF-ACCESS: for shelf row r = 0..M-1 and left-column robot row i = 0..M-1 whose robot
  (i, 0) reaches the shelf point (-s/2, r*s): the own row gets access without a draw, any other
  reaching row draws u = random() and gets access iff u < p (official geometry: |i - r| = 1).
* P-RELEASE-DRAWS: per released product: choice(recipe ids); for each raw token in recipe raw
  order choice(rows stocking it, ascending); uniform(mass_min, mass_max); uniform(lo, hi) slack
  with lo = max(1, due_slack - jitter), hi = due_slack + jitter.
* P-DUE: due_offset = ceil(slack * LB), LB = max(pick + critical_path + deliver, N - 1).

Lost releases draw nothing, so the k-th released product is controller independent and the
instance lists every product that can be released: continuing mode 1 + horizon // interval,
batch mode batch_size.
"""

from __future__ import annotations

import copy
import math
import random
from typing import Any, Mapping, Sequence

import networkx as nx

from agspec import IR_VERSION

REALIZATION_METHOD = "python-mt19937/construct-then-reset"
REACH_TOLERANCE = 1e-9  # G-REACH: a point is reachable iff distance <= reach + 1e-9

Recipe = Mapping[str, Any]


class InstanceError(ValueError):
    """The inputs cannot be realized (unknown recipe or variant, bad index/seed, cyclic recipe)."""


# --------------------------------------------------------------------------- profiles


def _deep_merge(base: dict[str, Any], overrides: Mapping[str, Any]) -> dict[str, Any]:
    out = dict(base)
    for key, value in overrides.items():
        if isinstance(value, Mapping) and isinstance(out.get(key), Mapping):
            out[key] = _deep_merge(dict(out[key]), value)
        else:
            out[key] = copy.deepcopy(value)
    return out


def resolve_profile(profile_ir: Mapping[str, Any], variant: str | None = None) -> dict[str, Any]:
    """PR-VARIANT: apply the named variant's overrides, drop ``variants``, record ``variant``."""
    variants = profile_ir.get("variants") or {}
    base = {k: copy.deepcopy(v) for k, v in profile_ir.items() if k not in ("variants", "variant")}
    if variant is not None:
        if variant not in variants:
            known = ", ".join(sorted(variants)) or "none"
            raise InstanceError(
                f"profile `{profile_ir.get('id')}` has no variant `{variant}` (declared: {known})"
            )
        base = _deep_merge(base, variants[variant])
    base["variant"] = variant
    return base


# --------------------------------------------------------------------------- recipes


def raw_types(recipe_ids: Sequence[str], recipes: Mapping[str, Recipe]) -> list[str]:
    """S-SHELF-LAYOUT: raw tokens of the scenario recipes in first-appearance order."""
    seen: list[str] = []
    for rid in recipe_ids:
        for tok in recipes[rid].get("raw", []):
            if tok not in seen:
                seen.append(tok)
    return seen


def critical_path(recipe: Recipe) -> int:
    """Longest chain of operation durations in the recipe DAG (XOR: the longest alternative).

    An ``after`` entry naming an XOR group depends on every alternative of the group; the
    longest path then takes the longest route (P-DUE).
    """
    ops = {op["id"]: op for op in recipe.get("operations", [])}
    groups = {g["id"]: list(g.get("alternatives", [])) for g in recipe.get("xor", []) or []}
    source = ("__source__",)  # a node no operation id can equal
    graph = nx.DiGraph()
    graph.add_node(source)
    for op_id, op in ops.items():
        graph.add_edge(source, op_id, weight=op["duration"])
    for op_id, op in ops.items():
        for pred in op.get("after", []):
            preds = groups.get(pred, [pred])
            for p in preds:
                if p not in ops:
                    raise InstanceError(
                        f"recipe `{recipe.get('id')}`: operation `{op_id}` runs after unknown `{p}`"
                    )
                graph.add_edge(p, op_id, weight=op["duration"])
    try:
        return int(nx.dag_longest_path_length(graph, weight="weight"))
    except nx.NetworkXUnfeasible as exc:
        raise InstanceError(f"recipe `{recipe.get('id')}` has a precedence cycle") from exc


def flow_time_lower_bound(recipe: Recipe, profile: Mapping[str, Any], cols: int) -> int:
    """P-DUE: LB = max(pick + critical_path + deliver, N - 1)."""
    durations = profile["durations"]
    return max(durations["pick"] + critical_path(recipe) + durations["deliver"], cols - 1)


# --------------------------------------------------------------------------- shelves


def shelf_layout(rows: int, raws: Sequence[str], capacity: int) -> list[dict[str, Any]]:
    """S-SHELF-LAYOUT: initial stock per shelf row."""
    stock: list[dict[str, int]] = [{} for _ in range(rows)]
    if raws:
        for r in range(rows):
            stock[r][raws[r % len(raws)]] = capacity
        for k, tok in enumerate(raws):
            stock[k % rows].setdefault(tok, capacity)
    return [{"row": r, "stock": stock[r]} for r in range(rows)]


def rows_stocking(shelves: Sequence[Mapping[str, Any]]) -> dict[str, list[int]]:
    """Rows stocking each token, ascending (the list ``choice`` draws a source row from)."""
    out: dict[str, list[int]] = {}
    for shelf in sorted(shelves, key=lambda s: s["row"]):
        for tok in shelf["stock"]:
            out.setdefault(tok, []).append(shelf["row"])
    return out


def _reaches_shelf(robot_row: int, shelf_row: int, spacing: float, reach: float) -> bool:
    # G-SHELF-POINT: robot (i, 0) has base (0, i*s); shelf point of row r is (-s/2, r*s).
    return math.hypot(0.5 * spacing, (shelf_row - robot_row) * spacing) <= reach + REACH_TOLERANCE


def draw_shelf_access(
    rng: random.Random, rows: int, probability: float, spacing: float, reach: float
) -> list[dict[str, Any]]:
    """S-SHELF-ACCESS: one reset's extra-access draws, shelf row outer, robot row inner."""
    access = []
    for r in range(rows):
        allowed = []
        for i in range(rows):
            if not _reaches_shelf(i, r, spacing, reach):
                continue
            if i == r:
                allowed.append(i)  # own row: no draw
            elif rng.random() < probability:
                allowed.append(i)
        access.append({"shelf_row": r, "robot_rows": allowed})
    return access


# --------------------------------------------------------------------------- products


def _slack_range(products: Mapping[str, Any]) -> tuple[float, float]:
    """S-PRODUCT-DRAW: the arguments (lo, hi) of the slack draw uniform(lo, hi)."""
    slack, jitter = products["due_slack"], products["due_slack_jitter"]
    return max(1, slack - jitter), slack + jitter


def slack_bounds(products: Mapping[str, Any]) -> tuple[float, float]:
    """The closed interval of slacks uniform(lo, hi) can draw: [hi, lo] when due_slack + jitter < 1
    makes lo = 1 > hi (RES-SLACK-BELOW-ONE)."""
    lo, hi = _slack_range(products)
    return min(lo, hi), max(lo, hi)


def draw_product(
    rng: random.Random,
    pid: int,
    scenario: Mapping[str, Any],
    recipes: Mapping[str, Recipe],
    candidate_rows: Mapping[str, Sequence[int]],
    lower_bounds: Mapping[str, int],
) -> dict[str, Any]:
    """P-RELEASE-DRAWS: the draws of one release, in the original order."""
    recipe_id = rng.choice(list(scenario["recipes"]))
    source_rows = {tok: rng.choice(list(candidate_rows[tok])) for tok in recipes[recipe_id]["raw"]}
    mass_min, mass_max = scenario["products"]["mass"]
    mass = rng.uniform(mass_min, mass_max)
    lo, hi = _slack_range(scenario["products"])
    slack = rng.uniform(lo, hi)
    return {
        "id": pid,
        "recipe": recipe_id,
        "source_rows": source_rows,
        "mass": mass,
        "slack": slack,
        "due_offset": math.ceil(slack * lower_bounds[recipe_id]),
    }


def releasable_count(scenario: Mapping[str, Any]) -> int:
    """How many products can be released: continuing 1 + horizon // interval; batch batch_size."""
    evaluation = scenario["evaluation"]
    if evaluation["mode"] == "batch":
        return int(evaluation["batch_size"])
    return 1 + int(evaluation["horizon"]) // int(scenario["release"]["interval"])


def _first_release_happens(scenario: Mapping[str, Any]) -> bool:
    # R-RELEASE: the forced release at t = 0 is skipped (no draw) only if WIP cap or batch is 0.
    if int(scenario["release"]["wip_cap"]) < 1:
        return False
    return releasable_count(scenario) >= 1


def realize(
    scenario: Mapping[str, Any],
    recipes: Mapping[str, Recipe],
    profile: Mapping[str, Any],
    generation_seed: int,
) -> dict[str, Any]:
    """I-REALIZATION: the evaluated (reset #2) realization for ``generation_seed``."""
    grid, shelves_cfg = scenario["grid"], scenario["shelves"]
    rows, cols = int(grid["rows"]), int(grid["cols"])
    raws = raw_types(scenario["recipes"], recipes)
    shelves = shelf_layout(rows, raws, int(shelves_cfg["capacity"]))
    candidate_rows = rows_stocking(shelves)
    lower_bounds = {rid: flow_time_lower_bound(recipes[rid], profile, cols) for rid in scenario["recipes"]}
    probability = shelves_cfg["extra_access_probability"]
    spacing, reach = profile["spacing"], profile["reach"]

    rng = random.Random(generation_seed)
    # reset #1 (construction): shelf access, then the forced release at t = 0
    draw_shelf_access(rng, rows, probability, spacing, reach)
    if _first_release_happens(scenario):
        draw_product(rng, 0, scenario, recipes, candidate_rows, lower_bounds)
    # reset #2 (unseeded; the evaluated episode)
    access = draw_shelf_access(rng, rows, probability, spacing, reach)
    products = [
        draw_product(rng, pid, scenario, recipes, candidate_rows, lower_bounds)
        for pid in range(releasable_count(scenario))
    ]
    return {
        "method": REALIZATION_METHOD,
        "raw_types": raws,
        "shelves": shelves,
        "shelf_access": access,
        "products": products,
    }


# --------------------------------------------------------------------------- identity


# S-SEEDS, RES-SEED-BASES-DEFAULT: the official generation and execution seed bases
DEFAULT_SEED_BASES = (10000, 20000)


def _check_seed(name: str, value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise InstanceError(f"{name} must be an integer, got {value!r}")
    return value


def instance_id(scenario: Mapping[str, Any], index: int | None, generation_seed: int, by_index: bool) -> str:
    """I-ID: official `{prefix}-{family}-{level}-s{index:02d}`, else `{scenario}-s{index:02d}`
    or, for an explicit generation seed, `{scenario}-g{seed}`."""
    suite = scenario.get("suite") or {}
    if by_index and index is not None:
        if suite.get("official"):
            return f"{suite['prefix']}-{scenario['family']}-{scenario['level']}-s{index:02d}"
        return f"{scenario['id']}-s{index:02d}"
    return f"{scenario['id']}-g{generation_seed}"


def make_instance(
    scenario_ir: Mapping[str, Any],
    recipes: Mapping[str, Recipe],
    profile_ir: Mapping[str, Any],
    *,
    index: int | None = None,
    generation_seed: int | None = None,
    execution_seed: int | None = None,
) -> dict[str, Any]:
    """Build the self-contained instance IR (S-INSTANCE).

    Seeds (S-SEEDS): suite index k gives generation = generation_seed_base + k and
    execution = execution_seed_base + k; explicit seeds override. With only an explicit
    generation seed the execution seed defaults to it (the original's single-``seed`` rule).
    """
    scenario = copy.deepcopy(dict(scenario_ir))
    suite = scenario.get("suite") or {}
    if index is not None:
        index = _check_seed("index", index)
        if index < 0:
            raise InstanceError(f"index must be >= 0, got {index}")
    if generation_seed is not None:
        generation_seed = _check_seed("generation seed", generation_seed)
    if execution_seed is not None:
        execution_seed = _check_seed("execution seed", execution_seed)

    derived_gen = derived_exec = None
    if index is not None:
        # RES-SEED-BASES-DEFAULT: a scenario without suite seed bases uses the official ones
        derived_gen = int(suite.get("generation_seed_base", DEFAULT_SEED_BASES[0])) + index
        derived_exec = int(suite.get("execution_seed_base", DEFAULT_SEED_BASES[1])) + index
    if generation_seed is None and derived_gen is None:
        raise InstanceError("give a suite index or a generation seed")
    gen = generation_seed if generation_seed is not None else derived_gen
    if execution_seed is not None:
        exe = execution_seed
    elif derived_exec is not None and gen == derived_gen:
        exe = derived_exec
    else:
        exe = gen
    by_index = index is not None and gen == derived_gen

    missing = [rid for rid in scenario["recipes"] if rid not in recipes]
    if missing:
        raise InstanceError(f"scenario `{scenario.get('id')}` uses unknown recipe(s): {', '.join(missing)}")
    ref = scenario.get("profile") or {}
    if ref.get("id") is not None and profile_ir.get("id") != ref.get("id"):
        raise InstanceError(
            f"scenario `{scenario.get('id')}` uses profile `{ref.get('id')}`, got `{profile_ir.get('id')}`"
        )
    profile = resolve_profile(profile_ir, ref.get("variant"))
    used = {rid: copy.deepcopy(dict(recipes[rid])) for rid in dict.fromkeys(scenario["recipes"])}

    return {
        "ir_version": IR_VERSION,
        "kind": "instance",
        "id": instance_id(scenario, index, gen, by_index),
        "scenario": scenario,
        "recipes": used,
        "profile": profile,
        "seeds": {"index": index, "generation": gen, "execution": exe},
        "realization": realize(scenario, used, profile, gen),
    }
