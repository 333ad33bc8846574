"""Information invariants: INV-OBSERVATION, INV-MASKING (spec chapter 08)."""

from __future__ import annotations

import math

from agspec.formats.actions import DELIVER, DIRECTION_NAMES, HANDOFF0, IDLE, N_ACTIONS, OP0, OP_SLOTS, PICK0
from agspec.formats.actions import PICK_SLOTS, RECEIVE0
from agspec.formats.actions import describe as _action_name
from agspec.invariants.context import NEIGHBOUR_FIELDS, OBS_FIELDS, OPERATION_OPTION_FIELDS, PICK_OPTION_FIELDS
from agspec.invariants.context import REACH_TOLERANCE, SUPPORT_TOLERANCE, Context, Json, StateView, Violation
from agspec.invariants.context import parse_candidate, parse_cell, parse_item, reporter

# --------------------------------------------------------------------------- INV-OBSERVATION


def _held_view(ctx: Context, view: StateView, item: str | None) -> Json | None:
    if item is None:
        return None
    parsed = parse_item(item)
    if parsed is None:
        return {"item": item}
    recipe = ctx.recipe_of(view, parsed[0])
    return {"product": parsed[0], "token": parsed[1], "final": bool(recipe and parsed[1] == recipe.terminal)}


def expected_pick_ids(ctx: Context, view: StateView, robot: str) -> list[str]:
    """O-PICK-OPTIONS recomputed from the state: ids in (release epoch, id string) order."""
    r = view.robots.get(robot) or {}
    cell = parse_cell(robot)
    if cell[1] != 0 or not view.free(robot) or r.get("holding") is not None or r.get("supports") is not None:
        return []
    options = []
    for pid, prod in view.products.items():
        if prod.get("delivered_at") is not None:
            continue
        recipe = ctx.recipes.get(prod.get("recipe"))
        if recipe is None or pid >= len(ctx.realization_products):
            continue
        xor = prod.get("xor") or {}
        needed = {tok for op in recipe.ops.values()
                  if not (op.xor_group and xor.get(op.xor_group) not in (None, op.id)) for tok in op.inputs}
        sources = ctx.realization_products[pid].get("source_rows", {})
        for tok in recipe.raw:
            if tok in prod.get("raw_taken", []) or tok not in needed or tok not in sources:
                continue
            row = int(sources[tok])
            stock = (view.shelves[row] if row < len(view.shelves) else {}).get(tok, 0)
            if cell[0] not in ctx.shelf_access.get(row, ()) or stock <= 0:
                continue
            if math.hypot(0.5 * ctx.spacing, (row - cell[0]) * ctx.spacing) > ctx.reach + REACH_TOLERANCE:
                continue
            options.append((prod.get("released_at", 0), f"pick:{pid}:{tok}:{row}"))
    return [oid for _, oid in sorted(options)]


def _mentioned_robots(obs: Json) -> set[str]:
    out = set()
    if isinstance(obs.get("robot"), str):
        out.add(obs["robot"])
    for nb in obs.get("neighbours") or []:
        if isinstance(nb, dict) and isinstance(nb.get("robot"), str):
            out.add(nb["robot"])
    for opt in obs.get("operation_options") or []:
        if not isinstance(opt, dict):
            continue
        out.update(m for m in opt.get("members") or [] if isinstance(m, str))
        parsed = parse_candidate(str(opt.get("id", "")))
        if parsed:
            out.update(parsed[2])
    if isinstance(obs.get("supports"), str):
        parsed = parse_candidate(obs["supports"])
        if parsed:
            out.update(parsed[2])
    return out


