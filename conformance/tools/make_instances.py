#!/usr/bin/env python3
"""Regenerate the hand-designed instances of the conformance suite (conformance/instances/*.json).

Every instance is built from small DSL texts (recipes, profiles, scenarios below) with the same
pipeline as ``agspec instance``: ``agspec.dsl`` -> IR -> ``agspec.ir.instance.make_instance``.
A few realization fields are then pinned by hand (source rows, shelf access, initial stock) so
that each conformance case can state its expectations from the spec alone; every pinned value
stays within what the instance validator accepts (I-SOURCE-ROWS, I-SHELF-ACCESS; a non-pattern
initial stock is only warning AG515, "fine for a hand-made test instance").

    python conformance/tools/make_instances.py          # rewrite conformance/instances/*.json
    python conformance/tools/make_instances.py --check  # fail if a file is missing or stale

Profiles used by the suite:

* ``abstract-v1`` — the official profile (catalogue), for the geometry cases;
* ``paper-v1``    — abstract-v1 with ``role_target_offset 0``: the paper's "no offset" geometry
                    cases (G-PAPER-CASES, G-WORKED-VALUES row 1);
* ``flat-v1``     — motion planning and trajectory conflicts off, ``rho_conf`` and clearance 0,
                    logistics durations 1: every activity takes exactly its process duration
                    (G-DURATION: D = max(1, P)) and nothing conflicts geometrically, so logic
                    cases are checkable by hand.
"""

from __future__ import annotations

import argparse
import copy
import json
import sys
from pathlib import Path
from typing import Any, Callable

from agspec.dsl.build import compile_text
from agspec.ir.instance import make_instance
from agspec.ir.schemas import validate_schema
from agspec.ir.validate import errors, validate_instance
from agspec.resources import catalogue_dir

HERE = Path(__file__).resolve().parent
OUT = HERE.parent / "instances"


# --------------------------------------------------------------------------- DSL texts

PROFILES = {
    "paper-v1": """
profile paper-v1 {
    doc "abstract-v1 without role-target offsets (the paper's midpoint case, G-WORKED-VALUES row 1)"
    spacing 1.0
    reach 1.5
    reference_reach 1.5
    reference_time 1.0
    rho_conf 0.25
    clearance 0.1
    role_target_offset 0.0
    retreat_fraction 0.25
    speed 1.0
    joint_speed 1.0
    payload 10.0
    robot_model generic_ur
    tools gripper
    durations pick 2 handoff 1 deliver 2
    motion_planning on
    trajectory_conflicts on
}
""",
    "flat-v1": """
profile flat-v1 {
    doc "logic-only profile: no motion time, no geometric conflicts, unit logistics durations"
    spacing 1.0
    reach 1.5
    reference_reach 1.5
    reference_time 1.0
    rho_conf 0.0
    clearance 0.0
    role_target_offset 0.12
    retreat_fraction 0.25
    speed 1.0
    joint_speed 1.0
    payload 10.0
    robot_model generic_ur
    tools gripper
    durations pick 1 handoff 1 deliver 1
    motion_planning off
    trajectory_conflicts off
}
""",
}



def derived(name: str, doc: str, **changes: str) -> str:
    """A profile that is the official abstract-v1 (catalogue text, without its named variants) with
    some fields changed: ``changes`` maps a field to the text after its name."""
    import re

    text = (catalogue_dir() / "profiles" / "abstract-v1.ag").read_text(encoding="utf-8")
    body = text[text.index("profile abstract-v1 {"):]
    body = "\n".join(line for line in body.splitlines() if not line.strip().startswith("variant "))
    body = body.replace("profile abstract-v1 {", f"profile {name} {{\n    doc \"{doc}\"", 1)
    for key, value in changes.items():
        body, n = re.subn(rf"^(\s*){key} .*$", rf"\g<1>{key} {value}", body, count=1, flags=re.M)
        if n != 1:
            raise SystemExit(f"profile {name}: abstract-v1 has no field {key}")
    return body + "\n"


