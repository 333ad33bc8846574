"""The invariant checker (spec chapter 08): clean on real traces, and each INV-* catches a hand-mutated
trace.  Every mutation test first confirms the unmutated trace is clean, then changes one thing and
asserts that the invariant it breaks is reported (with the right entity where that is unambiguous).
"""

from __future__ import annotations

import ast
import io
import json
from functools import lru_cache
from pathlib import Path

import pytest

from agspec import invariants as inv
from agspec.invariants import INVARIANT_IDS, check_trace, parse_trace_text
from agspec.evaluate import run_episode
from agspec.ir.instance import make_instance
from agspec.formats.trace import TraceWriter

from conftest_ir import bundle


@lru_cache(maxsize=None)
def trace_text(scenario: str, controller: str, horizon: int, index: int = 0) -> str:
    sc, recipes, profile = bundle(scenario)
    instance = make_instance(sc, recipes, profile, index=index)
    buf = io.StringIO()
    run_episode(instance, controller, horizon=horizon, seed=7, trace=TraceWriter(buf), observations_in_trace=True)
    return buf.getvalue()


def records(scenario: str = "coalition-medium", controller: str = "greedy", horizon: int = 120) -> list[dict]:
    """A fresh parsed copy of a cached trace (tests mutate it freely)."""
    return parse_trace_text(trace_text(scenario, controller, horizon))


def ticks(recs):
    return [r for r in recs if r.get("type") == "tick"]


def first(recs, pred):
    """The first tick record satisfying ``pred`` (with its index in ``recs``)."""
    for k, r in enumerate(recs):
        if r.get("type") == "tick" and pred(r):
            return k, r
    raise AssertionError("no record satisfies the predicate")


def reported(recs) -> set[str]:
    return check_trace(recs).ids()


# --------------------------------------------------------------------------- real traces are clean


@pytest.mark.parametrize(
    "scenario,controller,horizon",
    [
        ("flow-easy", "greedy", 60),
        ("flow-hard", "random", 40),
        ("coalition-medium", "greedy", 120),
        ("coalition-hard", "centralized", 60),
        ("concurrency-medium", "parallel-aware", 80),
        ("geometry-matched-high", "random", 40),
    ],
)
def test_checker_passes_on_reference_traces(scenario, controller, horizon):
    """INV-* hold on the reference interpreter's traces; the vacuity counters show real work."""
    report = check_trace(records(scenario, controller, horizon))
    assert report.ok, report.summary()
    assert report.ticks == horizon
    assert report.states == horizon + 1
    assert report.agents in (20, 30, 48)
    assert not report.skipped  # observations and masks are in the trace
    for inv_id in INVARIANT_IDS:
        assert report.records[inv_id] == horizon + 1
    for inv_id in ("INV-CONSERVATION", "INV-EXCLUSIVITY", "INV-OBSERVATION", "INV-MASKING", "INV-ACCOUNTING",
                   "INV-PROGRESS", "INV-RECIPE", "INV-LOCALITY"):
        assert report.checks[inv_id] > 0, inv_id


def test_coalition_trace_exercises_operations():
    """The mutation base trace has picks, handoffs, 2/3/4-robot operations, supports and a delivery."""
    report = check_trace(records())
    assert report.checks["INV-ARITY"] > 0 and report.checks["INV-LIFETIME"] > 0 and report.checks["INV-SUPPORT"] > 0
    kinds = {(a["kind"], len(a["members"])) for r in ticks(records()) for a in r["state"]["activities"]}
    assert {("pick", 1), ("handoff", 2), ("operation", 2), ("operation", 3), ("operation", 4), ("deliver", 1)} <= kinds


def test_observations_are_optional_and_their_skip_is_reported():
    """INV-TRACE: without observations, INV-OBSERVATION and INV-MASKING report a skip, not a pass."""
    recs = records("flow-easy", "greedy", 60)
    for r in ticks(recs):
        del r["observations"]
    report = check_trace(recs)
    assert report.ok, report.summary()
    assert set(report.skipped) == {"INV-OBSERVATION", "INV-MASKING"}
    assert report.checks["INV-OBSERVATION"] == 0


# --------------------------------------------------------------------------- the module's contract


def test_one_function_per_invariant_named_after_its_id():
    assert [i for i, _ in inv.INVARIANTS] == list(INVARIANT_IDS)
    for inv_id, fn in inv.INVARIANTS:
        assert fn.__name__ == "inv_" + inv_id.removeprefix("INV-").lower()
        assert inv_id in (fn.__doc__ or ""), fn.__name__


