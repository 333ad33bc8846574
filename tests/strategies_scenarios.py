"""Hypothesis strategies for whole *valid* scenarios: recipes, a profile and a scenario that together
pass ``agspec validate`` (errors), and the instance realized from them.

The space drawn is the space the DSL and the IR accept (S-SCENARIO, S-RULE-VARIANTS, D-TOPOLOGY):

* grids of 1..5 rows and 2..6 columns under the three topologies with radius 1 and 2;
* one to three recipes from :func:`strategies.recipes` (XOR groups, resources, odd names), their
  arity capped by the grid's k_topo (D-KTOPO) and their raw tokens by it too, so that AG421 rarely
  rejects;
* a profile around ``abstract-v1`` with every geometry switch and parameter that changes behaviour
  (``motion_planning``, ``trajectory_conflicts``, ``spacing``, ``reach``, ``rho_conf``,
  ``clearance``, ``role_target_offset``, ``retreat_fraction``, speeds, logistics durations,
  ``payload``) and up to three named variants, one of which the scenario may select (PR-VARIANT);
* release interval and WIP cap, continuing or batch evaluation, shelf capacities down to 1 with
  slow replenishment (releases get lost, R-RELEASE), extra access, every coordination setting
  (``support_timeout`` 0..5, ``switch_lock`` 0..3, ``support_visible``), product mass ranges (some
  above the payload: AG459 rejects those), scenario resources that override the recipes' (capacity
  0, 1 = exclusive, 2..3 = finite).

A draw is kept only if the real validator accepts it: JSON Schema and the semantic checks of every
document (``agspec.load.semantic_validator``: RC-*, PR-*, S-*, realizability AG45x) and the
instance checks (AG5xx) of the realized instance.  :func:`bundle_errors` is that filter;
:func:`raw_bundles` the unfiltered strategy (its acceptance rate is reported by
``benchmarks/selfcheck.py``); :func:`bundles` the filtered one.

Every document is in canonical form *as the DSL builds it*: the drawn IR is formatted
(``agspec.dsl.fmt``) and compiled back, so what is checked is what a user writing the text gets.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from hypothesis import assume
from hypothesis import strategies as st

from agspec.dsl.build import compile_text
from agspec.dsl.fmt import format_ir
from agspec.ir.instance import make_instance
from agspec.ir.schemas import validate_schema
from agspec.ir.topology import TOPOLOGIES, grid_k_topo
from agspec.ir.validate import validate_instance
from agspec.load import semantic_validator
from strategies import IR, recipes

Json = dict[str, Any]


@dataclass(frozen=True)
class Bundle:
    """One generated scenario with everything it references, and its DSL texts."""

    recipes: dict[str, Json]  # recipe id -> IR
    profile: Json
    scenario: Json
    texts: dict[str, str]  # "recipe:<id>" / "profile" / "scenario" -> canonical DSL text
    instance: Json | None = None
    problems: tuple[str, ...] = ()  # instance errors (AG5xx) of a scenario the validator accepted

    def describe(self) -> str:
        g = self.scenario["grid"]
        return (f"{g['rows']}x{g['cols']} {g['topology']} r{g['radius']}, recipes {list(self.recipes)}, "
                f"profile variant {self.scenario['profile'].get('variant')}")


class _Docs:
    """The resolver of the validator (``get(kind, name)``) over the bundle's own documents."""

    def __init__(self, recipes: dict[str, Json], profile: Json):
        self.recipes, self.profile = recipes, profile

    def get(self, kind: str, name: str) -> Json | None:
        if kind == "recipe":
            return self.recipes.get(name)
        if kind == "profile" and name == self.profile.get("id"):
            return self.profile
        return None


# --------------------------------------------------------------------------- values

