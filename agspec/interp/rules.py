"""The AssemblyGrid v1 transition rules, one function per rule ID of spec/05-transition.md.

:mod:`agspec.interp.tick` calls them in the order of R-TICK-ORDER.  Each function mutates the
:class:`~agspec.interp.state.State` it is given and appends plain-dict events to ``events``.
"""

from __future__ import annotations

from typing import Any, Iterable

from agspec.interp import geometry
from agspec.interp.candidates import Candidate
from agspec.interp.model import Model
from agspec.interp.state import Activity, Cell, Product, Proposal, State, cell_id

Events = list[dict[str, Any]]


def bump(state: State, name: str, by: float = 1) -> None:
    state.counters[name] = state.counters.get(name, 0) + by


# --------------------------------------------------------------------------- conflicts and blocking


def geometric_conflict(model: Model, plan_a, target_a, members_a, plan_b, target_b, members_b) -> bool:
    """G-CONFLICT between two motion plans (only when the profile checks trajectory conflicts)."""
    rho_conf, clearance, segments = model.conflict_parameters
    return geometry.plans_conflict(plan_a, plan_b, rho_conf, clearance, segments=segments)


def shares_exclusive(model: Model, res_a: Iterable[str], res_b: Iterable[str]) -> bool:
    common = frozenset(res_a).intersection(res_b)  # usually empty: no generator for it
    return bool(common) and any(model.resource_cap(r) <= 1 for r in common)


def exhausted(state: State, model: Model, resources: Iterable[str]) -> bool:
    """Resource: a finite-capacity resource already used by as many committed activities as it has units."""
    for r in resources:
        cap = model.resource_cap(r)
        used = sum(1 for a in state.activities if r in a.resources)
        if used >= cap:
            return True
    return False


def blocking_cause(state: State, model: Model, members, resources, plan, target) -> str | None:
    """R-BLOCKING: why an activity cannot start against the committed activities, or None.

    Reservations are scanned in creation order; the first one sharing a robot gives "robot", the first
    one sharing an exclusive resource gives "resource"; otherwise exhaustion of a finite-capacity
    resource gives "resource"; otherwise any geometric conflict gives "geometry".
    """
    members = set(members)
    geo = False
    for act in state.activities:
        if not members.isdisjoint(act.members):
            return "robot"
        if shares_exclusive(model, resources, act.resources):
            return "resource"
        if not geo and geometric_conflict(model, plan, target, members, act.plan, act.target, act.members):
            geo = True
    # capacity-1 resources were handled by the sharing test; others (including capacity 0, which
    # makes a resource unusable: S-RESOURCES) block once all their units are in use
    if exhausted(state, model, [r for r in resources if model.resource_cap(r) != 1]):
        return "resource"
    return "geometry" if geo else None


def count_block(state: State, cause: str, events: Events, what: dict[str, Any]) -> None:
    """M-BLOCKED: one blocked-activity event per blocked start attempt, with exactly one cause."""
    bump(state, "trajectory_conflict_count")
    bump(state, f"{cause}_block_count")
    events.append({"type": "blocked", "cause": cause, **what})


def start_activity(state: State, model: Model, act: Activity) -> None:
    """R-EXECUTION: commit the members for D ticks and reserve the activity's resources."""
    state.activities.append(act)
    state.next_seq += 1
    for m in act.members:
        robot = state.robots[m]
        robot.busy_until = act.end
        robot.activity = act.aid
    plan = act.plan
    bump(state, "geometry_delay_ticks", plan.approach + plan.retreat)
    bump(state, "motion_duration_total", plan.duration)
    bump(state, "motion_path_length", plan.path_length)
    margin = state.counters.get("minimum_reach_margin")
    if margin is None or plan.min_reach_margin < margin:
        state.counters["minimum_reach_margin"] = plan.min_reach_margin


# --------------------------------------------------------------------------- R-PICK


