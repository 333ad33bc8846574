"""Seeded mutants of the reference interpreter: each breaks ONE rule or invariant, realistically.

A mutant is applied inside the simulator process (``tests/mutants/sim.py --mutant NAME``) by
monkeypatching or wrapping a function of :mod:`agspec.interp` — the kind of bug a port of the
simulator plausibly has (an off-by-one, a missing check, a refreshed clock) — or, for the
robustness mutants, by misbehaving on the wire (crash, hang, garbage, wrong ``seq``).

Every mutant declares what the harness must report for it:

* ``outcome`` — ``"fail"`` (a divergence from the reference or an invariant violation) or
  ``"error"`` (crash, timeout, protocol);
* ``ids`` — the acceptable identifications, any of: an invariant ID (``INV-…``) reported with the
  failure, a prefix of the JSON Pointer of the first divergence into the reply (``/state/wip``,
  ``/observations/*/mask``; ``*`` matches one token), or the error ``kind/code`` of F-PROTOCOL-ERRORS
  (``crash/exit``, ``timeout``, ``protocol/malformed_json``);
* ``workload`` — a small instance and controller that trigger the mutant within a few ticks;
* ``invariant`` — for mutants that break an invariant, the invariant ID the invariant checker must report on
  the mutant's own trace *without* the reference (None for departures only a comparison can see: a
  transfer without consent, an admission without support, a wrong duration);
* ``reads`` — for the mutants that hard-code an instance value (the official one) instead of reading
  it: the instance the mutant actually simulates, as a pure function of the one it is sent.  Their
  workload is the **default run** of ``agspec conform`` (:data:`DEFAULT_RUN`): such a mutant behaves
  exactly as the reference on every item whose instance ``reads`` leaves unchanged, so the default
  run fails it iff the items ``reads`` changes fail it.

This module is test code: nothing in the product imports it.
"""

from __future__ import annotations

import dataclasses
import json
import os
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

HERE = Path(__file__).resolve().parent
INSTANCES = HERE / "instances"


@dataclass
class Session:
    """What a mutant may hook into besides the interpreter: the protocol loop of sim.py."""

    # cmd -> list of callables(msg, session) run before the request is handled; may exit or hang
    before: dict[str, list[Callable[[dict, "Session"], None]]] = field(default_factory=dict)
    # callables(msg, reply) -> reply, or a str written verbatim instead of the JSON reply
    after: list[Callable[[dict, dict], Any]] = field(default_factory=list)
    sim: Any = None  # the agspec.interp.tick.Simulator of the loaded instance
    # the capabilities declared in the start reply (F-PROTOCOL); the reply carries only these parts
    capabilities: dict[str, bool] = field(default_factory=lambda: {"observations": True, "masks": True,
                                                                   "privileged_state": True, "events": True,
                                                                   "diagnostic_state": True})
    # instance -> reason to answer `unsupported` to its load (F-PROTOCOL-UNSUPPORTED), or None to accept it
    refuse: Callable[[dict], str | None] | None = None

    def on(self, cmd: str, fn: Callable[[dict, "Session"], None]) -> None:
        self.before.setdefault(cmd, []).append(fn)


DEFAULT_RUN = "default-run"  # the workload of the hard-coding mutants: every item of `agspec conform`


@dataclass(frozen=True)
class Workload:
    instance: str  # file name under tests/mutants/instances, "catalogue:<scenario>:<index>" or DEFAULT_RUN
    controller: str = "greedy"
    ticks: int = 12
    seed: int = 1

    def path(self) -> Path | None:
        if self.instance.startswith("catalogue:") or self.instance == DEFAULT_RUN:
            return None
        return INSTANCES / self.instance


@dataclass(frozen=True)
class Mutant:
    name: str
    breaks: str  # the rule / invariant it violates
    description: str
    apply: Callable[[Session], None]
    outcome: str  # "fail" | "error"
    ids: tuple[str, ...]
    workload: Workload
    invariant: str | None = None  # what the invariant checker alone (no reference) must report
    reads: Callable[[dict], dict] | None = None  # a hard-coding mutant: the instance it simulates



MUTANTS: dict[str, Mutant] = {}


