"""Coordination invariants: INV-SUPPORT, INV-PROGRESS, INV-LIFETIME, INV-ARITY (spec chapter 08)."""

from __future__ import annotations

from typing import Mapping

from agspec.invariants.context import Context, Json, OpInfo, Violation, _completed_ops, parse_candidate, parse_cell
from agspec.invariants.context import reporter

# --------------------------------------------------------------------------- INV-SUPPORT


def inv_support(ctx: Context, prev: Json | None, rec: Json) -> list[Violation]:
    """INV-SUPPORT: supporting or committing never creates a second owner (R-SUPPORT,
    R-SUPPORT-LIFECYCLE, R-EXPIRY, R-HELD-MATERIAL): one item per robot, one robot per item, a handoff
    in flight keeps its single owner, support records are consistent and support never moves material."""
    ID = "INV-SUPPORT"
    s = ctx.view(rec["state"])
    tick = s.t
    out, bad = reporter(ID, tick)

    for rid, r in s.robots.items():
        if isinstance(r.get("holding"), list) and len(r["holding"]) > 1:
            bad(rid, f"robot {rid} owns {len(r['holding'])} items at once")
    for item, robots in s.holders.items():
        if len(robots) > 1:
            bad(item, f"item {item} has {len(robots)} owners ({', '.join(sorted(robots))}); support or "
                      "commitment must not create a second owner")
    # a handoff in flight keeps exactly one owner: the sender
    for a in s.activities:
        if a.get("kind") != "handoff":
            continue
        ctx.count(ID)
        item = a.get("item")
        owners = s.holders.get(item, [])
        members = a.get("members", [])
        if len(owners) != 1 or owners[0] not in members:
            bad(a.get("id"), f"handoff {a.get('id')} in flight: {item} is owned by {owners or 'nobody'}, expected "
                             f"exactly one member")
            continue
        for m in members:
            if m != owners[0]:
                r = s.robots.get(m) or {}
                if r.get("holding") is not None:
                    bad(m, f"receiver {m} of handoff {a.get('id')} already holds {r.get('holding')}")
                if r.get("incoming") not in (None, item):
                    bad(m, f"receiver {m} of handoff {a.get('id')} expects {r.get('incoming')}, not {item}")
    for rid, r in s.robots.items():
        if r.get("incoming") is not None:
            acts = [s.act_by_id.get(aid) for aid in s.membership.get(rid, [])]
            if not any(x and x.get("kind") == "handoff" and x.get("item") == r["incoming"] for x in acts):
                bad(rid, f"robot {rid} expects incoming {r['incoming']} without a handoff in flight")
    # during an operation every input is held by exactly one member
    for a in s.activities:
        if a.get("kind") != "operation":
            continue
        recipe = ctx.recipe_of(s, a.get("product"))
        op = recipe.ops.get(a.get("operation")) if recipe else None
        if op is None:
            continue
        for tok in op.inputs:
            item = f"{a['product']}:{tok}"
            owners = s.holders.get(item, [])
            if len(owners) != 1 or owners[0] not in a.get("members", []):
                bad(a.get("id"), f"operation {a.get('id')}: input {item} is held by {owners or 'nobody'}, "
                                 "expected exactly one coalition member")
    # support records (R-SUPPORT-LIFECYCLE)
    for cid, pr in s.proposals.items():
        ctx.count(ID)
        parsed = parse_candidate(cid)
        members = set(parsed[2]) if parsed else set()
        created, expires = pr.get("created_at"), pr.get("expires_at")
        if created is None or expires is None or expires != created + ctx.support_timeout:
            bad(cid, f"support record {cid}: expires_at {expires} != created_at {created} + timeout "
                     f"{ctx.support_timeout}")
        elif not (created < tick <= expires):
            bad(cid, f"support record {cid} created at {created}, expiring at {expires}, still exists at t={tick}")
        for sup in pr.get("supporters", []):
            if parsed is not None and sup not in members:
                bad(cid, f"robot {sup} supports {cid} but is not one of its members")
            if (s.robots.get(sup) or {}).get("supports") != cid:
                bad(sup, f"robot {sup} is listed as a supporter of {cid} but its pending support is "
                         f"{(s.robots.get(sup) or {}).get('supports')}")
    for rid, r in s.robots.items():
        cid = r.get("supports")
        if cid is None:
            continue
        pr = s.proposals.get(cid)
        if pr is None or rid not in pr.get("supporters", []):
            bad(rid, f"robot {rid} supports {cid}, but no support record lists it")
        if s.membership.get(rid):
            bad(rid, f"robot {rid} is committed to {s.membership[rid]} and still supports {cid}")
    if prev is None:
        return out
    # support never moves material: supporters and committed members change their item only through
    # a completion of an activity they belong to
    p = ctx.view(prev["state"])
    tr = ctx.transition(prev, rec)
    completing_members = {m for a in tr.completing for m in a.get("members", [])}
    for rid, r in p.robots.items():
        if r.get("supports") is None and not p.membership.get(rid):
            continue
        ctx.count(ID)
        after = (s.robots.get(rid) or {}).get("holding")
        if after != r.get("holding") and rid not in completing_members:
            what = f"supports {r.get('supports')}" if r.get("supports") else f"is committed to {p.membership[rid]}"
            bad(rid, f"robot {rid} {what} at t={p.t}, yet its item changed from {r.get('holding')} to {after} "
                     "without a completion of its own activity")
    return out