def start_picks(state: State, model: Model, picks: list[tuple[Cell, dict]], events: Events) -> None:
    """R-PICK: input-column robots start the picks they chose, in row-major order.

    A pick that is no longer possible (another robot took the same option earlier in this epoch)
    is dropped silently; one that conflicts with a committed activity is a blocked event.
    """
    t = state.t
    for cell, option in sorted(picks, key=lambda p: p[0]):
        robot = state.robots[cell]
        product = state.products[option["product"]]
        token, row = option["token"], option["shelf_row"]
        if (
            token in product.raw_taken
            or product.delivered
            or not robot.free(t)
            or robot.holding is not None
            or state.shelves[row].get(token, 0) <= 0
        ):
            continue
        spacing = float(model.profile["spacing"])
        target = geometry.shelf_point(row, spacing)
        plan = model.plans.plan([(cell, robot.pose, target)], model.pick_duration, target)  # G-MOTION
        if plan is None:
            continue
        resources = frozenset({f"shelf:{row}:{token}"})
        cause = blocking_cause(state, model, (cell,), resources, plan, target)
        what = {"kind": "pick", "robot": cell_id(cell), "product": product.pid, "token": token}
        if cause is not None:
            count_block(state, cause, events, what)
            continue
        state.shelves[row][token] -= 1
        product.raw_taken.add(token)
        act = Activity(
            aid=f"pick@{t}:{product.pid}:{token}:{cell_id(cell)}",
            kind="pick",
            members=(cell,),
            resources=resources,
            plan=plan,
            target=target,
            start=t,
            end=t + plan.duration,
            seq=state.next_seq,
            product=product.pid,
            item=(product.pid, token),
            shelf_row=row,
        )
        start_activity(state, model, act)
        robot.op_label = "pick"
        events.append({"type": "pick_started", "activity": act.aid, **what, "shelf_row": row, "end": act.end})


# --------------------------------------------------------------------------- R-HANDOFF


def start_handoffs(state: State, model: Model, sends: dict[Cell, int], receives: dict[Cell, int], events: Events) -> None:
    """R-HANDOFF: a transfer starts only on matching handoff(v) by u and receive(u) by v.

    Senders are processed in row-major order; the receiver must be the sender's G_handoff neighbour in
    the chosen direction (D-TOPOLOGY); both robots must be free, the sender holding, the receiver
    empty, neither already in a transfer started this epoch; the plan targets the midpoint of the two
    bases (G-HANDOFF-POINT) with the profile's handoff duration.
    """
    t = state.t
    engaged: set[Cell] = set()
    spacing = float(model.profile["spacing"])
    for sender_cell in sorted(sends):
        partner = model.handoff_partner.get((sender_cell, sends[sender_cell]))
        if partner is None:  # clause 1: no robot in that direction, or not a G_handoff neighbour
            continue
        recv_cell, back = partner
        if receives.get(recv_cell) != back:
            continue
        sender, receiver = state.robots[sender_cell], state.robots[recv_cell]
        if sender_cell in engaged or recv_cell in engaged:
            continue
        if not (sender.free(t) and receiver.free(t) and sender.holding is not None and receiver.holding is None):
            continue
        item = sender.holding
        if state.products[item[0]].mass > float(model.profile.get("payload", 10.0)):
            continue  # condition 4, RES-PAYLOAD-CHECKS: never binds on a valid instance (AG459)
        target = geometry.handoff_point(sender_cell, recv_cell, spacing)
        plan = model.plans.plan(  # G-MOTION
            [(sender_cell, sender.pose, target), (recv_cell, receiver.pose, target)], model.handoff_duration, target
        )
        if plan is None:
            continue
        resources = frozenset({f"token:{item[0]}:{item[1]}"})
        what = {"kind": "handoff", "sender": cell_id(sender_cell), "receiver": cell_id(recv_cell), "item": f"{item[0]}:{item[1]}"}
        cause = blocking_cause(state, model, (sender_cell, recv_cell), resources, plan, target)
        if cause is not None:
            count_block(state, cause, events, what)
            continue
        engaged.update((sender_cell, recv_cell))
        act = Activity(
            aid=f"handoff@{t}:{item[0]}:{item[1]}:{cell_id(sender_cell)}>{cell_id(recv_cell)}",
            kind="handoff",
            members=(sender_cell, recv_cell),
            resources=resources,
            plan=plan,
            target=target,
            start=t,
            end=t + plan.duration,
            seq=state.next_seq,
            product=item[0],
            item=item,
            sender=sender_cell,
            receiver=recv_cell,
        )
        start_activity(state, model, act)
        receiver.incoming = item
        sender.op_label, receiver.op_label = "handoff_send", "handoff_receive"
        events.append({"type": "handoff_started", "activity": act.aid, **what, "end": act.end})


