"""Hypothesis strategies that generate *valid* recipe IR (for the semantic-check tests).

Construction (RC-MATERIAL by design): start from the raw materials as "loose" tokens; each new
operation consumes 1..3 loose tokens and produces a fresh one, until a single token is left — the
terminal product FINAL.  The material flow is therefore an in-tree: every token is consumed exactly
once and every input is produced by a predecessor (the producers of an operation's inputs are put
in its `after` list, plus optional extra earlier operations).  Optionally some operations get an
XOR twin (same inputs and output, other type/duration); `after` entries that named the original then
name the group.  Arity, roles (kmax roles, inputs bound at most once) and numbers are drawn inside
their valid ranges (RC-ARITY, RC-ROLES, RC-DURATION).
"""

from __future__ import annotations

from hypothesis import strategies as st

IR = "agspec-ir/1"
K_TOPO = 4


@st.composite
def valid_recipes(draw, max_raw: int = 3, max_xor: int = 2) -> dict:
    n_raw = draw(st.integers(1, max_raw))
    raw = [f"R{k}" for k in range(n_raw)]
    raw = draw(st.permutations(raw))  # raw order is meaningful but arbitrary
    loose = list(raw)
    producer: dict[str, str] = {}
    ops: list[dict] = []
    while len(loose) > 1 or not ops:
        k = len(ops)
        take = draw(st.integers(1, min(3, len(loose))))
        idx = sorted(draw(st.permutations(range(len(loose))))[:take])
        inputs = [loose[i] for i in idx]
        loose = [t for i, t in enumerate(loose) if i not in idx]
        op_id = f"op{k:02d}"
        output = f"T{k}"
        needed = {producer[t] for t in inputs if t in producer}
        extra = set(draw(st.lists(st.sampled_from([o["id"] for o in ops]), max_size=2))) if ops else set()
        ops.append(_operation(draw, op_id, inputs, output, needed | extra))
        producer[output] = op_id
        loose.append(output)
    _rename(ops, loose[0], "FINAL")
    groups = _add_xor(draw, ops, max_xor)
    resources = {}
    if draw(st.booleans()):
        resources = {"fixture": draw(st.integers(1, 3))}
        for op in ops:
            if draw(st.booleans()):
                op["resources"] = ["fixture"]
    return {
        "ir_version": IR,
        "kind": "recipe",
        "id": "generated",
        "value": draw(st.floats(0.1, 10.0)),
        "raw": list(raw),
        "resources": resources,
        "operations": sorted(ops, key=lambda o: o["id"]),
        "xor": groups,
    }


def _operation(draw, op_id: str, inputs: list[str], output: str, after: set[str]) -> dict:
    n_in = len(inputs)
    kmin = draw(st.integers(n_in, K_TOPO))
    kmax = draw(st.integers(kmin, K_TOPO))
    bound = draw(st.lists(st.sampled_from(inputs), unique=True, max_size=n_in))
    roles = [{"name": f"holder_{tok}", "binds": tok} for tok in bound]
    roles += [{"name": f"helper_{k}"} for k in range(kmax - len(roles))]
    roles = draw(st.permutations(roles))
    return {
        "id": op_id,
        "type": draw(st.sampled_from(["align", "assemble", "inspect", "process"])),
        "inputs": sorted(inputs),
        "outputs": [output],
        "after": sorted(after),
        "arity": [kmin, kmax],
        "roles": list(roles),
        "resources": [],
        "duration": draw(st.integers(1, 9)),
        "weight": draw(st.floats(0.1, 5.0)),
    }


def _rename(ops: list[dict], old: str, new: str) -> None:
    for op in ops:
        op["outputs"] = [new if t == old else t for t in op["outputs"]]
        op["inputs"] = sorted(new if t == old else t for t in op["inputs"])
        for role in op["roles"]:
            if role.get("binds") == old:
                role["binds"] = new


def _add_xor(draw, ops: list[dict], max_xor: int) -> list[dict]:
    """Give up to ``max_xor`` operations an alternative twin; dependants then name the group."""
    chosen = draw(st.lists(st.sampled_from([o["id"] for o in ops]), unique=True, max_size=max_xor))
    groups = []
    for n, op_id in enumerate(chosen):
        original = next(o for o in ops if o["id"] == op_id)
        twin = dict(original, id=f"{op_id}_alt", type="alternative", duration=draw(st.integers(1, 9)),
                    roles=[dict(r) for r in original["roles"]], inputs=list(original["inputs"]),
                    outputs=list(original["outputs"]), after=list(original["after"]))
        ops.append(twin)
        gid = f"xor{n}"
        for op in ops:
            if op_id in op["after"] and op["id"] != twin["id"]:
                op["after"] = sorted({gid if p == op_id else p for p in op["after"]})
        groups.append({"id": gid, "alternatives": sorted([op_id, twin["id"]])})
    return sorted(groups, key=lambda g: g["id"])