def inv_observation(ctx: Context, prev: Json | None, rec: Json) -> list[Violation]:
    """INV-OBSERVATION: an observation carries exactly the O-OBSERVATION fields of the robot itself, its
    G_obs neighbours (as in the pre-action state) and its own options; operation options contain the
    robot and show support fractions |supporters| / |U_c| of the pre-action state; no supporter
    identities, due dates or remote robots (chapter 6, O-EXPOSURE, O-SUPPORT-FRACTION)."""
    ID = "INV-OBSERVATION"
    observations = rec.get("observations")
    if prev is None:
        return []
    if not observations:
        ctx.skipped.setdefault(ID, "the trace carries no observations")
        return []
    p = ctx.view(prev["state"])
    t = int(rec.get("t", p.t))
    out, bad = reporter(ID, t)

    all_options: dict[str, set[str]] = {}
    for robot, obs in observations.items():
        ctx.count(ID)
        if not isinstance(obs, dict):
            bad(robot, f"observation of {robot} is not an object")
            continue
        keys = set(obs)
        if keys != OBS_FIELDS:
            extra, missing = sorted(keys - OBS_FIELDS), sorted(OBS_FIELDS - keys)
            bad(robot, f"observation of {robot} has fields outside O-OBSERVATION {extra} / lacks {missing}")
        r = p.robots.get(robot)
        if r is None:
            bad(robot, f"observation for unknown robot {robot}")
            continue
        if obs.get("robot") != robot or obs.get("t") != t or obs.get("grid") != [ctx.rows, ctx.cols]:
            bad(robot, f"observation of {robot} is labelled robot={obs.get('robot')} t={obs.get('t')} "
                       f"grid={obs.get('grid')} (expected {robot}, {t}, {[ctx.rows, ctx.cols]})")
        if obs.get("holding") != _held_view(ctx, p, r.get("holding")):
            bad(robot, f"{robot} observes its holding as {obs.get('holding')}, the state has {r.get('holding')}")
        if obs.get("busy") != (not p.free(robot)):
            bad(robot, f"{robot} observes busy={obs.get('busy')}, the state says {not p.free(robot)}")
        if obs.get("supports") != r.get("supports"):
            bad(robot, f"{robot} observes its support as {obs.get('supports')}, the state has {r.get('supports')}")
        # neighbours: exactly the G_obs neighbours, with their state of s_t
        expected_nb = {nid: DIRECTION_NAMES[d] for d, nid in ctx.observation_neighbours(robot)}
        seen_nb = []
        for nb in obs.get("neighbours") or []:
            if not isinstance(nb, dict):
                bad(robot, f"{robot}: malformed neighbour entry {nb!r}")
                continue
            nid = nb.get("robot")
            seen_nb.append(nid)
            if set(nb) != NEIGHBOUR_FIELDS:
                bad(robot, f"{robot}: neighbour entry {nid} has fields {sorted(nb)}, expected {sorted(NEIGHBOUR_FIELDS)}")
            if nid not in expected_nb:
                bad(robot, f"{robot} observes robot {nid}, which is not its G_obs neighbour")
                continue
            if nb.get("dir") != expected_nb[nid]:
                bad(robot, f"{robot}: neighbour {nid} is labelled direction {nb.get('dir')}, expected {expected_nb[nid]}")
            nr = p.robots.get(nid) or {}
            if nb.get("holding") != _held_view(ctx, p, nr.get("holding")):
                bad(robot, f"{robot} observes {nid} holding {nb.get('holding')}, the state has {nr.get('holding')}")
            if nb.get("busy") != (not p.free(nid)):
                bad(robot, f"{robot} observes {nid} busy={nb.get('busy')}, the state says {not p.free(nid)}")
            if (nb.get("op") is None) != p.free(nid):
                bad(robot, f"{robot} observes {nid} with activity label {nb.get('op')!r} although it is "
                           f"{'free' if p.free(nid) else 'busy'}")
        if sorted(seen_nb, key=str) != sorted(expected_nb) or len(seen_nb) != len(set(seen_nb)):
            bad(robot, f"{robot} observes neighbours {seen_nb}, expected exactly {sorted(expected_nb)}")
        # operation options (O-OPERATION-OPTIONS, O-SUPPORT-FRACTION)
        ids = []
        keys_order = []
        for opt in obs.get("operation_options") or []:
            if not isinstance(opt, dict):
                bad(robot, f"{robot}: malformed operation option {opt!r}")
                continue
            cid = str(opt.get("id"))
            ids.append(cid)
            if set(opt) != OPERATION_OPTION_FIELDS:
                bad(cid, f"{robot}: option {cid} has fields {sorted(opt)}, expected {sorted(OPERATION_OPTION_FIELDS)}")
            parsed = parse_candidate(cid)
            if parsed is None:
                bad(cid, f"{robot}: option id {cid!r} is not a candidate id")
                continue
            pid, op_id, members = parsed
            if robot not in members or opt.get("members") != members:
                bad(cid, f"{robot} is offered {cid} with members {opt.get('members')}, which does not contain it "
                         "or does not match the id")
            if opt.get("size") != len(members) or opt.get("product") != pid or opt.get("operation") != op_id:
                bad(cid, f"{robot}: option {cid} reports size {opt.get('size')}, product {opt.get('product')}, "
                         f"operation {opt.get('operation')}, inconsistent with its id")
            pr = p.proposals.get(cid)
            expected = (len(pr.get("supporters", [])) / len(members)) if (pr and members and ctx.support_visible) else 0.0
            got = opt.get("support")
            if not isinstance(got, (int, float)) or abs(got - expected) > SUPPORT_TOLERANCE:
                bad(cid, f"{robot}: support fraction of {cid} is {got}, the pre-action state gives {expected}")
            keys_order.append((-(got if isinstance(got, (int, float)) else 0.0), cid))
        if keys_order != sorted(keys_order):
            bad(robot, f"{robot}: operation options are not ordered by (-support, id): {ids}")
        all_options[robot] = set(ids)
        # pick options (O-PICK-OPTIONS)
        picks = [o.get("id") if isinstance(o, dict) else o for o in obs.get("pick_options") or []]
        for o in obs.get("pick_options") or []:
            if isinstance(o, dict) and set(o) != PICK_OPTION_FIELDS:
                bad(robot, f"{robot}: pick option {o.get('id')} has fields {sorted(o)}, expected "
                           f"{sorted(PICK_OPTION_FIELDS)}")
        expected_picks = expected_pick_ids(ctx, p, robot)
        if picks != expected_picks:
            bad(robot, f"{robot}: pick options {picks}, O-PICK-OPTIONS gives {expected_picks}")
        # nothing about remote robots
        remote = sorted(_mentioned_robots(obs) - _observable_ids(ctx, robot))
        if remote:
            bad(robot, f"observation of {robot} mentions remote robot(s) {remote}")
    # O-EXPOSURE: the same key gives every member the same candidate
    for robot, ids in all_options.items():
        for cid in ids:
            parsed = parse_candidate(cid)
            for m in parsed[2] if parsed else []:
                if m in all_options and cid not in all_options[m]:
                    bad(cid, f"candidate {cid} is offered to {robot} but not to its member {m}")
    return out