def mutant(name: str, breaks: str, outcome: str, ids: tuple[str, ...], workload: Workload,
           invariant: str | None = None):
    def register(fn: Callable[[Session], None]) -> Callable[[Session], None]:
        MUTANTS[name] = Mutant(name, breaks, (fn.__doc__ or "").strip().splitlines()[0], fn, outcome, ids, workload,
                               invariant)
        return fn

    return register


def hard_coded(name: str, breaks: str, ids: tuple[str, ...], description: str,
               edit: Callable[[dict], None]) -> None:
    """Register a mutant that ignores an instance value and uses the official one: ``edit`` rewrites the
    instance it is sent (in place) before it loads it — what a simulator with a constant in its code
    does.  Workload: the default run of ``agspec conform``."""

    def reads(instance: dict) -> dict:
        out = json.loads(json.dumps(instance))
        edit(out)
        return out

    def apply(session: Session) -> None:
        def on_load(msg: dict, session: Session) -> None:
            if isinstance(msg.get("instance"), dict):
                msg["instance"] = reads(msg["instance"])

        session.on("load", on_load)

    MUTANTS[name] = Mutant(name, breaks, description, apply, "fail", ids, Workload(DEFAULT_RUN), None, reads)


# =============================================================================================
# material


@mutant("dup-handoff", "R-HANDOFF / INV-CONSERVATION", "fail", ("INV-CONSERVATION", "/state/robots/*/holding"),
        Workload("pair-1x2-flat.json", "greedy", 8), "INV-CONSERVATION")
def dup_handoff(session: Session) -> None:
    """Duplicated item on handoff: the sender keeps a copy of the item it handed over."""
    from agspec.interp import rules

    orig = rules.complete_handoff

    def complete_handoff(state, act, events):
        orig(state, act, events)
        state.robots[act.sender].holding = act.item  # BUG: should be None

    rules.complete_handoff = complete_handoff


@mutant("one-sided-handoff", "R-HANDOFF", "fail", ("/state/items", "/state/activities",
                                                   "/state/robots/*/holding", "/state/robots/*/busy_until"),
        Workload("pair-1x2-flat.json", "random", 6, seed=1))
def one_sided_handoff(session: Session) -> None:
    """One-sided handoff: a transfer starts without the receiver's matching receive action."""
    from agspec.interp import rules
    from agspec.interp.model import DIRECTIONS

    orig = rules.start_handoffs

    def start_handoffs(state, model, sends, receives, events):
        receives = dict(receives)
        for (i, j), d in sends.items():
            di, dj = DIRECTIONS[d]
            other = (i + di, j + dj)
            if other in state.robots and other not in receives:
                receives[other] = DIRECTIONS.index((-di, -dj))  # BUG: consent assumed
        orig(state, model, sends, receives, events)

    rules.start_handoffs = start_handoffs


# =============================================================================================
# support and admission


@mutant("support-refresh", "R-SUPPORT-LIFECYCLE / INV-SUPPORT", "fail",
        ("INV-SUPPORT", "/state/proposals/*/expires_at"),
        Workload("duo-1x2-flat.json", "random", 8, seed=0), "INV-SUPPORT")
def support_refresh(session: Session) -> None:
    """Support that refreshes its timeout when a robot re-selects the candidate it already supports."""
    from agspec.interp import rules

    orig = rules.record_supports

    def record_supports(state, model, supports, events):
        for cell, cand in supports.items():
            proposal = state.proposals.get(cand.cid)
            if proposal is not None and state.robots[cell].supports == cand.cid:
                proposal.expires_at = state.t + model.support_timeout  # BUG: no refresh in v1
        orig(state, model, supports, events)

    rules.record_supports = record_supports


@mutant("admit-partial", "R-ADMISSION", "fail", ("/state/activities", "/state/proposals",
                                                 "/state/robots/*/supports"),
        Workload("duo-1x2-flat.json", "random", 8, seed=0))
