#!/usr/bin/env python3
"""Regenerate the small instances the mutant workloads run on (tests/mutants/instances/*.json).

Each instance is built from DSL text with the same pipeline as ``agspec instance``
(agspec.dsl -> IR -> agspec.ir.instance.make_instance).  They are tiny on purpose: a seeded mutant
must be triggered within a few ticks so that the mutation test stays fast.  Several mutants need
shapes the official catalogue lacks (an ``after`` entry that material flow does not imply, an XOR
group, a finite resource of capacity 2, an optional helper two cells away).

    python tests/mutants/make_instances.py          # rewrite the files
    python tests/mutants/make_instances.py --check  # fail if a file is stale
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from agspec.dsl.build import compile_text
from agspec.ir.instance import make_instance
from agspec.ir.schemas import validate_schema
from agspec.ir.validate import errors, validate_instance

OUT = Path(__file__).resolve().parent / "instances"

FLAT = """
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
"""

MOTION = FLAT.replace("flat-v1", "motion-v1").replace("motion_planning off", "motion_planning on").replace(
    "joint_speed 1.0", "joint_speed 10.0").replace(
    "logic-only profile: no motion time, no geometric conflicts, unit logistics durations",
    "motion time on (G-DURATION) with fast joints: approaches of 1-2 ticks, no geometric conflicts")

RECIPES = {
    "solo": """
recipe solo {
    raw A
    operation inspect {
        type inspect
        inputs A -> FINAL
        team 1
        roles inspector(A)
        duration 1
    }
}
""",
    "pair": """
recipe pair {
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
    "gate": """
recipe gate {
    doc "`second` waits for `first` although it does not consume its output (RC-PRECEDENCE)"
    raw A, B
    operation first {
        type prepare
        inputs A -> PA
        team 1
        roles operator_a(A)
        duration 5
    }
    operation second {
        type prepare
        after first
        inputs B -> PB
        team 1
        roles operator_b(B)
        duration 2
    }
    operation join {
        type assemble
        after first, second
        inputs PA, PB -> FINAL
        team 2
        roles holder_PA(PA), holder_PB(PB)
        duration 2
    }
}
""",
    "xor_route": """
recipe xor_route {
    raw A, B
    operation glue {
        type glue
        inputs A -> Q
        team 1
        roles operator(A)
        duration 2
    }
    operation weld {
        type weld
        inputs B -> Q
        team 1
        roles operator(B)
        duration 3
    }
    operation finish {
        type finish
        after route
        inputs Q -> FINAL
        team 1
        roles operator(Q)
        duration 1
    }
    xor route = glue | weld
}
""",
    "bench": """
recipe bench {
    raw A
    resource bench capacity 2
    operation work {
        type work
        inputs A -> FINAL
        team 1
        roles operator(A)
        uses bench
        duration 4
    }
}
""",
    "helped": """
recipe helped {
    raw A
    operation insert {
        type assemble
        inputs A -> FINAL
        team 1..3
        roles holder(A), helper, stabilizer
        duration 3
    }
}
""",
    "duo": """
recipe duo {
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
}


def scenario_text(name: str, grid: str, recipe: str, profile: str, *, release: int = 50, wip: int = 1,
                  horizon: int = 40, shelves: str = "capacity 6 replenish 100 extra_access 0") -> str:
    return f"""
scenario {name} {{
    family mutants
    level unit
    grid {grid}
    recipes {recipe}
    profile {profile}
    release every {release}
    wip {wip}
    evaluation continuing horizon {horizon}
    shelves {shelves}
    coordination support_timeout 3 switch_lock 1 support_visible on bilateral_handoff on
    products mass 0.5..2.0 due_slack 2.2 jitter 0.5
}}
"""


INSTANCES: dict[str, dict[str, Any]] = {
    # deliveries within a few ticks (delivery before completion, WIP drift)
    "solo-1x2-flat": dict(grid="1 x 2", recipe="solo", profile=FLAT, release=4, wip=2, horizon=40),
    # a 2-robot operation lasting 3 ticks (role reassignment)
    "pair-1x2-flat": dict(grid="1 x 2", recipe="pair", profile=FLAT),
    # precedence without material flow (predecessor ignored)
    "gate-2x2-flat": dict(grid="2 x 2", recipe="gate", profile=FLAT, shelves="capacity 6 replenish 100 extra_access 1"),
    # an XOR group (sibling not closed)
    "xor-2x2-flat": dict(grid="2 x 2", recipe="xor_route", profile=FLAT),
    # a finite resource of capacity 2 wanted by three products at once (resource over capacity)
    "bench-3x2-flat": dict(grid="3 x 2", recipe="bench", profile=FLAT, release=1, wip=3, horizon=30,
                           shelves="capacity 6 replenish 100 extra_access 1"),
    # helpers above and below a holder in the middle row: not adjacent to each other
    # (every product is sourced from shelf row 1, so the middle-row robot holds)
    "helped-3x2-flat": dict(grid="3 x 2", recipe="helped", profile=FLAT, release=1, wip=3, horizon=30,
                            source_row=1),
    # a holder that may work alone or with a helper (support records that wait for a partner)
    "duo-1x2-flat": dict(grid="1 x 2", recipe="duo", profile=FLAT),
    # a von Neumann grid: no diagonal handoff, receive or neighbour (topology ignored)
    "duo-2x2-vn-flat": dict(grid="2 x 2 von_neumann radius 1", recipe="duo", profile=FLAT),
    # motion time on: approaches of 1, 2 and 5 ticks make ceil and round differ (duration rounding)
    "solo-2x3-motion": dict(grid="2 x 3", recipe="solo", profile=MOTION, release=3, wip=3, horizon=60,
                            shelves="capacity 6 replenish 5 extra_access 1"),
}


def _compile(text: str, what: str) -> dict[str, Any]:
    _source, built = compile_text(text, what)
    problems = [d for d in built.diagnostics if getattr(d, "severity", "error") == "error"]
    if problems or built.ir is None:
        raise SystemExit(f"{what}: DSL errors: {problems}")
    return built.ir


def build(name: str, spec: dict[str, Any]) -> dict[str, Any]:
    spec = dict(spec)
    source_row = spec.pop("source_row", None)
    profile = _compile(spec.pop("profile"), f"<profile of {name}>")
    recipe = _compile(RECIPES[spec["recipe"]], f"<recipe {spec['recipe']}>")
    scenario = _compile(scenario_text(f"mut-{name}", profile=profile["id"], **spec), f"<scenario {name}>")
    inst = make_instance(scenario, {recipe["id"]: recipe}, profile, generation_seed=7, execution_seed=0)
    inst["id"] = f"mut-{name}"
    if source_row is not None:  # pinned by hand, within I-SOURCE-ROWS
        for product in inst["realization"]["products"]:
            product["source_rows"] = {tok: source_row for tok in product["source_rows"]}
    problems = errors(validate_schema(inst)) or errors(validate_instance(inst))
    if problems:
        shown = "; ".join(f"{i.code} {i.pointer}: {i.message}" for i in problems)
        raise SystemExit(f"{name}: invalid instance: {shown}")
    return inst


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true")
    args = parser.parse_args(argv)
    OUT.mkdir(exist_ok=True)
    stale = []
    for name, spec in INSTANCES.items():
        text = json.dumps(build(name, spec), indent=1, ensure_ascii=False) + "\n"
        path = OUT / f"{name}.json"
        if args.check:
            if not path.is_file() or path.read_text(encoding="utf-8") != text:
                stale.append(path.name)
        else:
            path.write_text(text, encoding="utf-8")
    if stale:
        print("stale:", ", ".join(stale), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
