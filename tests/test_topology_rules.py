"""Every user of a locality relation takes it from the scenario's grid (D-TOPOLOGY, RES-RADIUS,
RES-TOPOLOGY-LINE): the interpreter's handoffs, masks and observation neighbours, the invariant
checker, the reference controllers (RES-STAGING-TOPOLOGY) and the PettingZoo encoding.

The suite cases of conformance/cases/topology.yaml show the same on the wire; the generated
scenarios of tests/test_selfcheck.py check it on every topology and radius.
"""

from __future__ import annotations

import copy
import json
from pathlib import Path

import pytest

from agspec.catalogue import load_instance
from agspec.invariants.context import Context
from agspec.conform.lockstep.actions import ControllerPolicy
from agspec.controllers import make_controller
from agspec.controllers.base import grid_key, routes
from agspec.dsl.build import compile_text
from agspec.evaluate import run_episode
from agspec.formats.actions import DIRECTION_NAMES, HANDOFF0, RECEIVE0
from agspec.interp import rules
from agspec.interp.model import Model
from agspec.interp.state import cell_id
from agspec.interp.tick import Simulator
from agspec.ir import topology
from agspec.ir.instance import make_instance
from agspec.ir.validate import validate_instance
from agspec.resources import catalogue_dir

ROOT = Path(__file__).resolve().parents[1]
GRIDS = [(t, r) for t in topology.TOPOLOGIES for r in (1, 2)]


def _ir(path: str) -> dict:
    _, built = compile_text((catalogue_dir() / path).read_text(encoding="utf-8"))
    return built.ir


def _instance(rows: int, cols: int, topo: str, radius: int, recipe: str = "solo_inspection", **products) -> dict:
    scenario = _ir("scenarios/flow-easy.ag")
    scenario.update(id="topo", recipes=[recipe], grid={"rows": rows, "cols": cols, "topology": topo, "radius": radius})
    scenario["products"].update(products)
    return make_instance(scenario, {recipe: _ir(f"recipes/{recipe}.ag")}, _ir("profiles/abstract-v1.ag"), index=0)


# --------------------------------------------------------------------------- one source of truth


@pytest.mark.parametrize("topo,radius", GRIDS)
def test_interpreter_and_checker_take_the_relations_from_ir_topology(topo, radius):  # D-TOPOLOGY
    inst = _instance(3, 4, topo, radius)
    model, ctx = Model.from_instance(inst), Context.from_instance(inst)
    handoff = topology.direction_slots(topology.handoff_graph(3, 4, topo, radius))
    obs = topology.direction_slots(topology.observation_graph(3, 4, topo, radius))
    manip = topology.manipulation_graph(3, 4, topo, radius)
    for c in model.cells:
        assert [(d, n) for d, _, n in model.handoff_slots[c]] == list(handoff[c])
        assert [(d, n) for d, _, n in model.observation_slots[c]] == list(obs[c])
        assert model.neighbours[c] == tuple(sorted(manip[c]))
        assert ctx.handoff_neighbours(cell_id(c)) == [(d, cell_id(n)) for d, n in handoff[c]]
        assert ctx.observation_neighbours(cell_id(c)) == [(d, cell_id(n)) for d, n in obs[c]]
        assert ctx.manip_neighbours(cell_id(c)) == [cell_id(n) for n in model.neighbours[c]]


@pytest.mark.parametrize("topo,radius,names", [
    ("moore", 1, ["N", "NE", "E", "SE", "S", "SW", "W", "NW"]),
    ("moore", 2, ["N", "NE", "E", "SE", "S", "SW", "W", "NW"]),
    ("von_neumann", 1, ["N", "E", "S", "W"]),
    ("von_neumann", 2, ["N", "NE", "E", "SE", "S", "SW", "W", "NW"]),  # diagonals: |di| + |dj| = 2
    ("line", 1, ["E", "W"]),
    ("line", 2, ["E", "W"]),  # RES-RADIUS: the cell two away has no direction slot
])
def test_direction_slots_of_an_interior_robot(topo, radius, names):  # RES-RADIUS, RES-TOPOLOGY-LINE
    sim = Simulator(_instance(3, 4, topo, radius))
    obs = sim.observe("1,1")
    assert [n["dir"] for n in obs["neighbours"]] == names  # O-OBSERVATION
    legal = {DIRECTION_NAMES[a - RECEIVE0] for a in range(RECEIVE0, RECEIVE0 + 8) if obs["mask"][a]}
    assert legal == set(names)  # O-MASK rule 5: an empty robot may receive from G_handoff neighbours only


def test_a_handoff_outside_g_handoff_never_starts_even_unmasked():  # R-HANDOFF clause 1
    """The rule itself refuses the pair, not only the mask: start_handoffs called with a matching
    cross-row pair on a line grid (as a simulator that skipped the mask would) starts nothing."""
    inst = json.loads((ROOT / "conformance/instances/topo-line-2x3-flat.json").read_text(encoding="utf-8"))
    sim = Simulator(inst)
    sim.reset(0)
    sim.step({"0,0": 2})  # pick A
    assert sim.state.robots[(0, 0)].holding == (0, "A")
    events: list = []
    s = DIRECTION_NAMES.index("S")
    rules.start_handoffs(sim.state, sim.model, {(0, 0): s}, {(1, 0): DIRECTION_NAMES.index("N")}, events)
    assert events == [] and sim.state.activities == []
    rules.start_handoffs(sim.state, sim.model, {(0, 0): DIRECTION_NAMES.index("E")}, {(0, 1): DIRECTION_NAMES.index("W")},
                         events)
    assert [e["type"] for e in events] == ["handoff_started"]