def admit_partial(session: Session) -> None:
    """Admission without all supporters: one supporter is taken as the whole coalition's consent."""
    from agspec.interp import rules

    orig = rules.admit_candidates

    def admit_candidates(state, model, by_id, events):
        for cid, proposal in state.proposals.items():
            cand = by_id.get(cid)
            if cand is None or not proposal.votes or proposal.votes == set(cand.members):
                continue
            if all(state.robots[m].supports in (None, cid) for m in cand.members):
                proposal.votes = set(cand.members)  # BUG: partners enlisted without their support
                for m in cand.members:
                    state.robots[m].supports = cid
        return orig(state, model, by_id, events)

    rules.admit_candidates = admit_candidates


@mutant("nonadjacent-coalition", "R-CANDIDATES / INV-OBSERVATION", "fail",
        ("INV-LOCALITY", "INV-OBSERVATION", "/observations/*/mask",
                                          "/observations/*/operation_options"),
        Workload("helped-3x2-flat.json", "greedy", 8), "INV-OBSERVATION")
def nonadjacent_coalition(session: Session) -> None:
    """Coalition with non-adjacent members: helpers are not checked for pairwise adjacency."""
    from agspec.interp import candidates, tick

    orig = candidates.build_candidates

    class Loose:
        """The model as build_candidates sees it: two empty-handed robots always count as adjacent."""

        def __init__(self, model, state):
            self._model, self._state = model, state

        def __getattr__(self, name):
            return getattr(self._model, name)

        def adjacent(self, a, b):
            robots = self._state.robots
            if robots[a].holding is None and robots[b].holding is None:
                return a != b  # BUG: the helper-helper test of R-CANDIDATES step 3 is skipped
            return self._model.adjacent(a, b)

    def build_candidates(state, model, *ready):
        return orig(state, Loose(model, state), *ready)

    tick.build_candidates = build_candidates


@mutant("role-reassign", "R-EXECUTION / INV-LIFETIME", "fail", ("INV-LIFETIME", "/state/activities/*/roles"),
        Workload("pair-1x2-flat.json", "greedy", 12), "INV-LIFETIME")
def role_reassign(session: Session) -> None:
    """Role reassignment mid-activity: the roles of a running coalition rotate two ticks after admission."""
    from agspec.interp import rules

    orig = rules.complete_activities

    def complete_activities(state, model, events):
        n = orig(state, model, events)
        for act in state.activities:
            if act.kind == "operation" and len(act.roles) >= 2 and act.start == state.t - 2 and act.end > state.t:
                names = [r for _, r in act.roles]
                act.roles = tuple(zip([m for m, _ in act.roles], names[1:] + names[:1]))  # BUG
                for m, r in act.roles:
                    state.robots[m].role_label = r
        return n

    rules.complete_activities = complete_activities


# =============================================================================================
# recipe logic


@mutant("predecessor-ignored", "RC-PRECEDENCE / INV-RECIPE", "fail",
        ("INV-RECIPE", "INV-OBSERVATION", "/observations/*/mask",
         "/observations/*/operation_options"),
        Workload("gate-2x2-flat.json", "random", 40, seed=2), "INV-RECIPE")
def predecessor_ignored(session: Session) -> None:
    """Predecessor ignored: readiness checks material only, not the operation's `after` entries."""
    from agspec.interp import candidates

    candidates.predecessors_done = lambda product, op, model: True  # BUG


@mutant("xor-not-closed", "R-XOR-CLOSURE / INV-RECIPE", "fail", ("INV-RECIPE", "/state/products/*/xor"),
        Workload("xor-2x2-flat.json", "greedy", 10), "INV-RECIPE")
def xor_not_closed(session: Session) -> None:
    """XOR sibling not closed: admitting an alternative does not record the group's choice."""
    from agspec.interp import rules

    orig = rules.admit

    def admit(state, model, cand, proposal, events):
        act = orig(state, model, cand, proposal, events)
        if cand.op.xor_group is not None:
            state.products[cand.pid].xor_choice.pop(cand.op.xor_group, None)  # BUG
        return act

    rules.admit = admit


@mutant("deliver-early", "R-DELIVERY / INV-ACCOUNTING", "fail",
        ("INV-ACCOUNTING", "/state/delivered", "/state/products/*/delivered_at"),
        Workload("solo-1x2-flat.json", "greedy", 12), "INV-ACCOUNTING")