# --------------------------------------------------------------------------- R-SUPPORT


def record_supports(state: State, model: Model, supports: dict[Cell, Candidate], events: Events) -> None:
    """R-SUPPORT: record each robot's support, in row-major order.

    Supporting a different candidate withdraws the previous support first (a candidate switch).
    The first supporter of a candidate creates its proposal with a clock of its own
    (R-SUPPORT-LIFECYCLE); re-selecting the same candidate refreshes neither clock nor lock.
    """
    t = state.t
    for cell in sorted(supports):
        cand = supports[cell]
        robot = state.robots[cell]
        if robot.supports == cand.cid:
            continue  # no refresh (R-SUPPORT-LIFECYCLE)
        if robot.supports is not None:
            old = state.proposals.get(robot.supports)
            if old is not None:
                old.votes.discard(cell)
            bump(state, "team_proposal_churn")
            events.append({"type": "support_switched", "robot": cell_id(cell), "from": robot.supports, "to": cand.cid})
        proposal = state.proposals.get(cand.cid)
        if proposal is None:
            proposal = Proposal(cid=cand.cid, created_at=t, expires_at=t + model.support_timeout)
            state.proposals[cand.cid] = proposal
            events.append({"type": "proposal_created", "candidate": cand.cid, "expires_at": proposal.expires_at})
        proposal.votes.add(cell)
        robot.supports = cand.cid
        robot.switch_lock = t + model.switch_lock  # R-SWITCH-LOCK
        events.append({"type": "support", "robot": cell_id(cell), "candidate": cand.cid})


# --------------------------------------------------------------------------- R-ADMISSION


def admit_candidates(state: State, model: Model, by_id: dict[str, Candidate], events: Events) -> int:
    """R-ADMISSION / R-JOINT-ADMISSIBLE: admit fully supported candidates in ascending id-string order.

    Returns the number of admissions.  Conflicts with a candidate admitted earlier in the same
    epoch are simultaneous arbitration and not counted; conflicts with other committed activities
    are blocked-activity events (M-BLOCKED).
    """
    t = state.t
    admitted_now: list[Activity] = []
    admissions = 0
    for cid in sorted(state.proposals):
        proposal = state.proposals[cid]
        cand = by_id.get(cid)
        if cand is None or proposal.votes != set(cand.members):
            continue
        if any(state.robots[m].supports != cid for m in cand.members):
            continue
        if any(
            set(cand.members) & set(a.members)
            or shares_exclusive(model, cand.resources, a.resources)
            or geometric_conflict(model, cand.plan, cand.target, cand.members, a.plan, a.target, a.members)
            for a in admitted_now
        ):
            continue  # same-epoch arbitration: the earlier candidate in canonical order wins
        cause = blocking_cause(state, model, cand.members, cand.resources, cand.plan, cand.target)
        if cause is not None:
            count_block(state, cause, events, {"kind": "operation", "candidate": cid})
            continue
        if any(not state.robots[m].free(t) for m in cand.members):
            continue
        product = state.products[cand.pid]
        if cand.op.id in product.in_progress or cand.op.id in product.completed:
            continue
        group = cand.op.xor_group
        if group is not None and product.xor_choice.get(group) not in (None, cand.op.id):
            continue  # RC-XOR: the route was already chosen
        act = admit(state, model, cand, proposal, events)
        admitted_now.append(act)
        admissions += 1
    return admissions


