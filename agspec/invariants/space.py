"""Spatial invariants: INV-LOCALITY, INV-EXCLUSIVITY (spec chapter 08)."""

from __future__ import annotations

import math
from collections import Counter

from agspec.invariants.context import CONFLICT_TOLERANCE, Context, Json, Violation, parse_cell, reporter

# --------------------------------------------------------------------------- INV-LOCALITY


def inv_locality(ctx: Context, prev: Json | None, rec: Json) -> list[Violation]:
    """INV-LOCALITY: operation members are pairwise adjacent in G_manip; handoff partners adjacent in
    G_handoff; picks from column 0 with shelf access; deliveries from column N-1 (R-CANDIDATES, R-PICK,
    R-HANDOFF, R-DELIVERY)."""
    ID = "INV-LOCALITY"
    out: list[Violation] = []
    s = ctx.view(rec["state"])
    acts = list(s.activities)
    if prev is not None:  # activities living less than one tick are seen only in the transition
        acts += [a for a in ctx.transition(prev, rec).started if a.get("from_event")]
    for a in acts:
        ctx.count(ID)
        kind, members, aid = a.get("kind"), list(a.get("members", [])), a.get("id")
        if kind == "operation":
            for i, u in enumerate(members):
                for v in members[i + 1:]:
                    if not ctx.manip_adjacent(u, v):
                        out.append(Violation(ID, s.t, aid, f"coalition of {aid}: members {u} and {v} are not adjacent "
                                                           f"in G_manip ({ctx.topology}, radius {ctx.radius})"))
        elif kind == "handoff":
            if len(members) != 2 or not ctx.handoff_adjacent(members[0], members[1]):
                out.append(Violation(ID, s.t, aid, f"handoff {aid} between {members} is not between G_handoff "
                                                   f"neighbours ({ctx.topology})"))
        elif kind == "pick":
            cell = parse_cell(members[0])
            row = a.get("shelf_row")
            if row is None:
                for r in a.get("resources", []):
                    if r.startswith("shelf:"):
                        row = int(r.split(":")[1])
            if cell[1] != 0:
                out.append(Violation(ID, s.t, aid, f"pick {aid} by {members[0]}, which is not in the input column"))
            elif row is not None and cell[0] not in ctx.shelf_access.get(int(row), ()):
                out.append(Violation(ID, s.t, aid, f"pick {aid}: robot row {cell[0]} has no access to shelf row {row}"))
        elif kind == "deliver":
            if parse_cell(members[0])[1] != ctx.cols - 1:
                out.append(Violation(ID, s.t, aid, f"delivery {aid} by {members[0]}, which is not in the output "
                                                   f"column {ctx.cols - 1}"))
    return out


# --------------------------------------------------------------------------- INV-EXCLUSIVITY


def _target_distance(a: Json, b: Json) -> float | None:
    ta, tb = a.get("target"), b.get("target")
    if not (isinstance(ta, list) and isinstance(tb, list) and len(ta) == 2 and len(tb) == 2):
        return None
    return math.hypot(ta[0] - tb[0], ta[1] - tb[1])


def inv_exclusivity(ctx: Context, prev: Json | None, rec: Json) -> list[Violation]:
    """INV-EXCLUSIVITY: no robot in two activities; a robot is busy iff committed; exclusive resources
    are never shared and finite ones never exceed capacity (default 1); shelf stock stays within
    [0, capacity]; committed activities' targets keep the G-CONFLICT distance; new activities start on
    free robots (R-PICK, R-HANDOFF, R-ADMISSION, R-BLOCKING, R-DELIVERY, R-EXECUTION, R-REPLENISH)."""
    ID = "INV-EXCLUSIVITY"
    s = ctx.view(rec["state"])
    tick = s.t
    out, bad = reporter(ID, tick)

    for rid, r in s.robots.items():
        ctx.count(ID)
        acts = s.membership.get(rid, [])
        if len(acts) > 1:
            bad(rid, f"robot {rid} is committed to {len(acts)} activities at once: {acts}")
        busy = int(r.get("busy_until") or 0) > tick
        if busy and not acts:
            bad(rid, f"robot {rid} is busy until {r.get('busy_until')} without an activity")
        if acts:
            a = s.act_by_id[acts[0]]
            if r.get("busy_until") != a.get("end"):
                bad(rid, f"robot {rid} is committed to {acts[0]} ending at {a.get('end')} but busy until "
                         f"{r.get('busy_until')}")
            if "activity" in r and r.get("activity") != acts[0]:
                bad(rid, f"robot {rid} records activity {r.get('activity')} but is a member of {acts[0]}")
    usage: dict[str, list[str]] = {}
    for a in s.activities:
        for res in set(a.get("resources", [])):
            usage.setdefault(res, []).append(a.get("id"))
    for res, users in usage.items():
        ctx.count(ID)
        if len(users) > ctx.capacity(res):
            bad(res, f"resource {res} (capacity {ctx.capacity(res)}) is held by {len(users)} activities: {users}")
    for row, shelf in enumerate(s.shelves):
        for tok, stock in shelf.items():
            ctx.count(ID)
            if not (isinstance(stock, int) and 0 <= stock <= ctx.shelf_capacity):
                bad(f"shelf:{row}:{tok}", f"shelf row {row} holds {stock!r} units of {tok}, outside "
                                          f"[0, {ctx.shelf_capacity}]")
    limit = ctx.rho_conf + ctx.clearance - CONFLICT_TOLERANCE  # G-CONFLICT, target part
    for i, a in enumerate(s.activities):
        for b in s.activities[i + 1:]:
            d = _target_distance(a, b)
            if d is not None and d < limit:
                bad(a.get("id"), f"committed activities {a.get('id')} and {b.get('id')} have targets {d:.3f} apart, "
                                 f"closer than the conflict distance {ctx.rho_conf + ctx.clearance:.3f}")
    if prev is None:
        return out
    p = ctx.view(prev["state"])
    tr = ctx.transition(prev, rec)
    starts: Counter = Counter()
    for a in tr.started:
        for m in a.get("members", []):
            starts[m] += 1
            if not p.free(m):
                bad(m, f"robot {m} starts {a.get('id')} at t={tr.t} although it was not free "
                       f"(busy until {(p.robots.get(m) or {}).get('busy_until')})")
    for m, n in starts.items():
        if n > 1:
            bad(m, f"robot {m} starts {n} activities in the same transition at t={tr.t}")
    return out