def deliver_early(session: Session) -> None:
    """Delivery before completion: the product counts as delivered when the delivery starts."""
    from agspec.interp import rules

    orig_start = rules.start_deliveries

    def start_deliveries(state, model, cells, events):
        before = {a.aid for a in state.activities}
        orig_start(state, model, cells, events)
        for act in state.activities:
            if act.kind == "deliver" and act.aid not in before:
                product = state.products[act.product]
                product.delivered, product.complete_time = True, state.t  # BUG: at start
                state.delivered += 1

    def complete_delivery(state, act, events):
        (cell,) = act.members
        state.robots[cell].holding = None
        state.item_holder.pop(act.item, None)
        events.append({"type": "delivered", "activity": act.aid, "product": act.product,
                       "robot": f"{cell[0]},{cell[1]}"})

    rules.start_deliveries = start_deliveries
    rules.complete_delivery = complete_delivery


# =============================================================================================
# resources, accounting, durations


@mutant("resource-over-capacity", "R-JOINT-ADMISSIBLE / INV-EXCLUSIVITY", "fail",
        ("INV-EXCLUSIVITY",),
        Workload("bench-3x2-flat.json", "greedy", 10), "INV-EXCLUSIVITY")
def resource_over_capacity(session: Session) -> None:
    """Resource over capacity: a finite resource counts as exhausted only once MORE units than it has are used."""
    from agspec.interp import rules

    def exhausted(state, model, resources):
        for r in resources:
            used = sum(1 for a in state.activities if r in a.resources)
            if used > model.resource_cap(r):  # BUG: should be >=
                return True
        return False

    rules.exhausted = exhausted


@mutant("wip-drift", "R-RELEASE / INV-ACCOUNTING", "fail", ("INV-ACCOUNTING", "/state/wip"),
        Workload("solo-1x2-flat.json", "greedy", 12), "INV-ACCOUNTING")
def wip_drift(session: Session) -> None:
    """WIP count drift: the WIP counter is not decremented when a delivery completes."""
    from agspec.interp import rules
    from agspec.interp.state import State

    State.wip = property(lambda s: s.released - s.delivered + int(s.counters.get("_wip_drift", 0)))
    orig = rules.complete_delivery

    def complete_delivery(state, act, events):
        orig(state, act, events)
        state.counters["_wip_drift"] = state.counters.get("_wip_drift", 0) + 1  # BUG

    rules.complete_delivery = complete_delivery


@mutant("duration-round", "G-DURATION", "fail",
        ("/state/activities/*/retreat", "/state/activities/*/end",
         "/state/robots/*/busy_until"),
        Workload("solo-2x3-motion.json", "greedy", 4))
def duration_round(session: Session) -> None:
    """Wrong duration rounding: the retreat is round(f_ret * A) instead of ceil(f_ret * A)."""
    from agspec.interp import geometry

    orig = geometry.plan_activity

    def plan_activity(members, process, profile, *, common_target=None, **memo):
        plan = orig(members, process, profile, common_target=common_target, **memo)
        if plan is None or not profile.get("motion_planning", True):
            return plan
        retreat = round(float(profile["retreat_fraction"]) * plan.approach)  # BUG: round, not ceil
        return dataclasses.replace(plan, retreat=retreat, duration=max(1, plan.approach + plan.process + retreat))

    geometry.plan_activity = plan_activity


# =============================================================================================
# observations and masks


@mutant("obs-leak", "O-OBSERVATION / INV-OBSERVATION", "fail", ("INV-OBSERVATION", "/observations/*/neighbours"),
        Workload("catalogue:flow-easy:0", "greedy", 3), "INV-OBSERVATION")
def obs_leak(session: Session) -> None:
    """Observation leaking remote robots: neighbour entries are listed out to Chebyshev distance 2."""
    from agspec.interp import observe, tick
    from agspec.interp.state import cell_id

    orig = observe.observation

    def observation(state, model, cell, options, mask, views=None):
        obs = orig(state, model, cell, options, mask, views)
        for other in sorted(state.robots):
            dist = max(abs(other[0] - cell[0]), abs(other[1] - cell[1]))
            if dist == 2:  # BUG: radius 2
                nb = state.robots[other]
                obs["neighbours"].append({"dir": "far", "robot": cell_id(other),
                                          "holding": observe._held(state, model, other), "busy": not nb.free(state.t),
                                          "failed": False, "op": nb.op_label, "role": nb.role_label})
        return obs

    tick.observation = observation