# Profiles that differ from abstract-v1 in ONE value: a simulator that hard-codes the official value
# fails the cases on them (F-CONFORM-COVERAGE, the variant space).
PROFILES.update({
    "notraj-v1": derived("notraj-v1", "abstract-v1 with trajectory conflicts off (motion planning on)",
                         trajectory_conflicts="off"),
    "nomotion-v1": derived("nomotion-v1", "abstract-v1 with motion planning off (trajectory conflicts on)",
                           motion_planning="off"),
    "reach-v1": derived("reach-v1", "abstract-v1 with reach 1.25", reach="1.25"),
    "speed-v1": derived("speed-v1", "abstract-v1 with Cartesian speed 0.0625", speed="0.0625"),
    "joint-v1": derived("joint-v1", "abstract-v1 with joint speed 2.0", joint_speed="2.0"),
    "retreat-v1": derived("retreat-v1", "abstract-v1 with retreat fraction 1.0", retreat_fraction="1.0"),
    "clearance-v1": derived("clearance-v1", "abstract-v1 with clearance 0.25", clearance="0.25"),
    "handoff2-v1": derived("handoff2-v1", "abstract-v1 with handoff process duration 2",
                           durations="pick 2 handoff 2 deliver 2"),
})

RECIPES = {
    "pair": """
recipe pair {
    doc "two-holder join with the paper's d = 3 (G-PAPER-CASES 1)"
    raw A, B
    operation join {
        type assemble
        inputs A, B -> FINAL
        team 2
        roles holder_A(A), holder_B(B)
        duration 3
    }
}
""",
    "reach_helper": """
recipe reach_helper {
    doc "one holder, an optional helper: the helper's target is the holder's base"
    raw A
    operation inspect {
        type inspect
        inputs A -> FINAL
        team 1..2
        roles holder(A), helper
        duration 2
    }
}
""",
    "branch": """
recipe branch {
    doc "productive concurrency: two independent unary branches and a join (C_max 11 serial vs 8 parallel)"
    raw A, B
    operation align_1 {
        type align
        inputs A -> P1
        team 1
        roles operator_1
        duration 3
    }
    operation align_2 {
        type align
        inputs B -> P2
        team 1
        roles operator_2
        duration 3
    }
    operation join {
        type assemble
        after align_1, align_2
        inputs P1, P2 -> FINAL
        team 2
        roles holder_P1(P1), holder_P2(P2)
        duration 2
    }
}
""",
    "insert4": """
recipe insert4 {
    doc "one holder plus one to three helpers (coalitions of 2, 3 and 4 robots)"
    raw A
    operation insert {
        type assemble
        inputs A -> FINAL
        team 2..4
        roles holder(A), inserter, stabilizer, inspector
        duration 4
    }
}
""",
    "solo": """
recipe solo {
    doc "one unary operation"
    raw A
    operation inspect {
        type inspect
        inputs A -> FINAL
        team 1
        roles inspector(A)
        duration 2
    }
}
""",
    "duo": """
recipe duo {
    doc "a unary or supported operation: lets one robot choose between a size-1 and a size-2 candidate"
    raw A
    operation fit {
        type fit
        inputs A -> FINAL
        team 1..2
        roles holder(A), helper
        duration 2
    }
}
""",
    "xor_route": """
recipe xor_route {
    doc "XOR group `route`: glue (A -> Q) or weld (B -> Q); finish (Q -> FINAL) runs after the group"
    raw A, B
    operation glue {
        type glue
        inputs A -> Q
        team 1
        roles operator
        duration 2
    }
    operation weld {
        type weld
        inputs B -> Q
        team 1
        roles operator
        duration 3
    }
    operation finish {
        type finish
        after route
        inputs Q -> FINAL
        team 1
        roles operator
        duration 1
    }
    xor route = glue | weld
}
""",
    "bench": """
recipe bench {
    doc "a unary operation that needs the finite resource `bench` (capacity 2)"
    raw A
    resource bench capacity 2
    operation work {
        type work
        inputs A -> FINAL
        team 1
        roles operator
        uses bench
        duration 3
    }
}
""",
}

