"""Instance checks (spec chapter 04, S-INSTANCE and S-REALIZATION; codes AG5xx): embedded documents,
profile binding, raw types, shelves, shelf access and products."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping

from agspec.formats.diagnostics import Issue
from agspec.ir.validate.common import REACH_TOLERANCE, Json, _dict, _err, _is_int, _is_num, _list, _prefixed, _ptr, _q
from agspec.ir.validate.common import _warn, errors
from agspec.ir.validate.profile import validate_profile
from agspec.ir.validate.recipe import validate_recipe
from agspec.ir.validate.scenario import _validate_scenario


class _EmbeddedResolver:
    """Resolves names against the documents embedded in an instance."""

    def __init__(self, instance: Mapping) -> None:
        self._recipes = _dict(instance.get("recipes"))
        self._profile = _dict(instance.get("profile"))

    def get(self, kind: str, name: str) -> Json | None:
        if kind == "recipe":
            return self._recipes.get(name)
        if kind == "profile" and self._profile.get("id") == name:
            return self._profile
        return None


def validate_instance(ir: Json) -> list[Issue]:
    """I-*: embedded documents are valid and of the right kind, and the realization is consistent
    with the scenario (shelves, shelf access, raw types, products)."""
    inst = _dict(ir)
    issues = _check_embedded(inst)
    issues += _check_profile_binding(inst)
    issues += _check_realization(inst)
    return issues


def _check_embedded(inst: Mapping) -> list[Issue]:
    """I-EMBEDDED: kinds, recipe keys, the recipes of the mix, and each embedded document's checks."""
    out: list[Issue] = []
    scenario, profile = _dict(inst.get("scenario")), _dict(inst.get("profile"))
    for key, doc, kind in (("scenario", scenario, "scenario"), ("profile", profile, "profile")):
        if doc and doc.get("kind") != kind:
            out.append(_err("AG501", f"the embedded {key} has kind {doc.get('kind')!r}, expected `{kind}`",
                            _ptr(key, "kind"), f"embed the {kind} IR itself"))
    recipes = _dict(inst.get("recipes"))
    for key, recipe in recipes.items():
        recipe = _dict(recipe)
        if recipe.get("kind") != "recipe":
            out.append(_err("AG501", f"embedded recipe `{key}` has kind {recipe.get('kind')!r}, expected "
                            "`recipe`", _ptr("recipes", key, "kind"), "embed recipe IR documents"))
        if recipe.get("id") != key:
            out.append(_err("AG502", f"embedded recipe is keyed `{key}` but its id is {recipe.get('id')!r}",
                            _ptr("recipes", key, "id"), "key every embedded recipe by its own id"))
        out += _prefixed(_ptr("recipes", key), validate_recipe(recipe))
    mix = [n for n in _list(scenario.get("recipes")) if isinstance(n, str)]
    for m, name in enumerate(_list(scenario.get("recipes"))):
        if isinstance(name, str) and name not in recipes:
            out.append(_err("AG503", f"recipe `{name}` of the product mix is not embedded in the instance",
                            _ptr("scenario", "recipes", m), "an instance embeds every recipe of its mix"))
    for key in recipes:
        if key not in mix:
            out.append(_warn("AG503", f"embedded recipe `{key}` is not in the scenario's product mix",
                             _ptr("recipes", key), "remove it; only recipes of the mix are released"))
    if profile:
        out += _prefixed(_ptr("profile"), validate_profile(profile))
    if scenario:
        embedded = _EmbeddedResolver(inst)
        checked = _validate_scenario(scenario, embedded, check_variant=False)
        # AG503 already reports a mix recipe that is not embedded (AG412 would repeat it); AG504
        # reports a profile mismatch (AG414 would repeat it).
        out += _prefixed(_ptr("scenario"), [i for i in checked if i.code not in ("AG412", "AG414")])
    return out