def admit(state: State, model: Model, cand: Candidate, proposal: Proposal, events: Events) -> Activity:
    """Create the activity of an admitted candidate; members, roles and site are fixed (INV-LIFETIME)."""
    t = state.t
    product = state.products[cand.pid]
    state.next_team += 1
    act = Activity(
        aid=f"op@{t}:{cand.cid}",  # R-IDS: start epoch + candidate key identify an activity
        kind="operation",
        members=cand.members,
        resources=cand.resources,
        plan=cand.plan,
        target=cand.target,
        start=t,
        end=t + cand.plan.duration,
        seq=state.next_seq,
        product=cand.pid,
        operation=cand.op.id,
        op_type=cand.op.type,
        candidate=cand.cid,
        roles=cand.roles,
        first_proposed_at=proposal.created_at,
    )
    start_activity(state, model, act)
    product.in_progress.add(cand.op.id)
    if cand.op.xor_group is not None:
        product.xor_choice[cand.op.xor_group] = cand.op.id  # RES-XOR-AT-ADMISSION
    for member, role in cand.roles:
        robot = state.robots[member]
        robot.supports = None
        robot.op_label, robot.role_label = cand.op.type, role
        robot.team_participations += 1
    del state.proposals[cand.cid]
    bump(state, "team_formation_count")
    bump(state, "team_size_sum", cand.size)
    bump(state, "team_formation_latency_sum", t - proposal.created_at)
    bump(state, "progress_events")
    if cand.size >= 2:
        bump(state, "coalition_formation_count")
        bump(state, "coalition_formation_latency_sum", t - proposal.created_at)
    events.append({"type": "admitted", "candidate": cand.cid, "activity": act.aid, "end": act.end,
                   "latency": t - proposal.created_at})
    return act


def drop_proposal(state: State, proposal: Proposal, reason: str, events: Events) -> None:
    """Remove a proposal; one that still has support counts as a failed attempt (M-ADMISSION-FAILURES)."""
    del state.proposals[proposal.cid]
    for cell in proposal.votes:
        if state.robots[cell].supports == proposal.cid:
            state.robots[cell].supports = None
    if proposal.votes:
        bump(state, "team_formation_failures")
        bump(state, "reject_unmatched_proposal")
        if len(proposal.cid.rsplit(":", 1)[1].split(";")) >= 2:
            bump(state, "coalition_formation_failures")
        events.append({"type": "admission_failed", "candidate": proposal.cid, "reason": reason})
    else:
        events.append({"type": "proposal_abandoned", "candidate": proposal.cid})


def expire_invalid_proposals(state: State, valid_ids: set[str], events: Events) -> None:
    """R-EXPIRY (in-epoch): after admission, drop proposals whose candidate no longer exists or expired."""
    for cid in sorted(state.proposals):
        proposal = state.proposals[cid]
        if cid not in valid_ids:  # RES-IN-EPOCH-EXPIRY: validity first; the branch below never fires
            drop_proposal(state, proposal, "invalid", events)
        elif state.t > proposal.expires_at:
            drop_proposal(state, proposal, "expired", events)


def expire_proposals(state: State, events: Events) -> None:
    """R-SUPPORT-LIFECYCLE: after the clock advance, a proposal created at t0 expires at t0 + timeout + 1."""
    for cid in sorted(state.proposals):
        proposal = state.proposals[cid]
        if state.t > proposal.expires_at:
            drop_proposal(state, proposal, "expired", events)