# --------------------------------------------------------------------------- INV-PROGRESS


def inv_progress(ctx: Context, prev: Json | None, rec: Json) -> list[Violation]:
    """INV-PROGRESS: completed operation sets only grow, and only by the operations completing in the
    transition; XOR choices and deliveries are never undone (R-COMPLETION, R-XOR-CLOSURE)."""
    ID = "INV-PROGRESS"
    out: list[Violation] = []
    if prev is None:
        s = ctx.view(rec["state"])
        for pid, prod in s.products.items():
            ctx.count(ID)
            if prod.get("completed") or prod.get("delivered_at") is not None:
                out.append(Violation(ID, s.t, str(pid), f"product {pid} starts with progress {prod.get('completed')}"))
        return out
    p, s = ctx.view(prev["state"]), ctx.view(rec["state"])
    tr = ctx.transition(prev, rec)
    tick = s.t
    for pid, before in p.products.items():
        ctx.count(ID)
        after = s.products.get(pid)
        if after is None:
            out.append(Violation(ID, tick, str(pid), f"released product {pid} vanished from the state"))
            continue
        lost = set(before.get("completed", [])) - set(after.get("completed", []))
        if lost:
            out.append(Violation(ID, tick, str(pid), f"product {pid}: completed operation(s) {sorted(lost)} were "
                                                    "removed; progress is monotone"))
        gained = set(after.get("completed", [])) - set(before.get("completed", []))
        expected = _completed_ops(tr, pid)
        if gained != expected:
            out.append(Violation(ID, tick, str(pid), f"product {pid}: operations {sorted(gained)} became completed, "
                                                    f"but the completing operation activities are {sorted(expected)}"))
        for group, choice in (before.get("xor") or {}).items():
            if (after.get("xor") or {}).get(group) != choice:
                out.append(Violation(ID, tick, str(pid), f"product {pid}: XOR choice {group}={choice} changed to "
                                                        f"{(after.get('xor') or {}).get(group)}"))
        if before.get("delivered_at") is not None and after.get("delivered_at") != before.get("delivered_at"):
            out.append(Violation(ID, tick, str(pid), f"product {pid} was delivered at {before['delivered_at']}; "
                                                    f"now delivered_at = {after.get('delivered_at')}"))
    return out


# --------------------------------------------------------------------------- INV-LIFETIME


def _signature(a: Json) -> tuple:
    return (
        a.get("kind"),
        tuple(a.get("members", [])),
        tuple(sorted((a.get("roles") or {}).items())),
        a.get("operation"),
        a.get("product"),
        a.get("candidate"),
        a.get("item"),
        tuple(sorted(a.get("resources", []))),
        a.get("start"),
        a.get("end"),
    )


_SIGNATURE_FIELDS = ("kind", "members", "roles", "operation", "product", "candidate", "item", "resources", "start", "end")


def inv_lifetime(ctx: Context, prev: Json | None, rec: Json) -> list[Violation]:
    """INV-LIFETIME: members, roles, operation (and every other attribute) of an activity id never
    change while it exists; it ends exactly at its end epoch (R-ADMISSION, R-EXECUTION, R-COMPLETION)."""
    ID = "INV-LIFETIME"
    out: list[Violation] = []
    s = ctx.view(rec["state"])
    tick = s.t
    for a in s.activities:
        ctx.count(ID)
        aid = a.get("id")
        sig = _signature(a)
        first = ctx.lifetime.get(aid)
        if aid in ctx.lifetime_gone:
            out.append(Violation(ID, tick, aid, f"activity {aid} reappears after it ended"))
        if first is None:
            ctx.lifetime[aid] = sig
        elif first != sig:
            changed = [f"{name}: {x!r} -> {y!r}" for name, x, y in zip(_SIGNATURE_FIELDS, first, sig) if x != y]
            out.append(Violation(ID, tick, aid, f"activity {aid} changed while committed ({'; '.join(changed)})"))
        start, end = a.get("start"), a.get("end")
        if not (isinstance(start, int) and isinstance(end, int) and start < tick < end):
            out.append(Violation(ID, tick, aid, f"activity {aid} [{start}, {end}) is listed at t={tick}"))
    if prev is None:
        return out
    p = ctx.view(prev["state"])
    t = int(rec.get("t", p.t))
    for aid, a in p.act_by_id.items():
        gone = aid not in s.act_by_id
        if gone:
            ctx.lifetime_gone.add(aid)
        if gone != (int(a.get("end", 0)) == t + 1):
            out.append(Violation(ID, tick, aid, f"activity {aid} with end {a.get('end')} "
                                                f"{'ended' if gone else 'is still listed'} at t={tick}"))
    for aid, a in s.act_by_id.items():
        if aid not in p.act_by_id and a.get("start") != t:
            out.append(Violation(ID, tick, aid, f"activity {aid} first appears at t={tick} but claims start "
                                                f"{a.get('start')} (expected {t})"))
    return out