def _observable_ids(ctx: Context, robot: str) -> frozenset[str]:
    """Robots an observation of ``robot`` may mention: itself, its G_obs neighbours and its G_manip
    neighbours (co-members of its candidates); memoized, the grid is static."""
    cached = ctx._observable.get(robot)
    if cached is None:
        ids = {robot} | {nid for _, nid in ctx.observation_neighbours(robot)}
        cached = ctx._observable[robot] = frozenset(ids | set(ctx.manip_neighbours(robot)))
    return cached


# --------------------------------------------------------------------------- INV-MASKING


def expected_mask(ctx: Context, view: StateView, robot: str, obs: Json) -> list[bool]:
    """O-MASK recomputed from the pre-action state and the robot's own option lists."""
    mask = [False] * N_ACTIONS
    mask[IDLE] = True
    r = view.robots.get(robot) or {}
    if not view.free(robot):
        return mask
    options = obs.get("operation_options") or []
    pending = r.get("supports")
    if pending is not None and view.t < int(r.get("switch_lock", -1)):
        for k, opt in enumerate(options[:OP_SLOTS]):
            if isinstance(opt, dict) and opt.get("id") == pending:
                mask[OP0 + k] = True
        return mask
    for k in range(min(len(options), OP_SLOTS)):
        mask[OP0 + k] = True
    if pending is not None:
        return mask
    directions = [d for d, _ in ctx.handoff_neighbours(robot)]
    if r.get("holding") is None:
        for k in range(min(len(obs.get("pick_options") or []), PICK_SLOTS)):
            mask[PICK0 + k] = True
        for d in directions:
            mask[RECEIVE0 + d] = True
    else:
        for d in directions:
            mask[HANDOFF0 + d] = True
        parsed = parse_item(r["holding"])
        recipe = ctx.recipe_of(view, parsed[0]) if parsed else None
        col = parse_cell(robot)[1]
        if (recipe is not None and parsed[1] == recipe.terminal and col == ctx.cols - 1
                and ctx.spacing * (ctx.cols - col) <= ctx.reach + REACH_TOLERANCE):
            mask[DELIVER] = True
    return mask