def _check_profile_binding(inst: Mapping) -> list[Issue]:
    """I-PROFILE: the embedded profile is the scenario's profile, resolved for its variant."""
    profile = _dict(inst.get("profile"))
    ref = _dict(_dict(inst.get("scenario")).get("profile"))
    if not profile or not ref:
        return []
    out: list[Issue] = []
    if profile.get("id") != ref.get("id"):
        out.append(_err("AG504", f"the embedded profile is {profile.get('id')!r} but the scenario uses "
                        f"{ref.get('id')!r}", _ptr("profile", "id"), "embed the scenario's profile"))
    if profile.get("variant") != ref.get("variant"):
        out.append(_err("AG504", f"the embedded profile is resolved for {_variant(profile.get('variant'))} "
                        f"but the scenario chooses {_variant(ref.get('variant'))}", _ptr("profile", "variant"),
                        "resolve the profile with the scenario's variant"))
    if "variants" in profile:
        out.append(_err("AG504", "the embedded profile still lists its variants; an instance embeds the "
                        "resolved profile", _ptr("profile", "variants"),
                        "apply the chosen variant and drop `variants`"))
    return out


def _variant(name: object) -> str:
    return "no variant" if name is None else f"variant `{name}`"


@dataclass(frozen=True)
class _Layout:
    rows: int
    cols: int
    spacing: float
    reach: float
    capacity: int | None


def _layout(inst: Mapping) -> _Layout | None:
    scenario, profile = _dict(inst.get("scenario")), _dict(inst.get("profile"))
    grid = _dict(scenario.get("grid"))
    rows, cols = grid.get("rows"), grid.get("cols")
    spacing, reach = profile.get("spacing"), profile.get("reach")
    if not (_is_int(rows) and _is_int(cols) and rows >= 1 and cols >= 1):
        return None
    if not (_is_num(spacing) and _is_num(reach) and spacing > 0 and reach > 0):
        return None
    cap = _dict(scenario.get("shelves")).get("capacity")
    return _Layout(int(rows), int(cols), float(spacing), float(reach), int(cap) if _is_int(cap) else None)


def _check_realization(inst: Mapping) -> list[Issue]:
    """I-REALIZATION: checks that depend on a broken part (missing recipe, malformed shelves,
    invalid recipe or profile) are skipped so that one mistake is reported once."""
    real = _dict(inst.get("realization"))
    layout = _layout(inst)
    if not real or layout is None:
        return []
    scenario = _dict(inst.get("scenario"))
    recipes = {k: _dict(v) for k, v in _dict(inst.get("recipes")).items()}
    mix_complete = all(n in recipes for n in _list(scenario.get("recipes")) if isinstance(n, str))
    out = _check_raw_types(real, scenario, recipes) if mix_complete else []
    shelves = _check_shelves(real, layout)
    out += shelves + _check_shelf_access(real, layout)
    out += _check_products(inst, real, layout, recipes, shelves_ok=not errors(shelves))
    return out


def _expected_raw_types(scenario: Mapping, recipes: Mapping[str, Mapping]) -> list[str]:
    """S-SHELF-LAYOUT: raw tokens of the mix's recipes in first-appearance order."""
    seen: list[str] = []
    for name in _list(scenario.get("recipes")):
        for tok in _list(_dict(recipes.get(name)).get("raw")) if isinstance(name, str) else []:
            if isinstance(tok, str) and tok not in seen:
                seen.append(tok)
    return seen


def _check_raw_types(real: Mapping, scenario: Mapping, recipes: Mapping[str, Mapping]) -> list[Issue]:
    """I-RAW-TYPES: the recorded raw types are those of the mix, in first-appearance order."""
    expected = _expected_raw_types(scenario, recipes)
    got = real.get("raw_types")
    if isinstance(got, list) and got != expected:
        return [_err("AG505", f"realization raw types are {got!r}, but the product mix needs {expected!r} "
                     "(first-appearance order)", _ptr("realization", "raw_types"),
                     "regenerate the instance with `agspec instance`")]
    return []


