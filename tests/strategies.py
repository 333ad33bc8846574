"""Hypothesis strategies for valid IR documents in canonical form (F-IR), reusable by any test.

``recipes()`` builds random *valid* recipes (schema-valid and semantically valid, RC-*):

* material chains: raw tokens start "loose"; each operation consumes 1..3 loose tokens and
  produces a fresh one, until one token is left: ``FINAL``.  Every token is consumed once and
  every input is produced by a predecessor — its producer (or the producer's XOR group) is in
  the consumer's ``after`` list, plus optional extra earlier operations: a DAG by construction;
* optional XOR groups: an operation gets 1..2 alternatives with the same inputs and output; a
  consumer then refers to the group id in ``after``;
* arity kmin >= #inputs, kmax <= 4 = k_topo; exactly kmax roles, the first ones bound to the
  inputs (or unbound), names unique; durations >= 1; weights and value > 0;
* names are mostly identifiers but include DSL keywords (``type``, ``duration``, ``x`` ...) and
  names that need quoting (``"two words"``, ``"a/b"``), to exercise the formatter.

``profiles()`` and ``scenarios()`` build schema-valid profile and scenario IR.  All three
return IR in canonical order (what ``agspec.dsl.build`` produces), so ``build(parse(fmt(ir)))
== ir`` must hold.
"""

from __future__ import annotations

from typing import Any

from hypothesis import strategies as st

IR = "agspec-ir/1"
K_TOPO = 4

_PLAIN = ["A", "B", "C", "AB", "P1", "op", "join", "holder_A", "_", "abstract-v1", "spacing-0.75", "v2.1",
          "operator", "FINALX", "inspect"]
_KEYWORDS = ["type", "duration", "weight", "inputs", "x", "on", "raw", "operation", "recipe", "moore"]
_ODD = ["two words", "a/b", "tilde~0", "ünïcode", "-dash", "9lives", "with.dot", ""]

# drawn from a pool (fast, shrinks well); the pool mixes identifiers, keywords and odd names
names = st.sampled_from(_PLAIN + _KEYWORDS + _ODD[:-1])
decimals = st.sampled_from([0.1, 0.12, 0.25, 0.3, 0.5, 1.0, 1.2, 1.25, 1.3, 1.5, 2.0, 2.2, 10.0])
positive_floats = st.one_of(
    decimals,
    st.floats(min_value=1e-6, max_value=1e6, allow_nan=False, allow_infinity=False),
)
docs = st.text(st.characters(codec="utf-8", exclude_categories=("Cs",)), max_size=20)


@st.composite
def _unique_names(draw: Any, n: int, avoid: set[str] = frozenset()) -> list[str]:
    """n distinct names from the pool, made unique with a numeric suffix where needed."""
    out: list[str] = []
    for base in draw(st.lists(names, min_size=n, max_size=n)):
        name, k = base, 1
        while name in out or name in avoid:
            name, k = f"{base}{k}", k + 1
        out.append(name)
    return out


@st.composite
def recipes(draw: Any, max_raw: int = 3, max_ops: int = 6, xor: bool = True, k_max: int = K_TOPO) -> dict[str, Any]:
    """A valid recipe IR in canonical order (see the module docstring); ``k_max`` caps every
    operation's arity (RC-ARITY: a scenario's grid may have a smaller k_topo than 4, D-KTOPO)."""
    n_raw = draw(st.integers(1, max_raw))
    tokens = draw(_unique_names(n_raw + max_ops, avoid={"FINAL"}))
    raw = tokens[:n_raw]
    fresh = iter(tokens[n_raw:])
    op_names = iter(draw(_unique_names(3 * max_ops + 4)))
    resources = draw(st.dictionaries(names, st.integers(1, 3), max_size=2))
    loose = list(raw)
    producer: dict[str, str] = {}  # token -> operation id or XOR group id
    ops: list[dict[str, Any]] = []
    groups: list[dict[str, Any]] = []
    while True:  # until FINAL is produced; loose never holds more than max_raw <= 3 tokens
        last = len(ops) + 1 >= max_ops
        take = len(loose) if last else draw(st.integers(1, min(3, len(loose))))
        chosen = draw(st.lists(st.sampled_from(range(len(loose))), min_size=take, max_size=take, unique=True))
        inputs = [loose[i] for i in chosen]
        loose = [t for i, t in enumerate(loose) if i not in chosen]
        output = "FINAL" if not loose else next(fresh)
        after = {producer[t] for t in inputs if t in producer}
        earlier = sorted({producer[t] for t in producer} | {o["id"] for o in ops if o["id"] not in
                                                          {a for g in groups for a in g["alternatives"]}})
        if earlier:
            after |= set(draw(st.lists(st.sampled_from(earlier), max_size=2)))
        n_alt = draw(st.sampled_from([1, 1, 1, 2, 3])) if xor and len(groups) < 2 else 1
        alts = [_operation(draw, next(op_names), inputs, output, after, sorted(resources), k_max)
                for _ in range(n_alt)]
        ops += alts
        if n_alt > 1:
            gid = next(op_names)
            groups.append({"id": gid, "alternatives": sorted(a["id"] for a in alts)})
            producer[output] = gid
        else:
            producer[output] = alts[0]["id"]
        if output == "FINAL":
            break
        loose.append(output)
    ir: dict[str, Any] = {"ir_version": IR, "kind": "recipe", "id": draw(names)}
    if draw(st.booleans()):
        ir["doc"] = draw(docs)
    ir.update({
        "value": draw(positive_floats),
        "raw": raw,
        "resources": resources,
        "operations": sorted(ops, key=lambda o: o["id"]),
        "xor": sorted(groups, key=lambda g: g["id"]),
    })
    return ir