# --------------------------------------------------------------------------- R-DELIVERY


def start_deliveries(state: State, model: Model, deliverers: list[Cell], events: Events) -> None:
    """R-DELIVERY: an output-column robot holding a product's terminal output delivers it."""
    t = state.t
    spacing = float(model.profile["spacing"])
    for cell in sorted(deliverers):
        robot = state.robots[cell]
        item = robot.holding
        if item is None or not robot.free(t) or cell[1] != model.cols - 1:
            continue
        product = state.products[item[0]]
        if item[1] != model.recipes[product.recipe].terminal or product.delivered:
            continue
        target = geometry.output_point(cell[0], model.cols, spacing)
        plan = model.plans.plan([(cell, robot.pose, target)], model.deliver_duration, target)  # G-MOTION
        if plan is None:
            continue
        resources = frozenset({f"product:{product.pid}"})
        what = {"kind": "deliver", "robot": cell_id(cell), "product": product.pid}
        cause = blocking_cause(state, model, (cell,), resources, plan, target)
        if cause is not None:
            count_block(state, cause, events, what)
            continue
        act = Activity(
            aid=f"deliver@{t}:{product.pid}:{cell_id(cell)}",
            kind="deliver",
            members=(cell,),
            resources=resources,
            plan=plan,
            target=target,
            start=t,
            end=t + plan.duration,
            seq=state.next_seq,
            product=product.pid,
            item=item,
        )
        start_activity(state, model, act)
        robot.op_label = "deliver"
        events.append({"type": "delivery_started", "activity": act.aid, **what, "end": act.end})


# --------------------------------------------------------------------------- completions


def complete_activities(state: State, model: Model, events: Events) -> int:
    """R-COMPLETION: apply the effect of every activity ending at t, in creation order.

    Returns the number of progress events (completed picks, handoffs, operations, deliveries).
    """
    t = state.t
    progress = 0
    freed: list[Cell] = []
    for act in [a for a in state.activities if a.end <= t]:
        for m, pose in act.plan.final_poses().items():
            state.robots[m].pose = pose  # G-END-EFFECTOR: the effector stays at its target
        if act.kind == "pick":
            complete_pick(state, act, events)
        elif act.kind == "handoff":
            complete_handoff(state, act, events)
        elif act.kind == "deliver":
            complete_delivery(state, act, events)
        else:
            complete_operation(state, model, act, events)
        progress += 1
        bump(state, "progress_events")
        for m in act.members:
            if state.robots[m].activity == act.aid:
                state.robots[m].activity = None
        freed.extend(act.members)
    # labels are set only on the members of an activity as it starts, and a robot becomes free only
    # when an activity it is a member of completes (R-EXECUTION): those members are the robots that
    # can be labelled and free now
    for cell in freed:
        robot = state.robots[cell]
        if robot.free(t):
            robot.op_label = robot.role_label = None
    return progress


def complete_pick(state: State, act: Activity, events: Events) -> None:
    (cell,) = act.members
    state.robots[cell].holding = act.item
    state.item_holder[act.item] = cell
    events.append({"type": "pick_completed", "activity": act.aid, "robot": cell_id(cell), "item": f"{act.item[0]}:{act.item[1]}"})


def complete_handoff(state: State, act: Activity, events: Events) -> None:
    sender, receiver = state.robots[act.sender], state.robots[act.receiver]
    sender.holding = None
    receiver.holding = act.item
    receiver.incoming = None
    state.item_holder[act.item] = act.receiver
    bump(state, "handoff_count")
    events.append({"type": "handoff_completed", "activity": act.aid, "item": f"{act.item[0]}:{act.item[1]}",
                   "sender": cell_id(act.sender), "receiver": cell_id(act.receiver)})  # F-TRACE-EVENTS


