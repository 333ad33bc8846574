"""The points an implementation author had to guess, now decided in the spec: each test holds the
reference to one Resolution (or to the one definition of `expires_at`, R-SUPPORT-LIFECYCLE) and is
named after it.
"""

from __future__ import annotations

import json
import re
from functools import lru_cache

import pytest
from click.testing import CliRunner

from agspec.catalogue import load_instance
from agspec.cli.main import cli
from agspec.conform.impl.serve import Server
from agspec.controllers import make_controller
from agspec.formats.actions import OP0
from agspec.interp import geometry, rules
from agspec.interp.candidates import build_candidates
from agspec.interp.snapshot import global_state
from agspec.interp.state import Activity
from agspec.interp.tick import Simulator
from agspec.ir.fingerprint import fingerprint
from agspec.resources import conformance_dir
from trace_lies import reference_trace

INSTANCES = conformance_dir() / "instances"


def instance(name: str) -> dict:
    return json.loads((INSTANCES / f"{name}.json").read_text(encoding="utf-8"))


@lru_cache(maxsize=None)
def catalogue(scenario: str, controller: str, horizon: int) -> tuple:
    return tuple(reference_trace(load_instance(scenario, 0, None), controller, horizon))


def ticks(records) -> list[dict]:
    return [r for r in records if r.get("type") == "tick"]


def transitions(records):
    """(s_t, tick record) pairs."""
    states = [r for r in records if r.get("type") in ("header", "tick")]
    return list(zip(states, states[1:]))


# --------------------------------------------------------------------------- R-SUPPORT-LIFECYCLE


def test_r_support_lifecycle_expires_at_is_the_last_eligible_epoch():
    """Admitted at some epoch in created_at..expires_at; expired exactly in the transition into
    expires_at + 1 — never earlier, never later."""
    admitted_at_last = expired = 0
    for scenario in ("coalition-easy", "coalition-medium", "concurrency-medium"):
        for before, rec in transitions(catalogue(scenario, "random", 120)):
            open_before = before["state"]["proposals"]
            created = {e["candidate"]: rec["t"] for e in rec["events"] if e["type"] == "proposal_created"}
            for e in rec["events"]:
                cid = e.get("candidate")
                clock = open_before[cid] if cid in open_before else None
                if e["type"] == "admitted":
                    start = clock["created_at"] if clock else created[cid]
                    end = clock["expires_at"] if clock else created[cid] + 3
                    assert start <= rec["t"] <= end
                    admitted_at_last += rec["t"] == end
                if e["type"] == "admission_failed" and e["reason"] == "expired":
                    assert clock is not None and clock["expires_at"] == rec["t"]  # removed into expires_at + 1
                    expired += 1
            for cid, p in rec["state"]["proposals"].items():
                assert p["created_at"] <= rec["state"]["t"] <= p["expires_at"]  # never open past expires_at
    assert expired > 0 and admitted_at_last >= 0


# --------------------------------------------------------------------------- RES-EXPIRY-ORDER


def test_res_expiry_order_records_removed_in_one_step_follow_candidate_order():
    several = 0
    for scenario in ("coalition-easy", "coalition-hard", "geometry-matched-high", "concurrency-hard"):
        for rec in ticks(catalogue(scenario, "random", 150)):
            run: list[str] = []
            for e in rec["events"] + [{"type": "end"}]:
                if e["type"] in ("admission_failed", "proposal_abandoned"):
                    run.append(e["candidate"])
                    continue
                if len(run) > 1:
                    assert run == sorted(run)  # code-point order of the id strings
                    several += 1
                run = []
    assert several > 0  # the runs do remove several records in one step


# --------------------------------------------------------------------------- RES-RELEASE-LOST-REASON