RECIPES["twostep"] = """
recipe twostep {
    doc "two unary steps on one holder: prep (A -> P), then fin (P -> FINAL), one tick each"
    raw A
    operation prep {
        type prepare
        inputs A -> P
        team 1
        roles operator
        duration 1
    }
    operation fin {
        type finish
        after prep
        inputs P -> FINAL
        team 1
        roles operator
        duration 1
    }
}
"""

RECIPES["xor_press"] = """
recipe xor_press {
    doc "XOR group `route`: glue (A -> Q, needs the press) or weld (B -> Q); finish (Q -> FINAL) after the group"
    raw A, B
    resource press capacity 1
    operation glue {
        type glue
        inputs A -> Q
        team 1
        roles operator
        uses press
        duration 2
    }
    operation weld {
        type weld
        inputs B -> Q
        team 1
        roles operator
        duration 3
    }
    operation finish {
        type finish
        after route
        inputs Q -> FINAL
        team 1
        roles operator
        duration 1
    }
    xor route = glue | weld
}
"""

# Official recipes reused by some instances.
CATALOGUE_RECIPES = ("flow_serial_3",)


def scenario_text(
    name: str,
    *,
    grid: str,
    recipe: str,
    profile: str,
    variant: str | None = None,
    release: int = 50,
    wip: int = 1,
    evaluation: str = "continuing horizon 40",
    shelves: str = "capacity 6 replenish 100 extra_access 0",
    coordination: str = "support_timeout 3 switch_lock 1 support_visible on bilateral_handoff on",
    resources: str = "",
    products: str = "mass 0.5..2.0 due_slack 2.2 jitter 0.5",
) -> str:
    return f"""
scenario {name} {{
    family conformance
    level unit
    grid {grid}
    recipes {recipe}
    profile {profile}{f" variant {variant}" if variant else ""}
    release every {release}
    wip {wip}
    evaluation {evaluation}
    shelves {shelves}
    coordination {coordination}
    products {products}
    {resources}
}}
"""


# --------------------------------------------------------------------------- realization pins

Patch = Callable[[dict[str, Any]], None]


def source_rows(*rows: dict[str, int]) -> Patch:
    """Pin the source rows of products 0, 1, ... (the last entry repeats for later products)."""

    def patch(inst: dict[str, Any]) -> None:
        for k, product in enumerate(inst["realization"]["products"]):
            product["source_rows"] = dict(rows[min(k, len(rows) - 1)])

    return patch


def shelf_access(access: dict[int, list[int]]) -> Patch:
    def patch(inst: dict[str, Any]) -> None:
        for entry in inst["realization"]["shelf_access"]:
            if entry["shelf_row"] in access:
                entry["robot_rows"] = list(access[entry["shelf_row"]])

    return patch


def stock(row: int, token: str, units: int) -> Patch:
    def patch(inst: dict[str, Any]) -> None:
        inst["realization"]["shelves"][row]["stock"][token] = units

    return patch


# --------------------------------------------------------------------------- the instances