def _check_shelves(real: Mapping, layout: _Layout) -> list[Issue]:
    """I-SHELVES: one shelf per grid row, in row order; stock of raw types within [0, capacity];
    every raw type stocked somewhere; the S-SHELF-LAYOUT pattern (warning if it deviates)."""
    shelves = real.get("shelves")
    if not isinstance(shelves, list):
        return []
    out: list[Issue] = []
    raws = [t for t in _list(real.get("raw_types")) if isinstance(t, str)]
    stocked: set[str] = set()
    for k, shelf in enumerate(shelves):
        row = _dict(shelf).get("row")
        if row != k:
            out.append(_err("AG506", f"shelf {k} is for row {row!r}; shelves list rows 0..{layout.rows - 1} "
                            "in order, one per grid row", _ptr("realization", "shelves", k, "row"),
                            "regenerate the instance with `agspec instance`"))
        for tok, amount in _dict(_dict(shelf).get("stock")).items():
            where = _ptr("realization", "shelves", k, "stock", tok)
            if tok not in raws:
                out.append(_err("AG507", f"shelf row {row} stocks `{tok}`, which is not a raw material of "
                                "the product mix", where, f"raw types: {_q(raws)}"))
            elif not (_is_int(amount) and 0 <= amount <= (layout.capacity if layout.capacity is not None else amount)):
                out.append(_err("AG507", f"shelf row {row} holds {amount!r} units of `{tok}`; stock must be an "
                                f"integer in [0, {layout.capacity}]", where, "shelf capacity is per token and row"))
            stocked.add(tok)
    if len(shelves) != layout.rows:
        out.append(_err("AG506", f"the realization lists {len(shelves)} shelves for a grid of {layout.rows} rows",
                        _ptr("realization", "shelves"), "one shelf per grid row"))
    for tok in raws:
        if tok not in stocked:
            out.append(_err("AG507", f"no shelf stocks raw material `{tok}`", _ptr("realization", "shelves"),
                            "products could never source it"))
    if not out and layout.capacity is not None:
        out += _check_shelf_pattern(shelves, raws, layout)
    return out


def _check_shelf_pattern(shelves: list, raws: list[str], layout: _Layout) -> list[Issue]:
    """S-SHELF-LAYOUT: row r stocks raws[r mod n] (plus raw k on row k mod M), all at capacity."""
    from agspec.ir.instance import shelf_layout  # the generator's own layout rule

    expected = shelf_layout(layout.rows, raws, layout.capacity)
    for k, (got, want) in enumerate(zip(shelves, expected)):
        if _dict(got).get("stock") != want["stock"]:
            return [_warn("AG515", f"shelf row {k} starts with stock {_dict(got).get('stock')!r}; the "
                          f"S-SHELF-LAYOUT pattern gives {want['stock']!r}",
                          _ptr("realization", "shelves", k, "stock"),
                          "fine for a hand-made test instance; generated instances follow the pattern")]
    return []


def _reaches_shelf(robot_row: int, shelf_row: int, layout: _Layout) -> bool:
    """G-SHELF-POINT, G-REACH: robot (i, 0) reaches the shelf point (-s/2, r*s) of row r."""
    dist = math.hypot(0.5 * layout.spacing, (shelf_row - robot_row) * layout.spacing)
    return dist <= layout.reach + REACH_TOLERANCE