def test_res_release_lost_reason_wip_cap_then_realization_then_raw_material():
    sim = Simulator(instance("solo-1x2-wip1-flat"))  # WIP cap 1, product 0 released at reset
    state, model = sim.state, sim.model
    for shelf in state.shelves:
        for token in shelf:
            shelf[token] = 0  # raw material is missing too
    state.t = model.release_interval
    reasons = []
    for fix in ("none", "deliver", "realize"):
        if fix == "deliver":  # WIP no longer binds; the realization is exhausted
            state.products[0].delivered, state.delivered = True, 1
            model.instance["realization"]["products"] = model.instance["realization"]["products"][:state.released]
        if fix == "realize":  # the realization has a next product: only raw material is missing
            model.instance["realization"]["products"] = instance("solo-1x2-wip1-flat")["realization"]["products"]
        events: list = []
        rules.release_product(state, model, events)
        reasons.append(events[0]["reason"])
        state.lost_releases -= 1
    assert reasons == ["wip_cap", "realization_exhausted", "raw_material"]


# --------------------------------------------------------------------------- RES-HANDOFF-MEMBERS


def test_res_handoff_members_are_sender_then_receiver():
    against_row_major = 0
    for scenario in ("flow-easy", "flow-medium", "coalition-easy"):
        for before, rec in transitions(catalogue(scenario, "random", 150)):
            for e in rec["events"]:
                if e["type"] != "handoff_started":
                    continue
                act = next((a for a in rec["state"]["activities"] if a["id"] == e["activity"]), None)
                if act is None:
                    continue
                assert act["members"] == [e["sender"], e["receiver"]]
                assert before["state"]["robots"][e["sender"]]["holding"] == act["item"]
                key = [tuple(map(int, m.split(","))) for m in act["members"]]
                against_row_major += key != sorted(key)
    assert against_row_major > 0  # some handoff goes west or north: members are not row-major


# --------------------------------------------------------------------------- RES-PAYLOAD-CHECKS


def _heavy(payload: float, name: str = "serial3-1x3-flat") -> dict:
    inst = instance(name)
    inst["profile"]["payload"] = payload
    return inst


def test_res_payload_checks_a_product_heavier_than_the_payload_is_never_handed_off():
    """R-HANDOFF 4: every mass is >= 0.5 > 0.1; the unary operations (no bound role) still run."""
    kinds = lambda recs: {e["type"] for r in ticks(recs) for e in r["events"]}  # noqa: E731
    assert "handoff_started" in kinds(reference_trace(_heavy(10.0), "greedy"))
    heavy = kinds(reference_trace(_heavy(0.1), "greedy"))
    assert "handoff_started" not in heavy and "pick_completed" in heavy  # picks do not check the payload
    assert "admitted" in heavy  # R-CANDIDATES 4 applies to operations with bound roles only (b >= 1)


def test_res_payload_checks_no_candidate_when_the_bound_share_exceeds_the_payload():
    """R-CANDIDATES 4: pair_assembly binds both roles; mass / 2 >= 0.25 > 0.1 leaves no candidate."""
    heavy, light = Simulator(_heavy(0.1, "pair-2x2-official")), Simulator(_heavy(10.0, "pair-2x2-official"))
    ctl = make_controller("greedy", 0)
    ctl.reset(0)
    for _ in range(40):
        found, _ = build_candidates(heavy.state, light.model)  # the same state under payload 10
        if found:
            assert heavy.decision.candidates == []  # none under payload 0.1
            return
        heavy.step(ctl.act(heavy.observe(), None))
    pytest.fail("no candidate appeared in 40 ticks")


def test_res_payload_checks_an_instance_below_its_masses_is_refused(tmp_path):
    path = tmp_path / "heavy.json"
    path.write_text(json.dumps(_heavy(0.1)), encoding="utf-8")
    result = CliRunner().invoke(cli, ["validate", str(path), "--format", "json"])
    assert result.exit_code == 1 and "AG459" in result.output and "/scenario/products/mass" in result.output
    path.write_text(json.dumps(_heavy(10.0)), encoding="utf-8")
    assert CliRunner().invoke(cli, ["validate", str(path)]).exit_code == 0


# --------------------------------------------------------------------------- RES-ZERO-CAPACITY


def _torch(capacity: int, conflicts: bool = False) -> dict:
    """xor-2x2-flat with the `weld` alternative needing resource `torch` of the given capacity."""
    inst = instance("xor-2x2-flat")
    recipe = inst["recipes"]["xor_route"]
    recipe["resources"] = {"torch": 1}
    next(op for op in recipe["operations"] if op["id"] == "weld")["resources"] = ["torch"]
    inst["scenario"]["resources"] = {"torch": capacity}
    if conflicts:  # G-CONFLICT on common targets (the flat profile has none)
        inst["profile"].update(rho_conf=0.25, clearance=0.1)
    return inst