def inv_masking(ctx: Context, prev: Json | None, rec: Json) -> list[Violation]:
    """INV-MASKING: idle is always legal; a busy robot has only idle; the mask equals O-MASK (it hides no
    locally legal action, e.g. the pick slots of a free empty-handed input robot, and exposes nothing
    else); every applied action was legal, illegal choices appear as coerced to idle (O-MASK,
    R-ACTION-VALIDATION, R-SWITCH-LOCK)."""
    ID = "INV-MASKING"
    if prev is None:
        return []
    out: list[Violation] = []
    p = ctx.view(prev["state"])
    t = int(rec.get("t", p.t))
    actions = rec.get("actions") or {}
    coerced = {ev.get("robot"): ev.get("action") for ev in rec.get("events") or [] if ev.get("type") == "action_coerced"}
    chosen = dict(rec.get("chosen") or {})
    for robot, a in actions.items():
        if not (isinstance(a, int) and 0 <= a < N_ACTIONS):
            out.append(Violation(ID, t, robot, f"{robot}: applied action {a!r} is outside 0..{N_ACTIONS - 1}"))
    observations = rec.get("observations")
    if not observations:
        ctx.skipped.setdefault(ID, "the trace carries no masks")
        return out
    for robot, obs in observations.items():
        ctx.count(ID)
        mask = obs.get("mask") if isinstance(obs, dict) else None
        if not (isinstance(mask, list) and len(mask) == N_ACTIONS and set(map(type, mask)) == {bool}):
            out.append(Violation(ID, t, robot, f"{robot}: the mask is not {N_ACTIONS} booleans"))
            continue
        if not mask[IDLE]:
            out.append(Violation(ID, t, robot, f"{robot}: idle is masked; at least idle must always be legal"))
        if not p.free(robot) and True in mask[1:]:
            legal = [_action_name(k) for k in range(1, N_ACTIONS) if mask[k]]
            out.append(Violation(ID, t, robot, f"{robot} is busy but its mask allows {legal}"))
        expected = expected_mask(ctx, p, robot, obs)
        if mask != expected:  # name the differing actions only when there are some
            hidden = [_action_name(k) for k in range(N_ACTIONS) if expected[k] and not mask[k]]
            exposed = [_action_name(k) for k in range(N_ACTIONS) if mask[k] and not expected[k]]
            if hidden:
                out.append(Violation(ID, t, robot, f"{robot}: the mask hides locally legal action(s) {hidden}"))
            if exposed:
                out.append(Violation(ID, t, robot, f"{robot}: the mask allows action(s) {exposed} that O-MASK forbids"))
        a = actions.get(robot, IDLE)
        if isinstance(a, int) and 0 <= a < N_ACTIONS and not mask[a]:
            out.append(Violation(ID, t, robot, f"{robot} applied {_action_name(a)}, which its mask forbids"))
        original = coerced.get(robot, chosen.get(robot, a))
        if original != a:
            if a != IDLE:
                out.append(Violation(ID, t, robot, f"{robot}: chosen {original!r} was replaced by {_action_name(a)}, "
                                                   "not by idle"))
            if isinstance(original, int) and 0 <= original < N_ACTIONS and mask[original]:
                out.append(Violation(ID, t, robot, f"{robot}: legal action {_action_name(original)} was coerced to idle"))
        elif robot in coerced and isinstance(a, int) and 0 <= a < N_ACTIONS and mask[a] and a != IDLE:
            out.append(Violation(ID, t, robot, f"{robot}: legal action {_action_name(a)} is reported as coerced"))
    return out