def _operation(draw: Any, op_id: str, inputs: list[str], output: str, after: set[str],
               resources: list[str], k_max: int = K_TOPO) -> dict[str, Any]:
    kmin = draw(st.integers(max(1, len(inputs)), max(len(inputs), k_max)))
    kmax = draw(st.integers(kmin, max(kmin, k_max)))
    role_names = draw(_unique_names(kmax))
    bind = draw(st.booleans())
    roles = []
    for i, name in enumerate(role_names):
        role: dict[str, Any] = {"name": name}
        if bind and i < len(inputs):
            role["binds"] = inputs[i]
        roles.append(role)
    op: dict[str, Any] = {"id": op_id}
    if draw(st.integers(0, 4)) == 0:
        op["doc"] = draw(docs)
    op.update({
        "type": draw(names),
        "inputs": sorted(inputs),
        "outputs": [output],
        "after": sorted(after),
        "arity": [kmin, kmax],
        "roles": roles,
        "resources": sorted(draw(st.lists(st.sampled_from(resources), unique=True))) if resources else [],
        "duration": draw(st.integers(1, 12)),
        "weight": draw(positive_floats),
    })
    return op


_PROFILE_NUMBERS = ("spacing", "reach", "reference_reach", "reference_time", "rho_conf", "clearance",
                    "role_target_offset", "retreat_fraction", "speed", "joint_speed", "payload")


@st.composite
def _settings(draw: Any, complete: bool) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key in _PROFILE_NUMBERS:
        if complete or draw(st.integers(0, 5)) == 0:
            out[key] = draw(positive_floats)
    if complete or draw(st.integers(0, 5)) == 0:
        out["robot_model"] = draw(names)
    if complete or draw(st.integers(0, 5)) == 0:
        out["tools"] = draw(st.lists(names, max_size=3))
    if complete:
        out["durations"] = {k: draw(st.integers(1, 5)) for k in ("pick", "handoff", "deliver")}
    elif draw(st.integers(0, 5)) == 0:
        keys = draw(st.lists(st.sampled_from(["pick", "handoff", "deliver"]), min_size=1, unique=True))
        out["durations"] = {k: draw(st.integers(1, 5)) for k in keys}
    for key in ("motion_planning", "trajectory_conflicts"):
        if complete or draw(st.integers(0, 5)) == 0:
            out[key] = draw(st.booleans())
    return out


@st.composite
def profiles(draw: Any) -> dict[str, Any]:
    """A schema-valid profile IR (all settings explicit, a few variants)."""
    ir: dict[str, Any] = {"ir_version": IR, "kind": "profile", "id": draw(names)}
    if draw(st.booleans()):
        ir["doc"] = draw(docs)
    ir.update(draw(_settings(True)))
    ir["variants"] = draw(st.dictionaries(names, _settings(False), max_size=3))
    return ir


@st.composite
def scenarios(draw: Any) -> dict[str, Any]:
    """A schema-valid scenario IR in canonical form."""
    ir: dict[str, Any] = {"ir_version": IR, "kind": "scenario", "id": draw(names)}
    if draw(st.booleans()):
        ir["doc"] = draw(docs)
    batch = draw(st.booleans())
    ir.update({
        "family": draw(names),
        "level": draw(names),
        "grid": {"rows": draw(st.integers(1, 9)), "cols": draw(st.integers(1, 9)),
                 "topology": draw(st.sampled_from(["moore", "von_neumann", "line"])),
                 "radius": draw(st.integers(1, 3))},
        "recipes": draw(st.lists(names, min_size=1, max_size=3)),
        "profile": {"id": draw(names), "variant": draw(st.one_of(st.none(), names))},
        "release": {"interval": draw(st.integers(1, 20)), "wip_cap": draw(st.integers(1, 12))},
        "evaluation": ({"mode": "batch", "batch_size": draw(st.integers(1, 50)), "timeout": draw(st.integers(1, 2000))}
                       if batch else {"mode": "continuing", "horizon": draw(st.integers(1, 1000))}),
        "shelves": {"capacity": draw(st.integers(1, 9)), "replenish_interval": draw(st.integers(1, 9)),
                    "extra_access_probability": draw(st.sampled_from([0.0, 0.3, 0.5, 1.0]))},
        "coordination": {"support_timeout": draw(st.integers(0, 5)), "switch_lock": draw(st.integers(0, 3)),
                         "support_visible": draw(st.booleans()), "bilateral_handoff": draw(st.booleans())},
        "products": {"mass": sorted([draw(positive_floats), draw(positive_floats)]),
                     "due_slack": draw(positive_floats), "due_slack_jitter": draw(positive_floats)},
        "resources": draw(st.dictionaries(names, st.integers(1, 4), max_size=2)),
    })
    if draw(st.booleans()):
        suite: dict[str, Any] = {"official": draw(st.booleans())}
        if draw(st.booleans()):
            suite["prefix"] = draw(names)
        if draw(st.booleans()):
            suite["generation_seed_base"] = draw(st.integers(0, 10**6))
            suite["execution_seed_base"] = draw(st.integers(0, 10**6))
        ir["suite"] = suite
    return ir