@mutant("mask-hides", "O-MASK / INV-MASKING", "fail", ("INV-MASKING", "/observations/*/mask", "/masks"),
        Workload("catalogue:flow-easy:0", "greedy", 3), "INV-MASKING")
def mask_hides(session: Session) -> None:
    """Mask hiding a legal local action: receiving from a diagonal neighbour is masked out."""
    from agspec.interp import observe, tick

    orig = observe.action_masks  # every robot's O-MASK of an epoch, as the transition asks for them

    def action_masks(state, model, options, last=None):
        out = {}
        for cell, mask in orig(state, model, options, last).items():
            mask = list(mask)  # masks are immutable tuples
            for d in (1, 3, 5, 7):  # BUG: von Neumann thinking on a Moore grid
                mask[observe.RECEIVE0 + d] = False
            out[cell] = tuple(mask)
        return out

    tick.action_masks = action_masks


@mutant("topology-ignored", "D-TOPOLOGY / O-MASK / INV-MASKING", "fail",
        ("INV-MASKING", "INV-OBSERVATION", "/observations/*/mask", "/observations/*/neighbours", "/masks"),
        Workload("duo-2x2-vn-flat.json", "random", 4), "INV-MASKING")
def topology_ignored(session: Session) -> None:
    """Topology ignored: every grid is read as Moore radius 1 (G_manip, G_handoff, G_obs), whatever
    its `topology` and `radius`."""
    from agspec.ir import topology

    for name in ("manipulation_graph", "handoff_graph", "observation_graph"):
        orig = getattr(topology, name)
        setattr(topology, name, lambda rows, cols, *_, _orig=orig: _orig(rows, cols, "moore", 1))  # BUG


# =============================================================================================
# variant parameters hard-coded: the official value instead of the instance's (S-RULE-VARIANTS,
# PR-VARIANT, PR-ABSTRACT-V1, S-COORDINATION, S-SHELVES, S-EVALUATION, RC-RESOURCES)


def _set(document: str, path: str, value: Any) -> Callable[[dict], None]:
    def edit(inst: dict) -> None:
        holder = inst[document]
        *parents, key = path.split("/")
        for p in parents:
            holder = holder[p]
        holder[key] = value

    return edit


# a divergence anywhere in a reply: which part shows first depends on the item that catches the mutant
ANY_PART = ("/state", "/events", "/observations", "/masks", "/done")

for _name, _doc, _path, _value, _breaks in (
    ("hardcode-rho-conf", "profile", "rho_conf", 0.25, "PR-VARIANT (rho_conf)"),
    ("hardcode-spacing", "profile", "spacing", 1.0, "PR-VARIANT (spacing)"),
    ("hardcode-role-offset", "profile", "role_target_offset", 0.12, "G-ROLE-TARGET (offset)"),
    ("hardcode-reach", "profile", "reach", 1.5, "G-REACH (reach)"),
    ("hardcode-clearance", "profile", "clearance", 0.1, "G-CONFLICT (clearance)"),
    ("hardcode-speed", "profile", "speed", 1.0, "G-MOTION (speed)"),
    ("hardcode-joint-speed", "profile", "joint_speed", 1.0, "G-MOTION (joint speed)"),
    ("hardcode-retreat", "profile", "retreat_fraction", 0.25, "G-DURATION (retreat fraction)"),
    ("hardcode-pick-duration", "profile", "durations/pick", 2, "G-DURATION (pick)"),
    ("hardcode-handoff-duration", "profile", "durations/handoff", 1, "G-DURATION (handoff)"),
    ("hardcode-deliver-duration", "profile", "durations/deliver", 2, "G-DURATION (deliver)"),
    ("hardcode-motion-planning", "profile", "motion_planning", True, "S-RULE-VARIANTS (motion_planning)"),
    ("hardcode-trajectory-conflicts", "profile", "trajectory_conflicts", True,
     "S-RULE-VARIANTS (trajectory_conflicts)"),
    ("hardcode-support-visible", "scenario", "coordination/support_visible", True,
     "S-RULE-VARIANTS (support_visible)"),
    ("hardcode-support-timeout", "scenario", "coordination/support_timeout", 3, "R-SUPPORT-LIFECYCLE (timeout)"),
    ("hardcode-switch-lock", "scenario", "coordination/switch_lock", 1, "R-SWITCH-LOCK (lock)"),
    ("hardcode-shelf-capacity", "scenario", "shelves/capacity", 6, "R-REPLENISH (capacity)"),
    ("hardcode-replenish", "scenario", "shelves/replenish_interval", 5, "R-REPLENISH (interval)"),
):
    hard_coded(_name, _breaks, ANY_PART, f"Hard-coded {_path.replace('/', '.')} = {_value}: the instance's value "
                                         "is never read.", _set(_doc, _path, _value))