def _support_weld(sim: Simulator, epochs: int) -> list[dict]:
    """Robot 1,0 picks B, then selects the weld candidate every epoch; the events of each tick."""
    out = []
    for t in range(epochs):
        ops = [c.cid for c in sim.decision.options[(1, 0)].operations]
        weld = [k for k, cid in enumerate(ops) if ":weld:" in cid]
        pick = [k for k, o in enumerate(sim.decision.options[(1, 0)].picks) if o["token"] == "B"]
        action = OP0 + weld[0] if weld else (2 + pick[0] if pick and t == 0 else 0)
        out.append(sim.step({"1,0": action}).events)
    return out


def test_res_zero_capacity_every_attempt_is_blocked_with_cause_resource():
    sim = Simulator(_torch(0))
    events = [e for tick in _support_weld(sim, 8) for e in tick]
    blocked = [e for e in events if e["type"] == "blocked"]
    assert blocked and all(e["cause"] == "resource" and ":weld:" in e["candidate"] for e in blocked)
    assert not any(e["type"] == "admitted" and ":weld:" in e["candidate"] for e in events)
    open_sim = Simulator(_torch(1))  # the same run with capacity 1 admits the weld
    assert any(e["type"] == "admitted" and ":weld:" in e["candidate"] for tick in _support_weld(open_sim, 8)
               for e in tick)


def test_res_zero_capacity_resource_comes_before_geometry():
    for capacity, cause in ((0, "resource"), (1, "geometry")):
        sim = Simulator(_torch(capacity, conflicts=True))
        _support_weld(sim, 1)  # 1,0 picked B (D = 1): the weld candidate exists now
        cand = next(c for c in sim.decision.candidates if ":weld:" in c.cid)
        other = (0, 1)  # a committed activity of another robot at the weld's own site
        sim.state.activities.append(Activity(aid="x", kind="operation", members=(other,), resources=frozenset(),
                                             plan=cand.plan, target=cand.target, start=0, end=99, seq=99))
        got = rules.blocking_cause(sim.state, sim.model, cand.members, cand.resources, cand.plan, cand.target)
        assert got == cause, capacity


# --------------------------------------------------------------------------- RES-PICK-ITEM


def test_res_pick_item_is_the_item_the_pick_will_create():
    picks = 0
    for scenario in ("flow-easy", "coalition-easy"):
        records = catalogue(scenario, "greedy", 80)
        for before, rec in transitions(records):
            for act in rec["state"]["activities"]:
                if act["kind"] != "pick":
                    continue
                _, pid, token, robot = act["id"].split("@")[1].split(":")
                assert act["item"] == f"{pid}:{token}" and act["product"] == int(pid)
                assert act["item"] not in rec["state"]["items"]  # it does not exist while the pick runs
                picks += 1
            for e in rec["events"]:
                if e["type"] == "pick_completed":
                    assert rec["state"]["items"][e["item"]] == e["robot"]  # it exists from the completion
    assert picks > 0


# --------------------------------------------------------------------------- RES-ACTIVITY-LABELS


def test_res_activity_labels_logistics_have_no_role():
    seen: set[tuple] = set()
    for name in ("flow-easy", "coalition-easy"):
        sim = Simulator(load_instance(name, 0, None))
        ctl = make_controller("greedy", 0)
        ctl.reset(0)
        for _ in range(70):
            obs = sim.observe()
            state = global_state(sim.state)
            acts = {a["id"]: a for a in state["activities"]}
            for o in obs.values():
                for n in o["neighbours"]:
                    robot = state["robots"][n["robot"]]
                    act = acts.get(robot["activity"])
                    if act is None:
                        if robot["incoming"] is None:
                            assert (n["op"], n["role"]) == (None, None)
                        continue
                    if act["kind"] == "operation":
                        recipe = sim.model.recipes[state["products"][act["product"]]["recipe"]]
                        expected = (recipe.op(act["operation"]).type, act["roles"][n["robot"]])
                    elif act["kind"] == "handoff":
                        expected = ("handoff_send" if act["members"][0] == n["robot"] else "handoff_receive", None)
                    else:
                        expected = (act["kind"], None)
                    assert (n["op"], n["role"]) == expected
                    seen.add(expected[0] if act["kind"] != "operation" else "operation")
            sim.step(ctl.act(obs, None))
    assert {"pick", "handoff_send", "handoff_receive", "deliver", "operation"} <= seen