INSTANCES: dict[str, dict[str, Any]] = {
    # G-PAPER-CASES 1: horizontal pair meeting at the midpoint, no role offset.
    "pair-1x2-paper": dict(grid="1 x 2", recipe="pair", profile="paper-v1"),
    # The same pair with the official 0.12 role offsets (G-WORKED-VALUES row 2).
    "pair-1x2-official": dict(grid="1 x 2", recipe="pair", profile="abstract-v1"),
    # G-PAPER-CASES 2: a helper two cells away (Moore radius 2) targets a point at distance 2.000.
    "reach-1x3-paper": dict(grid="1 x 3 moore radius 2", recipe="reach_helper", profile="paper-v1"),
    # G-PAPER-CASES 3: crossing vs separated transfers on a 2x2 block.
    "pair-2x2-official": dict(grid="2 x 2", recipe="pair", profile="abstract-v1",
                              patches=[shelf_access({0: [0, 1], 1: [0, 1]})]),
    # Productive concurrency (C_max 11 serial vs 8 parallel): batch of one product.
    "branch-2x2-flat": dict(grid="2 x 2", recipe="branch", profile="flat-v1", evaluation="batch 1 timeout 30"),
    # Coalitions of 2, 3 and 4 robots around one holder.
    "insert4-2x2-flat": dict(grid="2 x 2", recipe="insert4", profile="flat-v1"),
    # Serial recipe end to end on a line of three robots.
    "serial3-1x3-flat": dict(grid="1 x 3", recipe="flow_serial_3", profile="flat-v1"),
    # WIP cap: one product at a time, an opportunity every 2 ticks.
    "solo-1x2-wip1-flat": dict(grid="1 x 2", recipe="solo", profile="flat-v1", release=2, wip=1,
                               evaluation="continuing horizon 12"),
    # Raw-material availability and replenishment: capacity 2, row 0 starts with 1 unit.
    "solo-1x2-stock-flat": dict(grid="1 x 2", recipe="solo", profile="flat-v1", release=2, wip=3,
                                evaluation="continuing horizon 16", shelves="capacity 2 replenish 3 extra_access 0",
                                patches=[stock(0, "A", 1)]),
    # Two products whose A comes from the same shelf row (RES-PICK-TIE), both left robots have access.
    "solo-2x2-shared-official": dict(grid="2 x 2", recipe="solo", profile="abstract-v1", release=1, wip=2,
                                     evaluation="continuing horizon 20",
                                     patches=[source_rows({"A": 0}), shelf_access({0: [0, 1], 1: [0, 1]})]),
    # Switching and the switch lock (switch_lock 2 makes the lock bind, RES-SWITCH-LOCK-VACUOUS).
    "duo-1x2-lock2-flat": dict(grid="1 x 2", recipe="duo", profile="flat-v1",
                               coordination="support_timeout 3 switch_lock 2 support_visible on bilateral_handoff on"),
    # The official switch lock of 1 (vacuous after one epoch).
    "duo-1x2-flat": dict(grid="1 x 2", recipe="duo", profile="flat-v1"),
    # XOR group resolved at admission.
    "xor-2x2-flat": dict(grid="2 x 2", recipe="xor_route", profile="flat-v1"),
    # Finite resource bench (capacity 2) shared by three products.
    "bench-3x2-flat": dict(grid="3 x 2", recipe="bench", profile="flat-v1", release=1, wip=3,
                           evaluation="continuing horizon 20", patches=[
                               lambda inst: [p.__setitem__("source_rows", {"A": p["id"] % 3})
                                             for p in inst["realization"]["products"]]]),
    # The same with the scenario overriding bench to capacity 1 (exclusive, S-RESOURCES).
    "bench1-3x2-flat": dict(grid="3 x 2", recipe="bench", profile="flat-v1", release=1, wip=3,
                            evaluation="continuing horizon 20", resources="resource bench capacity 1", patches=[
                                lambda inst: [p.__setitem__("source_rows", {"A": p["id"] % 3})
                                              for p in inst["realization"]["products"]]]),
    # Tick order with geometry: a pick started at epoch t blocks an admission of the same epoch.
    "solo-2x2-official": dict(grid="2 x 2", recipe="solo", profile="abstract-v1", release=1, wip=2,
                              evaluation="continuing horizon 30",
                              patches=[source_rows({"A": 1}), shelf_access({0: [0, 1], 1: [0, 1]})]),

    # ---- the variant space (F-CONFORM-COVERAGE): each instance differs from the official
    # configuration in one value a simulator must read.
    # S-RULE-VARIANTS: each geometry switch off on its own.
    "pair-2x2-notraj": dict(grid="2 x 2", recipe="pair", profile="notraj-v1",
                            patches=[shelf_access({0: [0, 1], 1: [0, 1]})]),
    "pair-2x2-nomotion": dict(grid="2 x 2", recipe="pair", profile="nomotion-v1",
                              patches=[shelf_access({0: [0, 1], 1: [0, 1]})]),
    # PR-VARIANT: the conflict variants of abstract-v1 (rho_conf 0.12 / 0.40) and a larger clearance (0.25):
    # every product's A comes from shelf row 0, which both left robots can reach.
    **{f"twostep-2x2-{tag}": dict(grid="2 x 2", recipe="twostep", profile=profile, variant=variant, release=1, wip=2,
                                  evaluation="continuing horizon 30",
                                  patches=[source_rows({"A": 0}), shelf_access({0: [0, 1], 1: [0, 1]})])
       for tag, profile, variant in (("low", "abstract-v1", "conflict-low"), ("high", "abstract-v1", "conflict-high"),
                                     ("clearance", "clearance-v1", None))},
    # PR-VARIANT: the spacing variants (paper case 1 on a scaled line).
    "pair-1x2-s075": dict(grid="1 x 2", recipe="pair", profile="abstract-v1", variant="spacing-0.75"),
    "pair-1x2-s125": dict(grid="1 x 2", recipe="pair", profile="abstract-v1", variant="spacing-1.25"),
    # PR-ABSTRACT-V1: one robot parameter changed each.
    "duo-2x2-reach": dict(grid="2 x 2", recipe="duo", profile="reach-v1"),
    "solo-1x2-speed": dict(grid="1 x 2", recipe="solo", profile="speed-v1"),
    "solo-1x2-joint": dict(grid="1 x 2", recipe="solo", profile="joint-v1"),
    "solo-1x2-retreat": dict(grid="1 x 2", recipe="solo", profile="retreat-v1"),
    "pair-1x2-handoff2": dict(grid="1 x 2", recipe="pair", profile="handoff2-v1"),
    # S-COORDINATION: the cue hidden; a support timeout other than 3.
    "duo-1x2-hidden-flat": dict(grid="1 x 2", recipe="duo", profile="flat-v1",
                                coordination="support_timeout 3 switch_lock 1 support_visible off "
                                             "bilateral_handoff on"),
    "duo-1x2-timeout5-flat": dict(grid="1 x 2", recipe="duo", profile="flat-v1",
                                  coordination="support_timeout 5 switch_lock 1 support_visible on "
                                               "bilateral_handoff on"),
    # RC-RESOURCES / S-RESOURCES: a zero-capacity resource (scenario override of the recipe's 1) on one
    # XOR alternative; the other alternative keeps the recipe deliverable.
    "xor0-2x2-flat": dict(grid="2 x 2", recipe="xor_press", profile="flat-v1", resources="resource press capacity 0"),
    # S-EVALUATION: batch of two products, an opportunity every 2 ticks.
    "solo-1x2-batch2-flat": dict(grid="1 x 2", recipe="solo", profile="flat-v1", release=2, wip=2,
                                 evaluation="batch 2 timeout 20"),
    # D-TOPOLOGY: one holder (0,0 picks product 0's A from its own row) and helpers under each
    # topology and radius; the locality relations decide handoffs, masks, observations and coalitions.
    "topo-vn-2x2-flat": dict(grid="2 x 2 von_neumann radius 1", recipe="insert4", profile="flat-v1",
                             patches=[source_rows({"A": 0})]),
    "topo-vn-2x3-r2-flat": dict(grid="2 x 3 von_neumann radius 2", recipe="insert4", profile="flat-v1",
                                patches=[source_rows({"A": 0})]),
    "topo-line-2x3-flat": dict(grid="2 x 3 line radius 1", recipe="insert4", profile="flat-v1",
                               patches=[source_rows({"A": 0})]),
    "topo-line-1x4-r2-flat": dict(grid="1 x 4 line radius 2", recipe="insert4", profile="flat-v1"),
    "topo-line-2x3-r2-flat": dict(grid="2 x 3 line radius 2", recipe="insert4", profile="flat-v1",
                                  patches=[source_rows({"A": 0})]),
    "topo-moore-2x3-r2-flat": dict(grid="2 x 3 moore radius 2", recipe="insert4", profile="flat-v1",
                                   patches=[source_rows({"A": 0})]),
    # RES-SLACK-BELOW-ONE: due_slack + jitter < 1, so every slack lies in [0.5, 1] (uniform(1, 0.5)).
    "solo-1x2-slack-flat": dict(grid="1 x 2", recipe="solo", profile="flat-v1", release=4, wip=2,
                                evaluation="continuing horizon 12", products="mass 0.5..2.0 due_slack 0.5 jitter 0"),
}


