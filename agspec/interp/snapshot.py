"""Canonical global state view (spec O-GLOBAL-STATE, F-TRACE state record).

A language-neutral JSON form of the state: every identifier is a canonical id (R-IDS), every
collection has a canonical order, so two implementations' states compare field by field.
This is the privileged view; decentralized controllers never receive it.
"""

from __future__ import annotations

from typing import Any

from agspec.interp.state import State, cell_id, item_id


def global_state(state: State) -> dict[str, Any]:
    robots = {}
    for cell in sorted(state.robots):
        r = state.robots[cell]
        robots[cell_id(cell)] = {
            "holding": item_id(r.holding) if r.holding else None,
            "busy_until": r.busy_until,
            "incoming": item_id(r.incoming) if r.incoming else None,
            "supports": r.supports,
            "switch_lock": r.switch_lock,
            "activity": r.activity,
            "ee": [r.pose.ee[0], r.pose.ee[1]],
            "q": list(r.pose.q),
        }
    products = []
    for p in state.products:
        products.append(
            {
                "id": p.pid,
                "recipe": p.recipe,
                "released_at": p.spawn_time,
                "due": p.due_time,
                "completed": sorted(p.completed),
                "in_progress": sorted(p.in_progress),
                "xor": dict(sorted(p.xor_choice.items())),
                "raw_taken": sorted(p.raw_taken),
                "delivered_at": p.complete_time,
            }
        )
    activities = []
    for a in state.activities:
        entry: dict[str, Any] = {
            "id": a.aid,
            "kind": a.kind,
            "members": [cell_id(m) for m in a.members],
            "resources": sorted(a.resources),
            "start": a.start,
            "end": a.end,
            "approach": a.plan.approach,
            "process": a.plan.process,
            "retreat": a.plan.retreat,
            "target": [a.target[0], a.target[1]],
            "product": a.product,
        }
        if a.is_operation:
            entry.update(
                operation=a.operation,
                candidate=a.candidate,
                roles={cell_id(m): role for m, role in a.roles},
                first_proposed_at=a.first_proposed_at,
            )
        else:
            entry["item"] = item_id(a.item) if a.item else None
        activities.append(entry)
    return {
        "t": state.t,
        "released": state.released,
        "delivered": state.delivered,
        "wip": state.wip,
        "lost_releases": state.lost_releases,
        "robots": robots,
        "products": products,
        "items": {item_id(i): cell_id(c) for i, c in sorted(state.item_holder.items())},
        "shelves": [dict(sorted(s.items())) for s in state.shelves],
        "proposals": {
            cid: {
                "created_at": p.created_at,
                "expires_at": p.expires_at,
                "supporters": [cell_id(c) for c in sorted(p.votes)],
            }
            for cid, p in sorted(state.proposals.items())
        },
        "activities": activities,
    }