def test_the_line_reproduction_hands_nothing_across_rows():  # D-TOPOLOGY, INV-LOCALITY
    inst = _instance(3, 6, "line", 1, recipe="flow_serial_3")
    sim = Simulator(inst)
    ctl = make_controller("random", 0)
    ctl.reset(0)
    handoffs = 0
    for _ in range(100):
        for ev in sim.step(ctl.act(sim.observe())).events:
            if ev["type"] == "handoff_started":
                handoffs += 1
                assert ev["sender"].split(",")[0] == ev["receiver"].split(",")[0], ev
    assert handoffs > 0  # not vacuous: items did move, along rows


# --------------------------------------------------------------------------- controllers


def test_routes_on_moore_radius_1_are_the_originals():  # C-STAGING, RES-STAGING
    r = routes(grid_key(None, 5, 6))
    cells = [(i, j) for i in range(5) for j in range(6)]
    assert all(r.distance(a, b) == max(abs(a[0] - b[0]), abs(a[1] - b[1])) for a in cells for b in cells)
    # the spec's examples: anchor (r, N-3) with r >= 1, and r = 0
    assert r.staging_set((2, 3)) == ((2, 3), (1, 2), (1, 3), (2, 2))
    assert r.staging_set((0, 3)) == ((0, 3), (0, 2), (1, 2), (1, 3))


def test_routes_follow_the_topology():  # RES-STAGING-TOPOLOGY
    vn = routes(grid_key({"rows": 4, "cols": 5, "topology": "von_neumann", "radius": 1}, 4, 5))
    assert vn.distance((0, 0), (1, 1)) == 2  # Manhattan: no diagonal handoff
    line = routes(grid_key({"rows": 3, "cols": 6, "topology": "line", "radius": 1}, 3, 6))
    assert line.distance((0, 0), (1, 0)) is None  # rows are separate lines
    # product 1's anchor (1, 3) is unreachable from row 2: the staging set is anchored in row 2
    target = line.item_target(1, "A", False, (2, 0))
    assert target[0] == 2 and line.distance((2, 0), target) is not None
    assert line.item_target(1, "A", True, (2, 0)) == (2, 5)  # a terminal item: its row's output cell


def test_structured_references_deliver_on_a_von_neumann_grid():  # RES-STAGING-TOPOLOGY, C-GREEDY
    """pair_assembly on a 3 x 4 von Neumann grid through `agspec run`'s path: routed on G_handoff the
    structured references deliver; routed on the Moore graph (the old behaviour) items wait for
    diagonal moves no legal handoff makes."""
    inst = _instance(3, 4, "von_neumann", 1, recipe="pair_assembly")
    for name in ("greedy", "parallel-aware", "centralized"):
        assert run_episode(inst, name, horizon=150).metrics["delivered"] >= 3, name
    sim = Simulator(inst)
    moore = make_controller("greedy")  # no grid: the v1 default topology
    moore.reset(0)
    while sim.t < 150:
        sim.step(moore.act(sim.observe()))
    assert sim.final_metrics()["delivered"] < 3


def test_the_conformance_driver_gives_controllers_the_grid():  # C-INFORMATION, RES-STAGING-TOPOLOGY
    """ControllerPolicy (every lockstep run) plans on the instance's grid: its actions are those of the
    controller made with that grid, and differ from a Moore-routed one on this instance."""
    inst = _instance(3, 4, "von_neumann", 1, recipe="pair_assembly")
    grid = inst["scenario"]["grid"]
    policy = ControllerPolicy("greedy", 0)
    policy.reset(grid)
    same, moore = make_controller("greedy", 0, grid=grid), make_controller("greedy", 0)
    sim = Simulator(inst)
    differs = False
    for t in range(150):
        obs = sim.observe()
        chosen = policy.act(t, obs, sim.agents())
        assert chosen == same.act(obs)
        differs |= chosen != moore.act(obs)
        sim.step(chosen)
    assert differs


# --------------------------------------------------------------------------- adapters


def test_pettingzoo_direction_slots_stay_eight_and_follow_the_topology():  # A-OBS-VECTOR, O-MASK
    pytest.importorskip("pettingzoo")
    from agspec.marl.encoding import NEIGHBOUR_DIM, SELF_DIM
    from agspec.pettingzoo import parallel_env

    env = parallel_env(_instance(3, 4, "von_neumann", 1))
    obs, _ = env.reset()
    vec, mask = obs["1,1"]["observation"], obs["1,1"]["action_mask"]
    assert mask.shape == (114,)
    for d, name in enumerate(DIRECTION_NAMES):
        present = vec[SELF_DIM + d * NEIGHBOUR_DIM]
        if name in ("NE", "SE", "SW", "NW"):
            assert present == 0 and mask[RECEIVE0 + d] == 0 and mask[HANDOFF0 + d] == 0
        else:
            assert present == 1 and mask[RECEIVE0 + d] == 1


# --------------------------------------------------------------------------- realization


def test_slack_range_below_one_is_a_valid_realization():  # RES-SLACK-BELOW-ONE, S-PRODUCT-DRAW
    inst = _instance(2, 3, "moore", 1, due_slack=0.5, due_slack_jitter=0.0)
    slacks = [p["slack"] for p in inst["realization"]["products"]]
    assert all(0.5 <= s <= 1.0 for s in slacks) and len(set(slacks)) > 1  # uniform(1, 0.5) lies in [0.5, 1]
    assert [i for i in validate_instance(inst) if i.severity == "error"] == []
    bad = copy.deepcopy(inst)
    bad["realization"]["products"][0]["slack"] = 1.2
    assert any(i.code == "AG513" and i.pointer == "/realization/products/0/slack" for i in validate_instance(bad))