def test_invariants_never_import_the_interpreter():
    """STYLE §2: invariants read traces, never interpreter internals."""
    modules = sorted(Path(inv.__file__).parent.glob("*.py"))
    assert len(modules) > 1  # the package: one module per group of invariants
    imported = set()
    for module in modules:
        for node in ast.walk(ast.parse(module.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom):
                imported.add(node.module or "")
            elif isinstance(node, ast.Import):
                imported.update(a.name for a in node.names)
    assert not any(m.startswith("agspec.interp") for m in imported), imported


def test_violation_renders_id_tick_entity_and_message():
    v = inv.Violation("INV-ACCOUNTING", 7, "3", "wip 2 != released 3 - delivered 0")
    assert str(v) == "INV-ACCOUNTING t=7 [3]: wip 2 != released 3 - delivered 0"


# --------------------------------------------------------------------------- vacuity guard (INV-TRACE)


def test_empty_trace_is_a_violation():
    assert check_trace([]).ids() == {"TRACE-EMPTY"}


def test_trace_without_ticks_is_empty():
    recs = records("flow-easy", "greedy", 60)
    header = recs[0]
    assert "TRACE-EMPTY" in check_trace([header, {"type": "footer", "ticks": 0, "complete": True}]).ids()


def test_trace_without_footer_is_truncated():
    recs = records("flow-easy", "greedy", 60)[:-1]
    report = check_trace(recs)
    assert report.ids() == {"TRACE-TRUNCATED"}


def test_footer_tick_count_must_match_the_records():
    recs = records("flow-easy", "greedy", 60)
    del recs[-2]  # drop the last tick record, keep the footer
    assert report_ids_with(recs) == {"TRACE-TRUNCATED"}


def test_a_gap_in_the_epochs_is_truncation():
    recs = records("flow-easy", "greedy", 60)
    del recs[10]
    recs[-1]["ticks"] -= 1
    assert "TRACE-TRUNCATED" in check_trace(recs).ids()


def test_an_incomplete_footer_is_truncation():
    recs = records("flow-easy", "greedy", 60)
    recs[-1]["complete"] = False
    assert check_trace(recs).ids() == {"TRACE-TRUNCATED"}


def test_a_torn_last_line_reads_as_truncated(tmp_path):
    text = trace_text("flow-easy", "greedy", 60)
    path = tmp_path / "t.jsonl"
    path.write_text(text[: len(text) - 40], encoding="utf-8")  # crash mid-footer
    assert inv.check_trace_file(path).ids() == {"TRACE-TRUNCATED"}


def report_ids_with(recs):
    return check_trace(recs).ids()


# --------------------------------------------------------------------------- one mutation per invariant


def test_conservation_catches_a_duplicated_item():
    """INV-CONSERVATION: an item copied into a second, empty robot's hand."""
    recs = records()
    assert check_trace(recs).ok
    k, rec = first(recs, lambda r: r["state"]["items"])
    item, owner = next(iter(rec["state"]["items"].items()))
    empty = next(r for r, v in rec["state"]["robots"].items() if v["holding"] is None and r != owner)
    rec["state"]["robots"][empty]["holding"] = item
    report = check_trace(recs)
    assert "INV-CONSERVATION" in report.ids()
    assert any(v.entity == item for v in report.by_invariant("INV-CONSERVATION"))


def test_conservation_catches_a_fabricated_item():
    """INV-CONSERVATION: a terminal item appears without an operation producing it."""
    recs = records()
    k, rec = first(recs, lambda r: r["t"] > 20)
    state = rec["state"]
    pid = state["products"][0]["id"]
    empty = next(r for r, v in state["robots"].items() if v["holding"] is None and v["busy_until"] <= state["t"])
    fake = f"{pid}:FINAL"
    assert fake not in state["items"]
    state["robots"][empty]["holding"] = fake
    state["items"][fake] = empty
    state["items"] = dict(sorted(state["items"].items()))
    report = check_trace(recs)
    msgs = [v.message for v in report.by_invariant("INV-CONSERVATION") if v.entity == fake]
    assert any("appeared" in m for m in msgs), report.summary()


def test_conservation_catches_a_vanished_item():
    """INV-CONSERVATION: an item disappears from every later state without being consumed."""
    recs = records()
    k, rec = first(recs, lambda r: r["t"] > 10 and r["state"]["items"])
    item, owner = next(iter(rec["state"]["items"].items()))
    for r in ticks(recs)[rec["t"]:]:
        st = r["state"]
        if st["items"].get(item):
            st["robots"][st["items"].pop(item)]["holding"] = None
    assert "INV-CONSERVATION" in check_trace(recs).ids()


def test_support_catches_a_dangling_pending_support():
    """INV-SUPPORT: a robot's pending support names no support record."""
    recs = records()
    k, rec = first(recs, lambda r: r["t"] > 5)
    robot = next(r for r, v in rec["state"]["robots"].items() if v["supports"] is None and v["busy_until"] <= rec["state"]["t"])
    rec["state"]["robots"][robot]["supports"] = "op:0:align_ab:0,0;1,0"
    report = check_trace(recs)
    assert "INV-SUPPORT" in report.ids()
    assert any(v.entity == robot for v in report.by_invariant("INV-SUPPORT"))


def test_support_catches_a_second_owner_during_a_handoff():
    """INV-SUPPORT: the receiver of a handoff in flight owns the item as well as the sender."""
    recs = records()
    k, rec = first(recs, lambda r: any(a["kind"] == "handoff" for a in r["state"]["activities"]))
    act = next(a for a in rec["state"]["activities"] if a["kind"] == "handoff")
    receiver = next(m for m in act["members"] if rec["state"]["robots"][m]["holding"] is None)
    rec["state"]["robots"][receiver]["holding"] = act["item"]
    report = check_trace(recs)
    assert "INV-SUPPORT" in report.ids()
    assert any(v.entity in (act["item"], act["id"]) for v in report.by_invariant("INV-SUPPORT"))


def test_support_catches_a_supporter_outside_the_candidate():
    """INV-SUPPORT: a support record lists a robot that is not a member of its candidate."""
    recs = records()
    k, rec = first(recs, lambda r: r["state"]["proposals"])
    cid, pr = next(iter(rec["state"]["proposals"].items()))
    members = cid.rsplit(":", 1)[1].split(";")
    outsider = next(r for r in rec["state"]["robots"] if r not in members)
    pr["supporters"].append(outsider)
    rec["state"]["robots"][outsider]["supports"] = cid
    report = check_trace(recs)
    assert any("not one of its members" in v.message for v in report.by_invariant("INV-SUPPORT"))


def test_progress_catches_a_dropped_completed_operation():
    """INV-PROGRESS: a completed operation disappears from a product's progress."""
    recs = records()
    k, rec = first(recs, lambda r: any(p["completed"] for p in r["state"]["products"]))
    nxt = recs[k + 1]
    prod = next(p for p in nxt["state"]["products"] if p["completed"])
    dropped = prod["completed"].pop()
    report = check_trace(recs)
    assert "INV-PROGRESS" in report.ids()
    assert any(dropped in v.message for v in report.by_invariant("INV-PROGRESS"))


def test_progress_catches_an_undone_delivery():
    """INV-PROGRESS: a delivered product is un-delivered."""
    recs = records()
    k, rec = first(recs, lambda r: any(p["delivered_at"] is not None for p in r["state"]["products"]))
    nxt = recs[k + 1]["state"]
    prod = next(p for p in nxt["products"] if p["delivered_at"] is not None)
    prod["delivered_at"] = None
    assert "INV-PROGRESS" in check_trace(recs).ids()


def test_recipe_catches_an_operation_in_progress_without_activity():
    """INV-RECIPE: in_progress lists an operation that no activity executes and whose predecessor is open."""
    recs = records()
    k, rec = first(recs, lambda r: any(not p["completed"] and not p["in_progress"] for p in r["state"]["products"]))
    prod = next(p for p in rec["state"]["products"] if not p["completed"] and not p["in_progress"])
    prod["in_progress"] = ["supported_insert"]  # runs after align_ab, which is not completed
    report = check_trace(recs)
    assert report.ids() == {"INV-RECIPE"}, report.summary()
    msgs = " ".join(v.message for v in report.by_invariant("INV-RECIPE"))
    assert "predecessor `align_ab`" in msgs and "operation activities" in msgs


def test_recipe_catches_a_delivery_before_the_terminal_output():
    """INV-RECIPE: a product is marked delivered although its terminal operation never completed."""
    recs = records()
    k, rec = first(recs, lambda r: r["t"] > 5)
    prod = next(p for p in rec["state"]["products"] if "supported_insert" not in p["completed"])
    prod["delivered_at"] = rec["state"]["t"]
    report = check_trace(recs)
    assert any("no operation producing `FINAL`" in v.message for v in report.by_invariant("INV-RECIPE"))


def _operation_record(recs, size=2):
    return first(recs, lambda r: any(a["kind"] == "operation" and len(a["members"]) == size
                                     for a in r["state"]["activities"]))


def test_locality_catches_a_non_adjacent_coalition():
    """INV-LOCALITY: an operation activity whose members are not Moore neighbours."""
    recs = records()
    k, rec = _operation_record(recs)
    act = next(a for a in rec["state"]["activities"] if a["kind"] == "operation" and len(a["members"]) == 2)
    u, v = act["members"]
    far = next(r for r in rec["state"]["robots"]
               if max(abs(int(a) - int(b)) for a, b in zip(r.split(","), u.split(","))) >= 2)
    act["members"] = sorted([u, far], key=lambda r: tuple(map(int, r.split(","))))
    report = check_trace(recs)
    assert "INV-LOCALITY" in report.ids()
    assert any(v.entity == act["id"] for v in report.by_invariant("INV-LOCALITY"))


def test_locality_catches_a_delivery_off_the_output_column():
    """INV-LOCALITY: a delivery by a robot outside column N - 1."""
    recs = records()
    k, rec = first(recs, lambda r: any(a["kind"] == "deliver" for a in r["state"]["activities"]))
    act = next(a for a in rec["state"]["activities"] if a["kind"] == "deliver")
    act["members"] = ["0,0"]
    assert "INV-LOCALITY" in check_trace(recs).ids()


def test_lifetime_catches_a_member_added_mid_way():
    """INV-LIFETIME: a committed coalition gains a member while it executes."""
    recs = records()
    k, rec = _operation_record(recs)
    act = next(a for a in rec["state"]["activities"] if a["kind"] == "operation" and len(a["members"]) == 2)
    later = next(r for r in recs[k + 1:] if any(a["id"] == act["id"] for a in r["state"]["activities"]))
    act2 = next(a for a in later["state"]["activities"] if a["id"] == act["id"])
    act2["members"].append("4,5")
    report = check_trace(recs)
    assert "INV-LIFETIME" in report.ids()
    v = report.by_invariant("INV-LIFETIME")[0]
    assert v.entity == act["id"] and "members" in v.message


def test_lifetime_catches_a_changed_role_and_an_early_end():
    """INV-LIFETIME: roles rewritten mid-way; an activity vanishing before its end epoch."""
    recs = records()
    k, rec = _operation_record(recs)
    act = next(a for a in rec["state"]["activities"] if a["kind"] == "operation" and len(a["members"]) == 2)
    later = next(r for r in recs[k + 1:] if any(a["id"] == act["id"] for a in r["state"]["activities"]))
    act2 = next(a for a in later["state"]["activities"] if a["id"] == act["id"])
    m = act2["members"][0]
    act2["roles"][m] = "stabilizer"
    assert "INV-LIFETIME" in check_trace(recs).ids()


def test_arity_catches_swapped_roles_throughout_an_activity():
    """INV-ARITY: roles that are not the canonical assignment (consistently, so INV-LIFETIME is silent)."""
    recs = records()
    k, rec = _operation_record(recs)
    act = next(a for a in rec["state"]["activities"] if a["kind"] == "operation" and len(a["members"]) == 2)
    for r in ticks(recs):
        for a in r["state"]["activities"]:
            if a["id"] == act["id"]:
                (m1, r1), (m2, r2) = sorted(a["roles"].items())
                a["roles"] = {m1: r2, m2: r1}
    report = check_trace(recs)
    assert report.ids() == {"INV-ARITY"}, report.summary()
    assert "canonical assignment" in report.by_invariant("INV-ARITY")[0].message


def test_arity_catches_a_coalition_above_its_arity():
    """INV-ARITY: a coalition larger than min(k_max, k_topo)."""
    recs = records()
    k, rec = _operation_record(recs, size=2)
    act = next(a for a in rec["state"]["activities"] if a["kind"] == "operation" and len(a["members"]) == 2)
    if act["operation"] != "align_ab":
        pytest.skip("first 2-robot operation is not align_ab")
    act["members"] = act["members"] + ["4,5"]
    act["roles"]["4,5"] = "holder_A"
    assert any("members" in v.message and "needs" in v.message for v in check_trace(recs).by_invariant("INV-ARITY"))


def test_exclusivity_catches_shelf_stock_above_capacity():
    """INV-EXCLUSIVITY: shelf stock outside [0, capacity]."""
    recs = records()
    rec = ticks(recs)[30]
    token = next(iter(rec["state"]["shelves"][0]))
    rec["state"]["shelves"][0][token] = 7
    report = check_trace(recs)
    assert report.ids() == {"INV-EXCLUSIVITY"}
    assert report.by_invariant("INV-EXCLUSIVITY")[0].entity == f"shelf:0:{token}"


def test_exclusivity_catches_a_robot_in_two_activities():
    """INV-EXCLUSIVITY: one robot committed to two activities at once."""
    recs = records()
    k, rec = first(recs, lambda r: len(r["state"]["activities"]) >= 2)
    a, b = rec["state"]["activities"][:2]
    b["members"] = b["members"] + [a["members"][0]]
    report = check_trace(recs)
    assert any("2 activities" in v.message for v in report.by_invariant("INV-EXCLUSIVITY"))


def test_exclusivity_catches_a_shared_exclusive_resource():
    """INV-EXCLUSIVITY: two activities holding the same capacity-1 resource."""
    recs = records()
    k, rec = first(recs, lambda r: len(r["state"]["activities"]) >= 2)
    a, b = rec["state"]["activities"][:2]
    b["resources"] = sorted(set(b["resources"]) | {a["resources"][0]})
    report = check_trace(recs)
    assert any(v.entity == a["resources"][0] for v in report.by_invariant("INV-EXCLUSIVITY"))


def test_observation_catches_a_leaked_remote_robot():
    """INV-OBSERVATION: a robot sees a remote robot's state."""
    recs = records()
    rec = ticks(recs)[20]
    obs = rec["observations"]["0,0"]
    obs["neighbours"].append({"dir": "SE", "robot": "4,5", "holding": None, "busy": False, "failed": False,
                              "op": None, "role": None})
    report = check_trace(recs)
    assert report.ids() == {"INV-OBSERVATION"}
    assert any("4,5" in v.message and v.entity == "0,0" for v in report.by_invariant("INV-OBSERVATION"))


def test_observation_catches_due_dates_and_supporter_identities():
    """INV-OBSERVATION: fields outside O-OBSERVATION (due dates, supporter lists) are leaks."""
    recs = records()
    k, rec = first(recs, lambda r: any(o["operation_options"] for o in r["observations"].values()))
    robot, obs = next((r, o) for r, o in rec["observations"].items() if o["operation_options"])
    obs["due"] = 42
    obs["operation_options"][0]["supporters"] = [robot]
    msgs = [v.message for v in check_trace(recs).by_invariant("INV-OBSERVATION")]
    assert any("'due'" in m for m in msgs) and any("supporters" in m for m in msgs)


def test_observation_catches_a_wrong_support_fraction():
    """INV-OBSERVATION / O-SUPPORT-FRACTION: the cue must be |supporters| / |U_c| of the pre-action state."""
    recs = records()
    k, rec = first(recs, lambda r: any(o["operation_options"] for o in r["observations"].values()))
    robot, obs = next((r, o) for r, o in rec["observations"].items() if o["operation_options"])
    obs["operation_options"][0]["support"] = 0.75
    report = check_trace(recs)
    assert any("support fraction" in v.message for v in report.by_invariant("INV-OBSERVATION"))


def test_observation_catches_an_option_without_the_robot():
    """INV-OBSERVATION / O-EXPOSURE: a robot is offered a candidate it is not a member of."""
    recs = records()
    k, rec = first(recs, lambda r: any(o["operation_options"] for o in r["observations"].values()))
    robot, obs = next((r, o) for r, o in rec["observations"].items() if o["operation_options"])
    other = next(r for r, o in rec["observations"].items()
                 if r != robot and robot not in [m for opt in o["operation_options"] for m in opt["members"]])
    rec["observations"][other]["operation_options"].append(dict(obs["operation_options"][0]))
    assert "INV-OBSERVATION" in check_trace(recs).ids()


def test_masking_catches_a_mask_without_idle():
    """INV-MASKING: idle removed from a mask."""
    recs = records()
    rec = ticks(recs)[12]
    rec["observations"]["2,3"]["mask"][0] = False
    report = check_trace(recs)
    assert report.ids() == {"INV-MASKING"}
    assert any("idle is masked" in v.message for v in report.by_invariant("INV-MASKING"))


def test_masking_catches_hidden_pick_slots():
    """INV-MASKING: a free, empty-handed input robot with pick options has its pick slots hidden."""
    recs = records()
    k, rec = first(recs, lambda r: any(o["pick_options"] for o in r["observations"].values()))
    robot, obs = next((r, o) for r, o in rec["observations"].items() if o["pick_options"])
    for s in range(len(obs["pick_options"])):
        obs["mask"][2 + s] = False
    if rec["actions"][robot] in range(2, 34):
        rec["actions"][robot] = 0  # keep the applied action consistent with the mutated mask
    report = check_trace(recs)
    assert any("hides locally legal" in v.message and "pick slot 0" in v.message
               for v in report.by_invariant("INV-MASKING"))


def test_masking_catches_an_applied_illegal_action():
    """INV-MASKING / R-ACTION-VALIDATION: a busy robot's non-idle action was applied."""
    recs = records()
    k, rec = first(recs, lambda r: any(o["busy"] for o in r["observations"].values()))
    robot = next(r for r, o in rec["observations"].items() if o["busy"])
    rec["actions"][robot] = 1  # deliver, masked for a busy robot
    report = check_trace(recs)
    assert any("forbids" in v.message and v.entity == robot for v in report.by_invariant("INV-MASKING"))


def test_masking_catches_an_exposed_busy_action():
    """INV-MASKING: a busy robot whose mask allows more than idle."""
    recs = records()
    k, rec = first(recs, lambda r: any(o["busy"] for o in r["observations"].values()))
    robot = next(r for r, o in rec["observations"].items() if o["busy"])
    rec["observations"][robot]["mask"][1] = True
    assert any("busy" in v.message for v in check_trace(recs).by_invariant("INV-MASKING"))


def test_accounting_catches_wip_drift():
    """INV-ACCOUNTING: reported WIP drifts from released - delivered."""
    recs = records()
    rec = ticks(recs)[40]
    rec["state"]["wip"] += 1
    report = check_trace(recs)
    assert report.ids() == {"INV-ACCOUNTING"}
    assert any("wip" in v.message for v in report.by_invariant("INV-ACCOUNTING"))


def test_accounting_catches_a_decreasing_lost_count():
    """INV-ACCOUNTING: lost releases never decrease; released + lost counts opportunities."""
    recs = records()
    k, rec = first(recs, lambda r: r["state"]["lost_releases"] > 0)
    recs[k + 1]["state"]["lost_releases"] -= 1  # the epoch after the first lost release
    msgs = [v.message for v in check_trace(recs).by_invariant("INV-ACCOUNTING")]
    assert any("decreased" in m for m in msgs) and any("opportunity" in m for m in msgs)


def test_accounting_catches_a_release_off_schedule():
    """INV-ACCOUNTING / R-RELEASE: a product released at an epoch that is no release opportunity."""
    recs = records()
    rec = ticks(recs)[1]  # state t = 2; interval 5
    st = rec["state"]
    pid = st["released"]
    st["products"].append({"completed": [], "delivered_at": None, "due": 2 + 30, "id": pid, "in_progress": [],
                           "raw_taken": [], "recipe": "supported_insert", "released_at": 2, "xor": {}})
    st["released"] += 1
    st["wip"] += 1
    assert any("not a release opportunity" in v.message for v in check_trace(recs).by_invariant("INV-ACCOUNTING"))


# --------------------------------------------------------------------------- checker API


def test_check_records_runs_every_invariant_once_per_record():
    recs = records("flow-easy", "greedy", 60)
    ctx = inv.Context.from_instance(recs[0]["instance"])
    out = inv.check_records(ctx, None, recs[0])
    out += inv.check_records(ctx, recs[0], recs[1])
    assert out == []
    assert all(ctx.evaluated[i] == 2 for i in INVARIANT_IDS)


def test_trace_file_round_trip(tmp_path):
    path = tmp_path / "trace.jsonl"
    path.write_text(trace_text("flow-easy", "greedy", 60), encoding="utf-8")
    report = inv.check_trace_file(path)
    assert report.ok and report.ticks == 60
    assert "60 ticks, 20 agents" in report.summary()
    assert json.loads(path.read_text().splitlines()[0])["type"] == "header"
