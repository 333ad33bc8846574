"""The behavioural fields of a state record that events determine, and their differences
(F-TRACE-PAIRING): what the pairing check replays events over and compares with the next state."""

from __future__ import annotations

from typing import Any, Iterator, Mapping

Json = dict[str, Any]
ROBOT_FIELDS = ("holding", "incoming", "supports", "activity")
ACTIVITY_FIELDS = ("id", "kind", "members", "product", "start", "end", "item", "operation", "candidate",
                   "first_proposed_at")


def cell_key(robot: Any) -> tuple[int, int]:
    i, j = str(robot).split(",")
    return int(i), int(j)


def members_of(candidate: str) -> list[str]:
    """R-IDS: the members of ``op:{z}:{τ}:{i,j;…}``."""
    tail = candidate.rsplit(":", 1)[-1]
    return tail.split(";") if tail else []


def candidate_op(candidate: str) -> tuple[int, str]:
    parts = candidate.split(":")
    return int(parts[1]), parts[2]



def project(state: Mapping[str, Any]) -> Json:
    """The behavioural fields of a state record that events determine (F-TRACE-PAIRING)."""
    return {
        "released": state["released"], "delivered": state["delivered"], "wip": state["wip"],
        "lost_releases": state["lost_releases"],
        "robots": {rid: {k: r.get(k) for k in ROBOT_FIELDS} for rid, r in state["robots"].items()},
        "products": {int(p["id"]): {"recipe": p["recipe"], "released_at": p["released_at"], "due": p["due"],
                                    "completed": set(p["completed"]), "in_progress": set(p["in_progress"]),
                                    "xor": dict(p["xor"]), "raw_taken": set(p["raw_taken"]),
                                    "delivered_at": p["delivered_at"]}
                     for p in state["products"]},
        "items": dict(state["items"]),
        "shelves": [dict(s) for s in state["shelves"]],
        "proposals": {cid: {"created_at": p["created_at"], "expires_at": p["expires_at"],
                            "supporters": set(p["supporters"])} for cid, p in state["proposals"].items()},
        "activities": [{**{k: a[k] for k in ACTIVITY_FIELDS if k in a}, "roles": a.get("roles")}
                       for a in state["activities"]],
    }


def initial(instance: Mapping[str, Any], s0: Mapping[str, Any]) -> Json:
    """The state before the reset's events: nothing released, shelves as the realization stocks them."""
    shelves = [dict() for _ in s0["shelves"]]
    for entry in instance["realization"]["shelves"]:
        shelves[int(entry["row"])] = {tok: int(n) for tok, n in entry["stock"].items()}
    return {"released": 0, "delivered": 0, "wip": 0, "lost_releases": 0,
            "robots": {rid: dict.fromkeys(ROBOT_FIELDS) for rid in s0["robots"]}, "products": {}, "items": {},
            "shelves": shelves, "proposals": {}, "activities": []}


def _plain(value: Any) -> Any:
    return sorted(value) if isinstance(value, set) else value


def differences(expected: Json, actual: Json) -> Iterator[tuple[str, Any, Any]]:
    """(pointer into the state, what the events give, what the state has), in a stable order."""
    for key in ("released", "delivered", "wip", "lost_releases"):
        if expected[key] != actual[key]:
            yield f"/state/{key}", expected[key], actual[key]
    for rid in sorted(set(expected["robots"]) | set(actual["robots"]), key=cell_key):
        e, a = expected["robots"].get(rid) or {}, actual["robots"].get(rid) or {}
        for k in ROBOT_FIELDS:
            if e.get(k) != a.get(k):
                yield f"/state/robots/{rid}/{k}", e.get(k), a.get(k)
    pids = sorted(set(expected["products"]) | set(actual["products"]))
    for n, pid in enumerate(pids):
        e, a = expected["products"].get(pid), actual["products"].get(pid)
        if e is None or a is None:
            yield f"/state/products/{n}", "absent" if e is None else f"product {pid}", \
                "absent" if a is None else f"product {pid}"
            continue
        for k in e:
            if e[k] != a[k]:
                yield f"/state/products/{n}/{k}", _plain(e[k]), _plain(a[k])
    if expected["items"] != actual["items"]:
        for item in sorted(set(expected["items"]) | set(actual["items"])):
            if expected["items"].get(item) != actual["items"].get(item):
                yield f"/state/items/{item}", expected["items"].get(item), actual["items"].get(item)
    for row, (e, a) in enumerate(zip(expected["shelves"], actual["shelves"])):
        for tok in sorted(set(e) | set(a)):
            if e.get(tok) != a.get(tok):
                yield f"/state/shelves/{row}/{tok}", e.get(tok), a.get(tok)
    for cid in sorted(set(expected["proposals"]) | set(actual["proposals"])):
        e, a = expected["proposals"].get(cid), actual["proposals"].get(cid)
        if e is None or a is None:
            yield f"/state/proposals/{cid}", "absent" if e is None else "open", "absent" if a is None else "open"
            continue
        for k in e:
            if e[k] != a[k]:
                yield f"/state/proposals/{cid}/{k}", _plain(e[k]), _plain(a[k])
    e_ids = [x["id"] for x in expected["activities"]]
    a_ids = [x["id"] for x in actual["activities"]]
    if e_ids != a_ids:
        yield "/state/activities", e_ids, a_ids
        return
    for n, (e, a) in enumerate(zip(expected["activities"], actual["activities"])):
        for k in ACTIVITY_FIELDS:
            if k in e and e.get(k) != a.get(k):
                yield f"/state/activities/{n}/{k}", e.get(k), a.get(k)


__all__ = ["Json", "ROBOT_FIELDS", "ACTIVITY_FIELDS", "cell_key", "members_of", "candidate_op", "project", "initial",
           "differences"]