# --------------------------------------------------------------------------- RES-POSES-WITHOUT-MOTION-PLANNING


def test_res_poses_without_motion_planning_effectors_still_move():
    """With motion planning off a picker's end effector still ends at the shelf point (G-END-EFFECTOR)."""
    inst = instance("serial3-1x3-flat")
    assert inst["profile"]["motion_planning"] is False
    records = reference_trace(inst, "greedy")
    rows = {e["activity"]: e["shelf_row"] for r in ticks(records) for e in r["events"] if e["type"] == "pick_started"}
    moved = 0
    for rec in ticks(records):
        for e in rec["events"]:
            if e["type"] == "pick_completed":
                robot = rec["state"]["robots"][e["robot"]]
                assert robot["ee"] == list(geometry.shelf_point(rows[e["activity"]], inst["profile"]["spacing"]))
                assert any(q != 0 for q in robot["q"])  # the joint proxy moved with it
                moved += 1
    assert moved > 0


# --------------------------------------------------------------------------- RES-SLOT-OVERFLOW-STATE


def _flooded(horizon: int = 50) -> dict:
    """1 x 2, one product released every epoch: idle robots let the picker's options overflow 32 slots."""
    inst = instance("solo-1x2-wip1-flat")
    inst["scenario"]["release"] = {"interval": 1, "wip_cap": 500}
    inst["scenario"]["evaluation"]["horizon"] = horizon
    inst["scenario"]["shelves"]["replenish_interval"] = 1  # raw material never runs out
    first = inst["realization"]["products"][0]
    inst["realization"]["products"] = [{**first, "id": k} for k in range(horizon + 1)]
    inst["id"] = "flooded"
    return inst


def test_res_slot_overflow_state_ends_the_execution_until_a_reset():
    server = Server()
    assert server.handle({"cmd": "start", "seq": 1, "protocol": "agspec-protocol/1"})["ok"]
    assert server.handle({"cmd": "load", "seq": 2, "instance": _flooded()})["ok"]
    assert server.handle({"cmd": "reset", "seq": 3})["ok"]
    seq, reply = 3, {"ok": True}
    while reply["ok"]:
        seq += 1
        reply = server.handle({"cmd": "step", "seq": seq, "actions": {}})
    assert reply["error"]["code"] == "slot_overflow" and seq == 4 + 31  # 33 products at t = 32: 33 > 32 slots
    assert server.sim.state.t == 32 and server.sim.state.released == 33  # the transition was applied
    after = server.handle({"cmd": "step", "seq": seq + 1, "actions": {}})
    assert after["error"]["code"] == "not_reset"  # no robot can act in the overflowing state
    assert server.handle({"cmd": "reset", "seq": seq + 2})["ok"]  # a reset starts again
    assert server.handle({"cmd": "step", "seq": seq + 3, "actions": {}})["ok"]


def test_res_slot_overflow_state_run_writes_no_record_for_it(tmp_path):
    """`agspec run` (greedy cannot keep up with a release per epoch) stops with exit 1; the trace
    ends with the tick record of the last state a robot could act in, without a footer."""
    inst = _flooded(200)
    path, trace = tmp_path / "flooded.json", tmp_path / "flooded.jsonl"
    path.write_text(json.dumps(inst), encoding="utf-8")
    result = CliRunner().invoke(cli, ["run", str(path), "--trace", str(trace)])
    assert result.exit_code == 1 and "overflow" in result.output
    records = [json.loads(x) for x in trace.read_text(encoding="utf-8").splitlines()]
    assert records[0]["fingerprint"] == fingerprint(inst) and records[-1]["type"] == "tick"
    overflow_at = int(re.search(r"at t=(\d+):", result.output).group(1))
    assert records[-1]["state"]["t"] == overflow_at - 1  # the overflowing state has no record