def _tied_switches(inst: dict) -> None:
    inst["profile"]["trajectory_conflicts"] = inst["profile"].get("motion_planning", True)


hard_coded("geometry-switches-tied", "S-RULE-VARIANTS (one switch)", ANY_PART,
           "The two geometry switches read as one: trajectory conflicts follow motion planning.", _tied_switches)


def _resources_exclusive(inst: dict) -> None:
    names = {k for r in inst["recipes"].values() for k in r.get("resources") or {}}
    inst["scenario"]["resources"] = {k: 1 for k in names | set(inst["scenario"].get("resources") or {})}


hard_coded("resources-exclusive", "RC-RESOURCES (capacity)", ANY_PART,
           "Every resource exclusive: declared capacities (2, 0, ...) are read as 1.", _resources_exclusive)


def _recipe_capacities(inst: dict) -> None:
    declared = {k for r in inst["recipes"].values() for k in r.get("resources") or {}}
    inst["scenario"]["resources"] = {k: c for k, c in (inst["scenario"].get("resources") or {}).items()
                                     if k not in declared}


hard_coded("scenario-resources-ignored", "S-RESOURCES (override)", ANY_PART,
           "The scenario's resource capacities are ignored: the recipes' apply.", _recipe_capacities)


def _batch_ignored(inst: dict) -> None:
    ev = inst["scenario"]["evaluation"]
    if ev.get("mode") == "batch":
        inst["scenario"]["evaluation"] = {"mode": "continuing", "horizon": ev["timeout"]}


hard_coded("batch-ignored", "S-EVALUATION (batch)", ANY_PART,
           "Batch mode ignored: releases go on after Z products and the run ends only at the timeout.",
           _batch_ignored)


# =============================================================================================
# robustness: the process misbehaves on the wire


def _at_step(t: int, fn: Callable[[], None]) -> Callable[[dict, Session], None]:
    def hook(msg: dict, session: Session) -> None:
        if session.sim is not None and session.sim.t == t:
            fn()

    return hook


def _step_reply(session: Session, t: int, corrupt: Callable[[dict], Any]) -> None:
    """Replace the reply whose ``t`` is ``t`` (the step of epoch t - 1) by ``corrupt(reply)``."""

    def reply(msg: dict, rep: dict) -> Any:
        return corrupt(rep) if msg.get("cmd") == "step" and rep.get("t") == t else rep

    session.after.append(reply)


def _die() -> None:
    sys.stderr.write("mutant crash: segmentation fault (simulated)\n")
    sys.stderr.flush()
    os._exit(139)


@mutant("crash", "F-PROTOCOL (crash)", "error", ("crash/exit", "crash/eof"),
        Workload("catalogue:flow-easy:0", "greedy", 6))
def crash(session: Session) -> None:
    """A crash: the process exits without replying to the step of epoch 3."""
    session.on("step", _at_step(3, _die))


@mutant("hang", "F-PROTOCOL (timeout)", "error", ("timeout",), Workload("catalogue:flow-easy:0", "greedy", 6))
def hang(session: Session) -> None:
    """A hang: the process sleeps forever on the step of epoch 2."""
    session.on("step", _at_step(2, lambda: time.sleep(10**6)))


@mutant("garbage", "F-PROTOCOL (malformed reply)", "error", ("protocol/malformed_json",),
        Workload("catalogue:flow-easy:0", "greedy", 6))