def _check_shelf_access(real: Mapping, layout: _Layout) -> list[Issue]:
    """I-SHELF-ACCESS (S-SHELF-ACCESS): per shelf row, in row order, the ascending left-column robot
    rows allowed to pick there: rows that reach the shelf point, always including the own row."""
    access = real.get("shelf_access")
    if not isinstance(access, list):
        return []
    out: list[Issue] = []
    if len(access) != layout.rows:
        out.append(_err("AG508", f"shelf access lists {len(access)} shelves for a grid of {layout.rows} rows",
                        _ptr("realization", "shelf_access"), "one entry per shelf row"))
    for k, entry in enumerate(access):
        shelf_row, robot_rows = _dict(entry).get("shelf_row"), _dict(entry).get("robot_rows")
        if shelf_row != k:
            out.append(_err("AG508", f"shelf access entry {k} is for shelf row {shelf_row!r}; entries list "
                            "shelf rows in order", _ptr("realization", "shelf_access", k, "shelf_row"),
                            "regenerate the instance with `agspec instance`"))
            continue
        rows = _list(robot_rows)
        for m, row in enumerate(rows):
            where = _ptr("realization", "shelf_access", k, "robot_rows", m)
            if not (_is_int(row) and 0 <= row < layout.rows):
                out.append(_err("AG508", f"shelf row {k}: robot row {row!r} is outside the grid", where,
                                f"rows are 0..{layout.rows - 1}"))
            elif m > 0 and _is_int(rows[m - 1]) and row <= rows[m - 1]:
                out.append(_err("AG508", f"shelf row {k}: robot rows must be ascending and distinct", where,
                                "sort the rows"))
            elif not _reaches_shelf(int(row), k, layout):
                out.append(_err("AG508", f"shelf row {k}: the left-column robot of row {row} cannot reach the "
                                "shelf point, so it cannot pick there", where,
                                "only rows within reach of the shelf point may get access"))
        if _reaches_shelf(k, k, layout) and isinstance(robot_rows, list) and k not in robot_rows:
            out.append(_err("AG508", f"shelf row {k}: its own row's robot reaches the shelf but has no "
                            "access", _ptr("realization", "shelf_access", k, "robot_rows"),
                            "the own row always has access (no draw)"))
    return out


def _check_products(
    inst: Mapping, real: Mapping, layout: _Layout, recipes: Mapping[str, Mapping], *, shelves_ok: bool
) -> list[Issue]:
    """I-PRODUCTS: ids 0..n-1 in release order, as many as can be released, recipes of the mix,
    source rows that stock the token, attributes within the scenario's ranges."""
    products = real.get("products")
    if not isinstance(products, list):
        return []
    scenario = _dict(inst.get("scenario"))
    out: list[Issue] = []
    expected = _expected_product_count(scenario)
    if expected is not None and len(products) != expected:
        out.append(_err("AG511", f"the realization lists {len(products)} products; this scenario can release "
                        f"{expected}", _ptr("realization", "products"),
                        "continuing mode: 1 + horizon // interval; batch mode: batch_size"))
    stock = [_dict(_dict(s).get("stock")) for s in _list(real.get("shelves"))]  # index = row if shelves_ok
    mix = [n for n in _list(scenario.get("recipes")) if isinstance(n, str)]
    sound = {n for n in mix if n in recipes and not errors(validate_recipe(recipes[n]))}
    profile_ok = not errors(validate_profile(_dict(inst.get("profile"))))
    for k, product in enumerate(products):
        product = _dict(product)
        if product.get("id") != k:
            out.append(_err("AG510", f"product {k} has id {product.get('id')!r}; products are numbered "
                            "0, 1, 2, ... in release order", _ptr("realization", "products", k, "id"),
                            "regenerate the instance with `agspec instance`"))
        recipe_id = product.get("recipe")
        if not isinstance(recipe_id, str) or recipe_id not in mix:
            out.append(_err("AG509", f"product {k} is a `{recipe_id}`, which is not in the product mix "
                            f"{_q(mix)}", _ptr("realization", "products", k, "recipe"),
                            "products are drawn from the scenario's recipes"))
            continue
        if recipe_id not in recipes:
            continue  # AG503 reports the missing recipe
        if shelves_ok:
            out += _check_source_rows(k, product, recipes[recipe_id], stock, layout)
        out += _check_product_draws(inst, k, product, recipes[recipe_id], layout,
                                    due=recipe_id in sound and profile_ok)
    return out


def _expected_product_count(scenario: Mapping) -> int | None:
    """P-RELEASE: continuing 1 + horizon // interval; batch: batch_size."""
    evaluation, release = _dict(scenario.get("evaluation")), _dict(scenario.get("release"))
    if evaluation.get("mode") == "batch":
        size = evaluation.get("batch_size")
        return int(size) if _is_int(size) else None
    horizon, interval = evaluation.get("horizon"), release.get("interval")
    if _is_int(horizon) and _is_int(interval) and interval >= 1:
        return 1 + int(horizon) // int(interval)
    return None