_SETTINGS = {  # profile settings and the values drawn for them (abstract-v1's value first)
    "spacing": [1.0, 0.75, 1.25],
    "reach": [1.5, 1.0, 1.25, 2.0],
    "reference_reach": [1.5, 1.0],
    "reference_time": [1.0, 2.0],
    "rho_conf": [0.25, 0.0, 0.12, 0.4, 1.0],
    "clearance": [0.1, 0.0, 0.3],
    "role_target_offset": [0.12, 0.0, 0.3],
    "retreat_fraction": [0.25, 0.0, 1.0],
    "speed": [1.0, 0.5, 2.0],
    "joint_speed": [1.0, 0.5, 2.0],
    "payload": [10.0, 10.0, 2.0],
}
_SWITCHES = ("motion_planning", "trajectory_conflicts")  # S-RULE-VARIANTS, profile side


def _durations(draw: Any) -> dict[str, int]:
    return {k: draw(st.integers(1, 3)) for k in ("pick", "handoff", "deliver")}


@st.composite
def _variant(draw: Any) -> Json:
    """A named profile variant: one to three overridden settings or switches (PR-VARIANT)."""
    keys = draw(st.lists(st.sampled_from(sorted(_SETTINGS) + list(_SWITCHES) + ["durations"]),
                         min_size=1, max_size=3, unique=True))
    out: Json = {}
    for key in keys:
        if key in _SWITCHES:
            out[key] = draw(st.booleans())
        elif key == "durations":
            out[key] = _durations(draw)
        else:
            out[key] = draw(st.sampled_from(_SETTINGS[key]))
    return out


@st.composite
def profiles(draw: Any) -> Json:
    ir: Json = {"ir_version": IR, "kind": "profile", "id": "gen-profile"}
    for key, values in _SETTINGS.items():
        ir[key] = draw(st.sampled_from(values))
    ir["robot_model"] = "generic_ur"
    ir["tools"] = ["gripper"]
    ir["durations"] = _durations(draw)
    for key in _SWITCHES:
        ir[key] = draw(st.booleans())
    names = draw(st.lists(st.sampled_from(["v-a", "v-b", "v-c"]), max_size=3, unique=True))
    ir["variants"] = {n: draw(_variant()) for n in names}
    return ir


@st.composite
def grids(draw: Any) -> Json:
    return {"rows": draw(st.integers(1, 5)), "cols": draw(st.integers(2, 6)),
            "topology": draw(st.sampled_from(TOPOLOGIES)), "radius": draw(st.integers(1, 2))}


@st.composite
def scenarios(draw: Any, grid: Json, recipe_ids: list[str], resources: list[str], variants: list[str]) -> Json:
    batch = draw(st.booleans())
    lo = draw(st.sampled_from([0.0, 0.5, 1.0]))
    ir: Json = {
        "ir_version": IR, "kind": "scenario", "id": "gen-scenario", "family": "generated", "level": "any",
        "grid": grid,
        "recipes": recipe_ids,
        "profile": {"id": "gen-profile", "variant": draw(st.one_of(st.none(), st.sampled_from(variants)))
                    if variants else None},
        "release": {"interval": draw(st.integers(1, 10)), "wip_cap": draw(st.integers(1, 6))},
        "evaluation": ({"mode": "batch", "batch_size": draw(st.integers(1, 5)), "timeout": draw(st.integers(20, 120))}
                       if batch else {"mode": "continuing", "horizon": draw(st.integers(20, 120))}),
        "shelves": {"capacity": draw(st.integers(1, 6)), "replenish_interval": draw(st.integers(1, 20)),
                    "extra_access_probability": draw(st.sampled_from([0.0, 0.3, 1.0]))},
        "coordination": {"support_timeout": draw(st.integers(0, 5)), "switch_lock": draw(st.integers(0, 3)),
                         "support_visible": draw(st.booleans()), "bilateral_handoff": True},
        "products": {"mass": [lo, lo + draw(st.sampled_from([0.0, 0.5, 0.5, 1.5, 1.5, 12.0]))],
                     "due_slack": draw(st.sampled_from([0.5, 1.0, 2.2, 5.0])),
                     "due_slack_jitter": draw(st.sampled_from([0.0, 0.5, 2.0]))},
        # S-RESOURCES: override some recipe resources (0 = none available, 1 = exclusive, 2..3 = finite)
        "resources": {r: draw(st.integers(0, 3)) for r in resources if draw(st.booleans())},
        "suite": {"official": False, "prefix": "gen", "generation_seed_base": draw(st.integers(0, 10**6)),
                  "execution_seed_base": draw(st.integers(0, 10**6))},
    }
    return ir