def garbage(session: Session) -> None:
    """Garbage output: the reply to the step of epoch 1 is not JSON."""
    _step_reply(session, 2, lambda rep: "Segmentation fault (core dumped) {'t': 2, ok: yes")


@mutant("wrong-seq", "F-PROTOCOL (seq not echoed)", "error", ("protocol/wrong_seq",),
        Workload("catalogue:flow-easy:0", "greedy", 6))
def wrong_seq(session: Session) -> None:
    """Wrong seq: the reply to the step of epoch 2 echoes a different seq."""
    _step_reply(session, 3, lambda rep: {**rep, "seq": ["not", "the", "seq", rep.get("seq")]})


# =============================================================================================
# verdicts: capabilities, levels, malformed numbers and nesting, nondeterminism (F-CONFORM-LEVELS,
# F-PROTOCOL-ERRORS, F-CONFORM-NONDETERMINISM)


@mutant("events-only-state-lie", "F-CONFORM-LEVELS (state not proven)", "level", ("level:state",),
        Workload("pair-1x2-flat.json", "greedy", 12))
def events_only_state_lie(session: Session) -> None:
    """Declares events only and sends a state whose `delivered` is wrong: proven at level events, never `state`."""
    session.capabilities.update(privileged_state=False, observations=False, masks=False)

    def reply(msg: dict, rep: dict) -> Any:
        if msg.get("cmd") in ("reset", "step") and rep.get("ok") and session.sim is not None:
            from agspec.interp.snapshot import global_state

            state = global_state(session.sim.state)
            state["delivered"] += 1  # BUG: the undeclared state lies
            return {**rep, "state": state}
        return rep

    session.after.append(reply)


@mutant("non-finite", "F-PROTOCOL-ERRORS (NaN in a reply)", "error", ("protocol/non_finite",),
        Workload("catalogue:flow-easy:0", "greedy", 6))
def non_finite(session: Session) -> None:
    """A NaN in the state of the reply to the step of epoch 1 (a bare `NaN` on the wire)."""
    _step_reply(session, 2, lambda rep: json.dumps({**rep, "state": {**rep["state"], "wip": float("nan")}},
                                                   separators=(",", ":")))


@mutant("deep-nesting", "F-PROTOCOL-ERRORS (nesting)", "error", ("protocol/too_deep",),
        Workload("catalogue:flow-easy:0", "greedy", 6))
def deep_nesting(session: Session) -> None:
    """The reply to the step of epoch 1 carries an event nested 200,000 arrays deep."""

    def nest(rep: dict) -> str:
        head = json.dumps({k: v for k, v in rep.items() if k != "events"}, separators=(",", ":"))[:-1]
        return head + ',"events":' + "[" * 200_000 + "]" * 200_000 + "}"

    _step_reply(session, 2, nest)


@mutant("rounded-support", "O-SUPPORT-FRACTION", "fail", ("/observations/*/operation_options/*/support",),
        Workload("helped-3x2-flat.json", "random", 20, seed=0))
def rounded_support(session: Session) -> None:
    """Support fraction rounded to two decimals (1/3 -> 0.33): exact for 1/2 and 1/4, wrong for thirds."""
    from agspec.interp import observe, tick

    orig = observe.observation

    def observation(state, model, cell, options, mask, views=None):
        obs = orig(state, model, cell, options, mask, views)
        for opt in obs["operation_options"]:
            opt["support"] = round(opt["support"], 2)  # BUG: a formatting shortcut
        return obs

    tick.observation = observation


_FIRST_EPISODE = {"done": False}
COIN_ENV = "AGSPEC_MUTANT_COIN"  # a directory of tickets, one per simulator process (see _first_process)


def _first_process() -> bool:
    """Whether this process took the first ticket in the coin directory (``$AGSPEC_MUTANT_COIN``, else one
    per parent process): a stand-in for a simulator seeded by its pid or the clock, whose every process
    may answer differently — deterministic here, so that the test that uses it is."""
    directory = Path(os.environ.get(COIN_ENV) or Path(tempfile.gettempdir()) / f"agspec-coin-{os.getppid()}")
    directory.mkdir(parents=True, exist_ok=True)
    n = 0
    while True:
        try:
            os.close(os.open(directory / f"ticket-{n}", os.O_CREAT | os.O_EXCL | os.O_WRONLY))
            return n == 0
        except FileExistsError:
            n += 1