def _check_source_rows(k: int, product: Mapping, recipe: Mapping, stock: list, layout: _Layout) -> list[Issue]:
    """I-SOURCE-ROWS: one source row per raw token of the recipe, each a row stocking the token."""
    out: list[Issue] = []
    sources = product.get("source_rows")
    if not isinstance(sources, Mapping):
        return []
    raw = [t for t in _list(recipe.get("raw")) if isinstance(t, str)]
    base = _ptr("realization", "products", k, "source_rows")
    for tok in raw:
        if tok not in sources:
            out.append(_err("AG512", f"product {k} has no source row for raw material `{tok}`", base,
                            "every raw token of the recipe needs a source row"))
    for tok, row in sources.items():
        where = base + _ptr(tok)
        if tok not in raw:
            out.append(_err("AG512", f"product {k} has a source row for `{tok}`, which its recipe does not "
                            "use", where, f"the recipe's raw materials: {_q(raw)}"))
        elif not (_is_int(row) and 0 <= row < layout.rows):
            out.append(_err("AG512", f"product {k}: source row {row!r} of `{tok}` is outside the grid", where,
                            f"rows are 0..{layout.rows - 1}"))
        elif int(row) >= len(stock) or tok not in stock[int(row)]:
            out.append(_err("AG512", f"product {k} sources `{tok}` from shelf row {row}, which does not stock "
                            "it", where, "source rows are drawn among the rows stocking the token"))
    return out


def _check_product_draws(
    inst: Mapping, k: int, product: Mapping, recipe: Mapping, layout: _Layout, *, due: bool
) -> list[Issue]:
    """P-RELEASE-DRAWS, P-DUE: mass and slack within the scenario ranges; due offset = ceil(slack * LB)."""
    out: list[Issue] = []
    params = _dict(_dict(inst.get("scenario")).get("products"))
    check_due = due
    mass, slack, due = product.get("mass"), product.get("slack"), product.get("due_offset")
    rng = params.get("mass")
    if isinstance(rng, list) and len(rng) == 2 and all(_is_num(x) for x in rng) and _is_num(mass):
        if not rng[0] <= mass <= rng[1]:
            out.append(_err("AG513", f"product {k} has mass {mass}, outside the scenario range {rng}",
                            _ptr("realization", "products", k, "mass"), "mass ~ U(min, max)"))
    ds, jitter = params.get("due_slack"), params.get("due_slack_jitter")
    if _is_num(ds) and _is_num(jitter) and _is_num(slack):
        lo, hi = _slack_bounds(ds, jitter)
        if not lo <= slack <= hi:
            out.append(_err("AG513", f"product {k} has due slack {slack}, outside [{lo}, {hi}]",
                            _ptr("realization", "products", k, "slack"),
                            "slack ~ U(max(1, due_slack - jitter), due_slack + jitter)"))
        elif check_due and _is_int(due):
            bound = _lower_bound(recipe, _dict(inst.get("profile")), layout.cols)
            if bound is not None and int(due) != math.ceil(slack * bound):
                out.append(_err("AG513", f"product {k} has due offset {due}, but ceil(slack x LB) = "
                                f"ceil({slack} x {bound}) = {math.ceil(slack * bound)}",
                                _ptr("realization", "products", k, "due_offset"),
                                "LB = max(pick + critical path + deliver, N - 1)"))
    return out


def _slack_bounds(due_slack: float, jitter: float) -> tuple[float, float]:
    """The slacks S-PRODUCT-DRAW can draw, from the draw's own definition (RES-SLACK-BELOW-ONE)."""
    from agspec.ir.instance import slack_bounds

    return slack_bounds({"due_slack": due_slack, "due_slack_jitter": jitter})


def _lower_bound(recipe: Mapping, profile: Mapping, cols: int) -> int | None:
    """P-DUE: LB = max(pick + critical_path + deliver, N - 1), or None if it cannot be computed."""
    from agspec.ir.instance import flow_time_lower_bound

    try:
        return int(flow_time_lower_bound(recipe, profile, cols))
    except (ValueError, KeyError, TypeError):
        return None