def complete_delivery(state: State, act: Activity, events: Events) -> None:
    (cell,) = act.members
    product = state.products[act.product]
    state.robots[cell].holding = None
    del state.item_holder[act.item]
    product.delivered = True
    product.complete_time = state.t
    state.delivered += 1
    events.append({"type": "delivered", "activity": act.aid, "product": product.pid, "robot": cell_id(cell)})


def output_holder(act: Activity, bound_members: list[Cell]) -> Cell:
    """R-COMPLETION: the output goes to the rightmost, then topmost, input-bound member (else any member)."""
    pool = bound_members or list(act.members)
    return min(pool, key=lambda c: (-c[1], c[0]))


def complete_operation(state: State, model: Model, act: Activity, events: Events) -> None:
    """R-COMPLETION: atomically consume the inputs and create the output (the transition Δτ)."""
    product = state.products[act.product]
    op = model.recipes[product.recipe].op(act.operation)
    bound_roles = {name for name, binds in op.roles if binds is not None}
    bound_members = [m for m, role in act.roles if role in bound_roles]
    for tok in op.inputs:
        item = (product.pid, tok)
        holder = state.item_holder.pop(item)
        state.robots[holder].holding = None
    receiver = output_holder(act, bound_members)
    out = (product.pid, op.output)
    state.robots[receiver].holding = out
    state.item_holder[out] = receiver
    product.in_progress.discard(op.id)
    product.completed.add(op.id)
    events.append({"type": "operation_completed", "activity": act.aid, "product": product.pid, "operation": op.id,
                   "consumed": [f"{product.pid}:{tok}" for tok in op.inputs], "produced": f"{product.pid}:{op.output}",
                   "holder": cell_id(receiver)})


def drop_finished_reservations(state: State) -> None:
    """Reservations whose interval has ended no longer constrain anything."""
    state.activities = [a for a in state.activities if a.end > state.t]


# --------------------------------------------------------------------------- R-REPLENISH, R-RELEASE


def replenish_shelves(state: State, model: Model, events: Events) -> None:
    """R-REPLENISH: every replenish interval, each stocked token gains one unit, up to capacity."""
    if state.t % model.replenish_interval != 0:
        return
    for shelf in state.shelves:
        for token in shelf:
            shelf[token] = min(model.shelf_capacity, shelf[token] + 1)


def release_product(state: State, model: Model, events: Events, forced: bool = False) -> None:
    """R-RELEASE: at each release opportunity, admit the next product if WIP < cap; otherwise it is lost."""
    t = state.t
    if not forced and t % model.release_interval != 0:
        return
    if model.mode == "batch" and state.released >= (model.batch_size or 0):
        return
    state.release_opportunities += 1
    if state.wip >= model.wip_cap:
        state.lost_releases += 1
        events.append({"type": "release_lost", "reason": "wip_cap"})
        return
    realization = model.instance["realization"]["products"]
    if state.released >= len(realization):
        state.lost_releases += 1
        events.append({"type": "release_lost", "reason": "realization_exhausted"})
        return
    spec = realization[state.released]
    recipe = model.recipes[spec["recipe"]]
    if any(state.shelves[int(row)].get(tok, 0) <= 0 for tok, row in spec["source_rows"].items()):
        # Paper: raw-material availability can block a release (DIV-RELEASE-STOCK: the original only
        # checks WIP).  The realization is not consumed, like any lost release.
        state.lost_releases += 1
        state.counters["lost_releases_raw_material"] = state.counters.get("lost_releases_raw_material", 0) + 1
        events.append({"type": "release_lost", "reason": "raw_material"})
        return
    product = Product(
        pid=int(spec["id"]),
        recipe=spec["recipe"],
        spawn_time=t,
        due_time=t + int(spec["due_offset"]),
        mass=float(spec["mass"]),
        value=recipe.value,
        source_rows={k: int(v) for k, v in spec["source_rows"].items()},
    )
    state.products.append(product)
    state.released += 1
    events.append({"type": "release", "product": product.pid, "recipe": product.recipe})