# --------------------------------------------------------------------------- DSL canonical form


def dsl_form(ir: Json) -> tuple[str, Json]:
    """The canonical DSL text of ``ir`` and the IR the DSL builds from it (F-DSL)."""
    text = format_ir(ir)
    _source, built = compile_text(text, f"<{ir['kind']} {ir.get('id')}>")
    if built.ir is None or any(d.severity == "error" for d in built.diagnostics):
        raise AssertionError(f"fmt produced text the DSL rejects: {[d.render(text) for d in built.diagnostics]}\n{text}")
    return text, built.ir


def bundle_of(recipes: list[Json], profile: Json, scenario: Json) -> Bundle:
    """A bundle of given documents (in the DSL's canonical form), without its instance."""
    texts: dict[str, str] = {}
    canonical: dict[str, Json] = {}
    for r in recipes:
        texts[f"recipe:{r['id']}"], canonical[r["id"]] = dsl_form(r)
    texts["profile"], profile = dsl_form(profile)
    texts["scenario"], scenario = dsl_form(scenario)
    return Bundle(canonical, profile, scenario, texts)


@st.composite
def raw_bundles(draw: Any) -> Bundle:
    """A bundle as drawn, before the validator's filter (its instance is not made yet)."""
    grid = draw(grids())
    k = min(4, grid_k_topo(grid["rows"], grid["cols"], grid["topology"], grid["radius"]))
    # on a `line` grid of several rows, inputs drawn from different rows never meet (AG454): mostly one raw token
    max_raw = 1 if grid["topology"] == "line" and grid["rows"] > 1 and draw(st.integers(0, 3)) else min(3, k)
    n = draw(st.integers(1, 3))
    drawn = [draw(recipes(max_raw=max_raw, max_ops=4, k_max=k)) for _ in range(n)]
    by_id: dict[str, Json] = {}
    for i, r in enumerate(drawn):
        r["id"] = f"r{i}-{r['id']}" if r["id"] else f"r{i}"
        by_id[r["id"]] = r
    profile = draw(profiles())
    resources = sorted({name for r in drawn for name in r.get("resources", {})})
    scenario = draw(scenarios(grid, list(by_id), resources, sorted(profile["variants"])))
    return bundle_of(drawn, profile, scenario)


def bundle_errors(bundle: Bundle) -> list[str]:
    """The errors ``agspec validate`` reports on the bundle's documents (schema, then semantics with
    the realizability checks), as "code pointer: message"; empty when the scenario is valid."""
    validate = semantic_validator()
    docs = _Docs(bundle.recipes, bundle.profile)
    out: list[str] = []
    for ir in [*bundle.recipes.values(), bundle.profile, bundle.scenario]:
        issues = validate_schema(ir)
        if not any(i.severity == "error" for i in issues):
            issues = list(issues) + list(validate(ir, docs))
        out += [f"{ir['kind']} {ir['id']}: {i.code} {i.pointer}: {i.message}" for i in issues if i.severity == "error"]
    return out


def realize(bundle: Bundle, index: int) -> Bundle:
    """The bundle with its instance at suite ``index`` (S-SEEDS) and the instance errors (AG5xx)."""
    inst = make_instance(bundle.scenario, bundle.recipes, bundle.profile, index=index)
    problems = [f"instance: {i.code} {i.pointer}: {i.message}"
                for i in [*validate_schema(inst), *validate_instance(inst)] if i.severity == "error"]
    return Bundle(bundle.recipes, bundle.profile, bundle.scenario, bundle.texts, inst, tuple(problems))


@st.composite
def bundles(draw: Any) -> Bundle:
    """A valid bundle with its instance: drawn, kept only when the validator reports no error.

    A realization the instance checks reject, of a scenario the validator accepted, is not filtered
    away: it would be a validator (or generator) bug, so it is kept in ``problems`` for the self-check.
    """
    bundle = draw(raw_bundles())
    assume(not bundle_errors(bundle))
    return realize(bundle, draw(st.integers(0, 3)))