# --------------------------------------------------------------------------- build


def _compile(text: str, what: str) -> dict[str, Any]:
    _source, built = compile_text(text, what)
    problems = [d for d in built.diagnostics if getattr(d, "severity", "error") == "error"]
    if problems or built.ir is None:
        raise SystemExit(f"{what}: DSL errors: {problems}")
    return built.ir


def _catalogue(kind: str, name: str) -> dict[str, Any]:
    path = catalogue_dir() / kind / f"{name}.ag"
    return _compile(path.read_text(encoding="utf-8"), str(path))


def profile_ir(name: str) -> dict[str, Any]:
    if name in PROFILES:
        return _compile(PROFILES[name], f"<profile {name}>")
    return _catalogue("profiles", name)


def recipe_ir(name: str) -> dict[str, Any]:
    if name in RECIPES:
        return _compile(RECIPES[name], f"<recipe {name}>")
    if name in CATALOGUE_RECIPES:
        return _catalogue("recipes", name)
    raise SystemExit(f"unknown recipe {name}")


def build(name: str, spec: dict[str, Any], generation_seed: int = 1) -> dict[str, Any]:
    spec = dict(spec)
    patches: list[Patch] = spec.pop("patches", [])
    scenario = _compile(scenario_text(f"conf-{name}", **spec), f"<scenario {name}>")
    recipe = recipe_ir(spec["recipe"])
    profile = profile_ir(spec["profile"])
    inst = make_instance(scenario, {recipe["id"]: recipe}, profile, generation_seed=generation_seed,
                         execution_seed=0)
    inst["id"] = f"conf-{name}"
    for patch in patches:
        patch(inst)
    problems = errors(validate_schema(inst)) or errors(validate_instance(inst))
    if problems:
        raise SystemExit(f"{name}: invalid instance: " + "; ".join(f"{i.code} {i.pointer}: {i.message}" for i in problems))
    return inst


def dumps(inst: dict[str, Any]) -> str:
    return json.dumps(inst, indent=1, ensure_ascii=False) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="only check that the files are up to date")
    ap.add_argument("names", nargs="*", help="instances to build (default: all)")
    args = ap.parse_args(argv)
    OUT.mkdir(parents=True, exist_ok=True)
    stale = []
    for name in args.names or sorted(INSTANCES):
        text = dumps(build(name, copy.deepcopy(INSTANCES[name])))
        path = OUT / f"{name}.json"
        if args.check:
            if not path.is_file() or path.read_text(encoding="utf-8") != text:
                stale.append(path.name)
            continue
        path.write_text(text, encoding="utf-8")
        print(f"wrote {path.relative_to(HERE.parent.parent)}")
    if stale:
        print("stale or missing: " + ", ".join(stale), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