# --------------------------------------------------------------------------- INV-ARITY


def canonical_roles(op: OpInfo, members: list[str], holder_of: Mapping[str, str]) -> dict[str, str] | None:
    """RC-ROLES / R-ROLE-ASSIGNMENT: bound roles to the holders of their inputs, the remaining roles in
    declaration order to the remaining members in row-major order; None if a bound role cannot go to a
    member."""
    assigned: dict[str, str] = {}
    for name, binds in op.roles:
        if binds is None:
            continue
        holder = holder_of.get(binds)
        if holder is None or holder not in members or holder in assigned:
            return None
        assigned[holder] = name
    free = [name for name, binds in op.roles if binds is None]
    rest = sorted((m for m in members if m not in assigned), key=parse_cell)
    for k, m in enumerate(rest):
        assigned[m] = free[k] if k < len(free) else f"helper_extra_{k}"
    return assigned


def inv_arity(ctx: Context, prev: Json | None, rec: Json) -> list[Violation]:
    """INV-ARITY: k_min <= |members| <= min(k_max, k_topo), roles cover exactly the members, and a new
    activity's roles are the canonical assignment computed from the state before its admission
    (R-ROLE-ASSIGNMENT, R-ADMISSION)."""
    ID = "INV-ARITY"
    out: list[Violation] = []
    s = ctx.view(rec["state"])
    tick = s.t
    p = ctx.view(prev["state"]) if prev is not None else None
    for a in s.activities:
        if a.get("kind") != "operation":
            continue
        ctx.count(ID)
        aid = a.get("id")
        members = list(a.get("members", []))
        recipe = ctx.recipe_of(s, a.get("product"))
        op = recipe.ops.get(a.get("operation")) if recipe else None
        if op is None:
            out.append(Violation(ID, tick, aid, f"activity {aid} executes unknown operation {a.get('operation')!r}"))
            continue
        cap = min(op.kmax, ctx.k_topo)
        if not (op.kmin <= len(members) <= cap):
            out.append(Violation(ID, tick, aid, f"{aid} has {len(members)} members; `{op.id}` needs "
                                                f"{op.kmin}..min({op.kmax}, k_topo={ctx.k_topo}) = {op.kmin}..{cap}"))
        if len(set(members)) != len(members):
            out.append(Violation(ID, tick, aid, f"{aid} lists a member twice: {members}"))
        if members != sorted(members, key=parse_cell):
            out.append(Violation(ID, tick, aid, f"{aid}: members {members} are not in row-major order"))
        cand = a.get("candidate")
        if cand is not None:
            parsed = parse_candidate(cand)
            if parsed is None or parsed[0] != a.get("product") or parsed[1] != op.id or parsed[2] != members:
                out.append(Violation(ID, tick, aid, f"{aid} executes candidate {cand}, whose key does not match "
                                                    f"product {a.get('product')}, `{op.id}`, members {members}"))
        roles = dict(a.get("roles") or {})
        if set(roles) != set(members):
            out.append(Violation(ID, tick, aid, f"{aid}: roles are given for {sorted(roles)}, members are {members}"))
        names = list(roles.values())
        declared = {name for name, _ in op.roles}
        if len(set(names)) != len(names):
            out.append(Violation(ID, tick, aid, f"{aid}: a role is assigned twice: {sorted(names)}"))
        for n in names:
            if n not in declared and not n.startswith("helper_extra_"):
                out.append(Violation(ID, tick, aid, f"{aid}: role `{n}` is not declared by `{op.id}`"))
        if p is not None and aid not in p.act_by_id:
            # a new activity: roles must be the canonical assignment at the pre-admission state s_t
            holder_of = {tok: p.items.get(f"{a['product']}:{tok}") for tok in op.inputs}
            expected = canonical_roles(op, members, {k: v for k, v in holder_of.items() if v is not None})
            if expected is None:
                out.append(Violation(ID, tick, aid, f"{aid}: the bound roles of `{op.id}` cannot be filled by the "
                                                    f"members {members} (input holders at t={p.t}: {holder_of})"))
            elif expected != roles:
                out.append(Violation(ID, tick, aid, f"{aid}: roles {dict(sorted(roles.items()))} differ from the "
                                                    f"canonical assignment {dict(sorted(expected.items()))}"))
    return out
