"""Scenario checks (spec chapter 04, S-*; codes AG410-AG422): grid, product mix, profile reference,
release, evaluation, shelves, products, resources and k_topo coupling."""

from __future__ import annotations

import json
from functools import lru_cache
from typing import Mapping

from agspec.formats.diagnostics import Issue
from agspec.ir import topology, variants
from agspec.ir.fingerprint import FingerprintError, fingerprint
from agspec.ir.validate.common import Json, Resolver, _dict, _did_you_mean, _err, _fixable, _is_int, _is_num, _list
from agspec.ir.validate.common import _ptr, _q, _str, _warn
from agspec.ir.validate.recipe import arity_of, recipe_view
from agspec.resources import catalogue_dir


def validate_scenario(ir: Json, resolver: Resolver) -> list[Issue]:
    """S-*: grid, references, release, evaluation, shelves, products, resources, and the coupling
    of every recipe's coalition demand with this grid's k_topo (S-FEASIBILITY, D-KTOPO); a scenario
    that claims to be official must be one of the catalogue's (S-OFFICIAL)."""
    return _validate_scenario(ir, resolver, check_variant=True) + _check_official_claim(_dict(ir))


@lru_cache(maxsize=1)
def _official_fingerprints() -> frozenset[str]:
    """The fingerprints of the official scenarios in the shipped catalogue lock (F-LOCK)."""
    try:
        lock = json.loads((catalogue_dir() / "lock.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return frozenset()
    return frozenset(entry.get("fingerprint") for entry in _dict(lock.get("scenarios")).values()
                     if isinstance(entry, dict))


def _check_official_claim(scenario: Mapping) -> list[Issue]:
    """S-OFFICIAL: `suite official` is a claim that results are comparable with the paper's; only the nine
    catalogue scenarios make it truthfully (a copy with any change has another fingerprint)."""
    if _dict(scenario.get("suite")).get("official") is not True:
        return []
    try:
        own = fingerprint(scenario)
    except FingerprintError:
        return []
    if own in _official_fingerprints():
        return []
    return [_warn("AG424", f"scenario {_q([scenario.get('id')])} claims `suite official` but is not an official "
                  f"catalogue scenario (its fingerprint {own[:19]}… is none of catalogue/lock.json's): its results "
                  "would be presented as comparable with the paper's", _ptr("suite", "official"),
                  "a scenario of your own is `suite unofficial prefix …`; `agspec catalogue list` shows the official ones")]


def _validate_scenario(ir: Json, resolver: Resolver, *, check_variant: bool) -> list[Issue]:
    scenario = _dict(ir)
    issues = _check_grid(scenario)
    issues += _check_recipe_refs(scenario, resolver)
    issues += _check_profile_ref(scenario, resolver, check_variant)
    issues += _check_scenario_numbers(scenario)
    issues += _check_scenario_resources(scenario)
    issues += _check_k_topo(scenario, resolver)
    issues += variants.check("scenario", scenario)  # S-RULE-VARIANTS
    return issues


def _grid_k_topo(scenario: Mapping) -> tuple[int, str] | None:
    """(k_topo, description) of a well-formed scenario grid, else None."""
    grid = _dict(scenario.get("grid"))
    rows, cols = grid.get("rows"), grid.get("cols")
    if not (_is_int(rows) and _is_int(cols) and rows >= 1 and cols >= 1):
        return None
    topo, radius = grid.get("topology", topology.DEFAULT_TOPOLOGY), grid.get("radius", topology.DEFAULT_RADIUS)
    if not (_is_int(radius) and isinstance(topo, str)):
        return None
    try:
        k = topology.grid_k_topo(int(rows), int(cols), topo, int(radius))
    except topology.TopologyError:
        return None
    return k, f"a {int(rows)}x{int(cols)} {topo} grid (radius {int(radius)})"


def _check_grid(scenario: Mapping) -> list[Issue]:
    """S-GRID: at least 1 row and 2 columns (input and output columns differ); known topology."""
    out: list[Issue] = []
    grid = _dict(scenario.get("grid"))
    if "rows" in grid and not (_is_int(grid["rows"]) and grid["rows"] >= 1):
        out.append(_err("AG410", f"the grid needs at least 1 row, got {grid['rows']!r}", _ptr("grid", "rows"),
                        "official grids have 4 to 6 rows"))
    if "cols" in grid and not (_is_int(grid["cols"]) and grid["cols"] >= 2):
        out.append(_err("AG410", f"the grid needs at least 2 columns, got {grid['cols']!r}",
                        _ptr("grid", "cols"),
                        "raw material enters in the left column and leaves from the right one; they must differ"))
    topo = grid.get("topology", topology.DEFAULT_TOPOLOGY)
    if isinstance(topo, str) and topo not in topology.TOPOLOGIES:
        out.append(_fixable(_err("AG411", f"unknown topology `{topo}`{_did_you_mean(topo, topology.TOPOLOGIES)}",
                                 _ptr("grid", "topology"), f"use one of {_q(topology.TOPOLOGIES)}"),
                            topo, topology.TOPOLOGIES))
    radius = grid.get("radius", topology.DEFAULT_RADIUS)
    if not (_is_int(radius) and radius >= 1):
        out.append(_err("AG411", f"topology radius must be an integer >= 1, got {radius!r}",
                        _ptr("grid", "radius"), "AssemblyGrid v1 uses radius 1"))
    return out


def _check_recipe_refs(scenario: Mapping, resolver: Resolver) -> list[Issue]:
    """S-MIX: the product mix is non-empty and names known recipes (a repeat skews the mix)."""
    out: list[Issue] = []
    recipes = scenario.get("recipes")
    if isinstance(recipes, list) and not recipes:
        out.append(_err("AG420", "the product mix is empty", _ptr("recipes"),
                        "list at least one recipe, e.g. `recipes supported_insert`"))
    seen: set[str] = set()
    for m, name in enumerate(_list(recipes)):
        if not isinstance(name, str):
            continue
        if name in seen:
            out.append(_warn("AG413", f"recipe `{name}` is listed twice in the product mix; releases choose "
                             "uniformly from the list, so it is drawn more often", _ptr("recipes", m),
                             "remove the repeat unless the skew is intended"))
            continue
        seen.add(name)
        if _resolve(resolver, "recipe", name) is None:
            known = _names(resolver, "recipe")
            out.append(_fixable(_err("AG412", f"unknown recipe `{name}`{_did_you_mean(name, known)}", _ptr("recipes", m),
                                     "declare the recipe in a .ag file on the search path or use a catalogue recipe"),
                                name, known))
    return out


def _names(resolver: Resolver | None, kind: str) -> list[str]:
    """The names a resolver knows for ``kind`` (F-SUGGEST), where it can list them."""
    names = getattr(resolver, "names", None)
    return list(names(kind)) if callable(names) else []


def _resolve(resolver: Resolver | None, kind: str, name: str) -> Json | None:
    if resolver is None:
        return None
    try:
        doc = resolver.get(kind, name)
    except (KeyError, LookupError, ValueError, OSError):
        return None
    return doc if isinstance(doc, Mapping) else None


def _check_profile_ref(scenario: Mapping, resolver: Resolver, check_variant: bool) -> list[Issue]:
    """S-PROFILE: the geometry profile exists and declares the chosen variant."""
    ref = _dict(scenario.get("profile"))
    pid = _str(ref.get("id"))
    if pid is None:
        return []
    profile = _resolve(resolver, "profile", pid)
    if profile is None:
        known = _names(resolver, "profile")
        return [_fixable(_err("AG414", f"unknown geometry profile `{pid}`{_did_you_mean(pid, known)}", _ptr("profile", "id"),
                              "official scenarios use `abstract-v1`"), pid, known)]
    variant = ref.get("variant")
    variants = _dict(profile.get("variants"))
    if check_variant and isinstance(variant, str) and variant not in variants:
        known = _q(sorted(variants)) or "none"
        return [_fixable(_err("AG415", f"profile `{pid}` has no variant `{variant}`{_did_you_mean(variant, variants)}",
                              _ptr("profile", "variant"), f"declared variants: {known}"), variant, variants)]
    return []


# (section, key, kind): kind "pos_int" > 0 integer, "nonneg_int" >= 0 integer, "pos" > 0 number,
# "nonneg" >= 0 number, "prob" in [0, 1].
# (section, key, rule, how the DSL writes it): messages name the setting as a `.ag` author wrote it
SCENARIO_NUMBERS: tuple[tuple[str, str, str, str], ...] = (
    ("release", "interval", "pos_int", "release every N"),
    ("release", "wip_cap", "pos_int", "wip N"),
    ("evaluation", "horizon", "pos_int", "evaluation continuing horizon N"),
    ("evaluation", "batch_size", "pos_int", "evaluation batch N"),
    ("evaluation", "timeout", "pos_int", "evaluation batch ... timeout N"),
    ("shelves", "capacity", "pos_int", "shelves capacity N"),
    ("shelves", "replenish_interval", "pos_int", "shelves ... replenish N"),
    ("shelves", "extra_access_probability", "prob", "shelves ... extra_access P"),
    ("coordination", "support_timeout", "nonneg_int", "coordination support_timeout N"),
    ("coordination", "switch_lock", "nonneg_int", "coordination ... switch_lock N"),
    ("products", "due_slack", "pos", "products ... due_slack X"),
    ("products", "due_slack_jitter", "nonneg", "products ... jitter X"),
)

_NUMBER_RULES = {
    "pos_int": ("AG416", "an integer >= 1", lambda x: _is_int(x) and x >= 1),
    "pos": ("AG416", "a number > 0", lambda x: _is_num(x) and x > 0),
    "nonneg_int": ("AG417", "an integer >= 0", lambda x: _is_int(x) and x >= 0),
    "nonneg": ("AG417", "a number >= 0", lambda x: _is_num(x) and x >= 0),
    "prob": ("AG418", "a probability in [0, 1]", lambda x: _is_num(x) and 0 <= x <= 1),
}


def _check_scenario_numbers(scenario: Mapping) -> list[Issue]:
    """S-RELEASE, S-EVALUATION, S-SHELVES, S-COORDINATION, S-PRODUCTS: value ranges."""
    out: list[Issue] = []
    for section, key, kind, dsl in SCENARIO_NUMBERS:
        values = _dict(scenario.get(section))
        if key not in values:
            continue
        code, what, ok = _NUMBER_RULES[kind]
        if not ok(values[key]):
            out.append(_err(code, f"`{dsl}` (`{section}.{key}`): the value must be {what}, got {values[key]!r}",
                            _ptr(section, key), _NUMBER_HINTS.get(key)))
    mass = _dict(scenario.get("products")).get("mass")
    if isinstance(mass, list):
        if not (len(mass) == 2 and all(_is_num(m) for m in mass) and 0 <= mass[0] <= mass[1]):
            out.append(_err("AG419", f"`products.mass` must be a range [min, max] with 0 <= min <= max, "
                            f"got {mass!r}", _ptr("products", "mass"), "official scenarios use [0.5, 2.0]"))
    return out


_NUMBER_HINTS = {
    "interval": "a product is offered every `interval` ticks",
    "wip_cap": "at most `wip_cap` unfinished products are in the system; at least 1",
    "horizon": "official evaluations run 400 ticks",
    "batch_size": "a batch has at least one product",
    "timeout": "a batch evaluation stops after `timeout` ticks",
    "capacity": "official shelves hold 6 units per raw material",
    "replenish_interval": "official shelves gain a unit every 5 ticks",
    "extra_access_probability": "official scenarios use 0.30",
    "support_timeout": "official scenarios use 3 ticks",
    "switch_lock": "official scenarios use 1 tick",
    "due_slack": "official scenarios use 2.2",
    "due_slack_jitter": "official scenarios use 0.5",
}


def _check_scenario_resources(scenario: Mapping) -> list[Issue]:
    """S-RESOURCES: scenario resource capacities are integers >= 0 (0 disables a resource; an
    operation that needs it is then reported by the realizability check, AG455)."""
    out: list[Issue] = []
    for name, cap in _dict(scenario.get("resources")).items():
        if not (_is_int(cap) and cap >= 0):
            out.append(_err("AG422", f"resource `{name}`: capacity must be an integer >= 0, got {cap!r}",
                            _ptr("resources", name), "capacity = how many activities may hold it at once"))
    return out


def _check_k_topo(scenario: Mapping, resolver: Resolver) -> list[Issue]:
    """S-FEASIBILITY (coalition size): kmin <= k_topo of THIS grid for every operation of the mix."""
    grid = _grid_k_topo(scenario)
    if grid is None:
        return []
    k, where = grid
    out: list[Issue] = []
    seen: set[str] = set()
    for m, name in enumerate(_list(scenario.get("recipes"))):
        if not isinstance(name, str) or name in seen:
            continue
        seen.add(name)
        recipe = _resolve(resolver, "recipe", name)
        if recipe is None:
            continue
        for op in recipe_view(recipe).ops:
            arity = arity_of(op)
            if arity is not None and arity[0] > k:
                out.append(_err(
                    "AG421", f"recipe `{name}`: operation `{op.id}` needs at least {arity[0]} robots, but "
                    f"{where} allows coalitions of at most {k} (k_topo)", _ptr("recipes", m),
                    "use a grid/topology whose manipulation graph has larger cliques (moore radius 1: 4), "
                    "or a recipe with smaller teams"))
    return out