@mutant("nondeterministic", "F-CONFORM-NONDETERMINISM", "fail", ("nondeterministic",),
        Workload("pair-1x2-flat.json", "greedy", 8))
def nondeterministic(session: Session) -> None:
    """Diverges (WIP off by one after tick 2) in the first episode of the first of its processes only: a
    replay of its reproducer in a fresh process, alone or after the same history, does not reproduce it."""
    first = _first_process()

    def reply(msg: dict, rep: dict) -> Any:
        if msg.get("cmd") == "step" and rep.get("t") == 3 and first and not _FIRST_EPISODE["done"]:
            _FIRST_EPISODE["done"] = True
            return {**rep, "state": {**rep["state"], "wip": rep["state"]["wip"] + 1}}
        return rep

    session.after.append(reply)


# =============================================================================================
# honest simulators that implement less than everything: they must pass at their level


@dataclass(frozen=True)
class Honest:
    name: str
    level: str  # the conformance level (F-CONFORM-LEVELS) the harness must report for it
    description: str
    apply: Callable[[Session], None]
    workload: Workload
    skips: int = 0  # items the harness must skip on its workload (F-PROTOCOL-UNSUPPORTED)


HONEST: dict[str, Honest] = {}


def honest(name: str, level: str, workload: Workload, skips: int = 0):
    def register(fn: Callable[[Session], None]) -> Callable[[Session], None]:
        HONEST[name] = Honest(name, level, (fn.__doc__ or "").strip().splitlines()[0], fn, workload, skips)
        return fn

    return register


@honest("state-only", "state", Workload("pair-1x2-flat.json", "greedy", 24))
def state_only(session: Session) -> None:
    """Privileged state only, no events: its handoffs start and complete within one tick (zero approach)."""
    session.capabilities.update(events=False, observations=False, masks=False)


@honest("no-events", "state+observations+masks", Workload("pair-1x2-flat.json", "greedy", 24))
def no_events(session: Session) -> None:
    """State, observations and masks, but no events (and so no `applied`): coercions are not reported."""
    session.capabilities.update(events=False)


@honest("events-only", "events", Workload("pair-1x2-flat.json", "greedy", 24))
def events_only(session: Session) -> None:
    """Events only: no state, observations or masks."""
    session.capabilities.update(privileged_state=False, observations=False, masks=False)


@honest("own-bookkeeping", "full", Workload("pair-1x2-flat.json", "greedy", 24))
def own_bookkeeping(session: Session) -> None:
    """Same behaviour, own bookkeeping: no switch lock is 0 (not -1), an idle robot's busy_until is 0, no poses,
    an activity's phases are not split."""
    session.capabilities["diagnostic_state"] = False

    def reply(msg: dict, rep: dict) -> Any:
        state = rep.get("state") if isinstance(rep, dict) else None
        if state:
            for r in state["robots"].values():
                r["switch_lock"] = max(0, r["switch_lock"])
                r["busy_until"] = r["busy_until"] if r["busy_until"] > state["t"] else 0
                r["ee"], r["q"] = [0.0, 0.0], []
            for a in state["activities"]:  # phases folded into one: only start and end are behaviour
                a["approach"], a["process"], a["retreat"] = 0, a["end"] - a["start"], 0
        return rep

    session.after.append(reply)


@honest("official-only", "full", Workload("catalogue:flow-easy:0", "greedy", 6), skips=1)
def official_only(session: Session) -> None:
    """Implements only the official catalogue instances: answers `unsupported` to any other instance."""
    session.refuse = lambda inst: (None if str(inst.get("id", "")).startswith("ag32-")
                                   else "only the official AssemblyGrid v1 catalogue instances are implemented")


def apply_honest(name: str, session: Session) -> None:
    if name not in HONEST:
        raise KeyError(f"unknown honest variant {name!r}; known: {', '.join(sorted(HONEST))}")
    HONEST[name].apply(session)


def apply(name: str, session: Session) -> None:
    if name not in MUTANTS:
        raise KeyError(f"unknown mutant {name!r}; known: {', '.join(sorted(MUTANTS))}")
    MUTANTS[name].apply(session)
