"""Recipe checks (spec chapter 02, RC-*; codes AG30x-AG39x): names, precedence, the material
shape of each operation, XOR groups, arity, roles, durations, weights, value and resources.

Material flow per XOR route (RC-MATERIAL) is checked in :mod:`agspec.ir.validate.material`; the
recipe view the checks read is :mod:`agspec.ir.validate.view`'s.
"""

from __future__ import annotations

import networkx as nx

from agspec.formats.diagnostics import Issue
from agspec.ir import topology
from agspec.ir.validate.common import MAX_CYCLES, Json, _dict, _did_you_mean, _err, _fixable, _is_int, _is_num, _list
from agspec.ir.validate.common import _ptr, _q, _str, _warn
from agspec.ir.validate.material import check_material, route_graph, route_ops, routes
from agspec.ir.validate.view import _Op, _RecipeView, recipe_view

# recipe_view and the route functions are importable from here as well as from their own modules
__all__ = ["arity_of", "recipe_view", "route_graph", "route_ops", "routes", "terminal_token", "validate_recipe"]


def _precedence_graph(view: _RecipeView) -> nx.DiGraph:
    """RC-PRECEDENCE: edge p -> o when o runs after p; a group entry stands for every alternative.

    Each edge remembers the ``after`` entry that created it (attribute ``ptr``).
    """
    graph = nx.DiGraph()
    graph.add_nodes_from(op.id for op in view.ops)
    ids = view.op_ids
    for op in view.ops:
        for m, pred in enumerate(_list(op.ir.get("after"))):
            if not isinstance(pred, str):
                continue
            sources = view.groups[pred][1] if pred in view.groups else ((pred,) if pred in ids else ())
            for src in sources:
                if not graph.has_edge(src, op.id):
                    graph.add_edge(src, op.id, ptr=op.ptr("after", m), target_index=op.index)
    return graph


# =============================================================================================
# Recipe checks (RC-*)
# =============================================================================================


def validate_recipe(ir: Json, k_topo: int | None = None) -> list[Issue]:
    """RC-*: all semantic checks of one recipe IR.

    ``k_topo`` is the coalition bound of the grid the recipe will run on; a recipe checked on its
    own uses the default v1 topology (Moore radius 1: 4, D-KTOPO).
    """
    bound = topology.default_k_topo() if k_topo is None else k_topo
    view = recipe_view(ir)
    issues: list[Issue] = []
    issues += _check_unique_names(ir, view)
    issues += _check_after(view)
    issues += _check_cycles(view)
    issues += _check_op_material_shape(view)
    issues += _check_xor(ir, view)
    issues += _check_arity(view, bound)
    issues += _check_roles(view)
    issues += _check_numbers(ir, view)
    issues += _check_resources(ir, view)
    issues += check_material(view)
    return issues


def _check_unique_names(ir: Json, view: _RecipeView) -> list[Issue]:
    """RC-NAMES: operation ids, raw materials and XOR group ids are unique; groups don't shadow ops."""
    out: list[Issue] = []
    seen: set[str] = set()
    for k, op in enumerate(_list(_dict(ir).get("operations"))):
        oid = _str(_dict(op).get("id"))
        if oid is None:
            continue
        if oid in seen:
            out.append(_err("AG301", f"operation `{oid}` is declared twice", _ptr("operations", k, "id"),
                            "give every operation of a recipe its own name"))
        seen.add(oid)
    raws: set[str] = set()
    for m, tok in enumerate(_list(_dict(ir).get("raw"))):
        if isinstance(tok, str) and tok in raws:
            out.append(_err("AG304", f"raw material `{tok}` is declared twice", _ptr("raw", m),
                            f"remove the second `{tok}` from the raw materials"))
        if isinstance(tok, str):
            raws.add(tok)
    gids: set[str] = set()
    for g, group in enumerate(_list(_dict(ir).get("xor"))):
        gid = _str(_dict(group).get("id"))
        if gid is None:
            continue
        if gid in gids:
            out.append(_err("AG325", f"XOR group `{gid}` is declared twice", _ptr("xor", g, "id"),
                            "give every XOR group its own name"))
        elif gid in seen:
            out.append(_err("AG325", f"XOR group `{gid}` has the same name as an operation",
                            _ptr("xor", g, "id"),
                            "`after` entries name operations or groups, so the names must differ"))
        gids.add(gid)
    return out


def _check_after(view: _RecipeView) -> list[Issue]:
    """RC-PRECEDENCE, RC-XOR: `after` names known operations or XOR groups, never an alternative."""
    out: list[Issue] = []
    known = view.op_ids | set(view.groups)
    for op in view.ops:
        for m, pred in enumerate(_list(op.ir.get("after"))):
            if not isinstance(pred, str):
                continue
            if pred not in known:
                out.append(_fixable(_err(
                    "AG302", f"operation `{op.id}` runs after `{pred}`, which is neither an operation "
                    f"nor an XOR group of this recipe{_did_you_mean(pred, known)}",
                    op.ptr("after", m), "name an operation or an XOR group declared in this recipe"), pred, known))
            elif pred in view.group_of:
                group = view.group_of[pred]
                out.append(_err(
                    "AG323", f"operation `{op.id}` runs after `{pred}`, an alternative of XOR group "
                    f"`{group}`; it would wait forever on routes that choose another alternative",
                    op.ptr("after", m), f"write `after {group}` (the chosen alternative of the group)"))
    return out


def _check_cycles(view: _RecipeView) -> list[Issue]:
    """RC-PRECEDENCE: the precedence relation (groups expanded to their alternatives) is a DAG.

    Each cycle (networkx ``find_cycle``) is reported once, at the `after` entry most likely to be
    the mistake: an edge not backed by material flow (the predecessor produces nothing the
    operation consumes), ties broken by the later-declared target.
    """
    graph = _precedence_graph(view)
    outputs = {op.id: set(op.outputs) for op in view.ops}
    inputs = {op.id: set(op.inputs) for op in view.ops}

    def blame(edge: tuple[str, str]) -> tuple[bool, int]:
        u, v = edge[0], edge[1]
        return (not (outputs[u] & inputs[v]), graph.edges[u, v]["target_index"])

    out: list[Issue] = []
    for _ in range(MAX_CYCLES):
        try:
            cycle = nx.find_cycle(graph)
        except nx.NetworkXNoCycle:
            break
        closing = max(cycle, key=blame)
        start = cycle.index(closing)
        ordered = cycle[start + 1:] + cycle[: start + 1]
        path = " -> ".join([ordered[0][0], *(v for _, v in ordered)])
        out.append(_err(
            "AG303", f"precedence cycle: {path}", graph.edges[closing[0], closing[1]]["ptr"],
            f"remove `{closing[0]}` (or its group) from the `after` list of `{closing[1]}`; "
            "recipe precedence must be acyclic"))
        graph.remove_edge(closing[0], closing[1])
    return out


def _check_op_material_shape(view: _RecipeView) -> list[Issue]:
    """RC-MATERIAL: every operation consumes at least one token and (v1) produces exactly one;
    an output never reuses the name of a raw material."""
    out: list[Issue] = []
    for op in view.ops:
        inputs, outputs = op.ir.get("inputs"), op.ir.get("outputs")
        if isinstance(inputs, list) and not inputs:
            out.append(_err("AG312", f"operation `{op.id}` consumes nothing", op.ptr("inputs"),
                            "every operation transforms at least one raw material or intermediate"))
        if isinstance(outputs, list) and len(outputs) != 1:
            out.append(_err("AG311", f"operation `{op.id}` has {len(outputs)} outputs; "
                            "AssemblyGrid v1 operations produce exactly one", op.ptr("outputs"),
                            "split the operation, or produce one combined subassembly"))
        for n, tok in enumerate(_list(outputs)):
            if tok in view.raw:
                out.append(_err("AG309", f"operation `{op.id}` produces `{tok}`, which is also a raw "
                                "material", op.ptr("outputs", n),
                                f"rename the output, or drop `{tok}` from the raw materials"))
    return out


def _check_xor(ir: Json, view: _RecipeView) -> list[Issue]:
    """RC-XOR: groups have >= 2 known alternatives with identical outputs; an op is in <= 1 group."""
    out: list[Issue] = []
    member_of: dict[str, str] = {}
    ids = view.op_ids
    for g, group in enumerate(_list(_dict(ir).get("xor"))):
        gid = _str(_dict(group).get("id")) or f"#{g}"
        alts = _list(_dict(group).get("alternatives"))
        first_outputs: tuple[str, list[str]] | None = None
        for a, alt in enumerate(alts):
            if not isinstance(alt, str):
                continue
            where = _ptr("xor", g, "alternatives", a)
            if alt not in ids:
                out.append(_fixable(_err("AG321", f"XOR group `{gid}` lists `{alt}`, which is not an operation "
                                         f"of this recipe{_did_you_mean(alt, ids)}", where,
                                         "list operations declared in this recipe"), alt, ids))
                continue
            if alt in member_of:
                msg = (f"XOR group `{gid}` lists `{alt}` twice" if member_of[alt] == gid
                       else f"operation `{alt}` is an alternative of both `{member_of[alt]}` and `{gid}`")
                out.append(_err("AG324", msg, where, "an operation belongs to at most one XOR group, once"))
                continue
            member_of[alt] = gid
            outputs = sorted(view.op(alt).outputs)
            if first_outputs is None:
                first_outputs = (alt, outputs)
            elif outputs != first_outputs[1]:
                out.append(_err(
                    "AG322", f"alternatives of XOR group `{gid}` must produce the same output: `{alt}` "
                    f"produces {_q(outputs) or 'nothing'}, `{first_outputs[0]}` produces "
                    f"{_q(first_outputs[1]) or 'nothing'}", where,
                    "whichever alternative runs, later operations consume the same token"))
        if len({a for a in alts if isinstance(a, str)}) < 2:
            out.append(_err("AG320", f"XOR group `{gid}` needs at least two alternatives, has "
                            f"{len({a for a in alts if isinstance(a, str)})}",
                            _ptr("xor", g, "alternatives"),
                            "add another alternative, or drop the group and use the operation directly"))
    return out


def arity_of(op: _Op) -> tuple[int, int] | None:
    """RC-ARITY: (kmin, kmax) of a well-formed arity, else None."""
    arity = op.ir.get("arity")
    if isinstance(arity, list) and len(arity) == 2 and all(_is_int(k) for k in arity):
        kmin, kmax = int(arity[0]), int(arity[1])
        if 1 <= kmin <= kmax:
            return kmin, kmax
    return None


def _check_arity(view: _RecipeView, k_topo: int) -> list[Issue]:
    """RC-ARITY: 1 <= kmin <= kmax, kmin <= k_topo, and the smallest team can hold every input."""
    out: list[Issue] = []
    for op in view.ops:
        arity = op.ir.get("arity")
        if not (isinstance(arity, list) and len(arity) == 2 and all(_is_int(k) for k in arity)):
            if "arity" in op.ir:
                out.append(_err("AG330", f"operation `{op.id}`: arity must be two integers [kmin, kmax]",
                                op.ptr("arity"), "write the team size as `team 2` or `team 2..4` (IR: `[kmin, kmax]`)"))
            continue
        kmin, kmax = int(arity[0]), int(arity[1])
        if kmin < 1:
            out.append(_err("AG330", f"operation `{op.id}` allows teams of {kmin} robots; the minimum "
                            "team size must be at least 1", op.ptr("arity", 0),
                            "every operation is performed by at least one robot"))
            continue
        if kmin > kmax:
            out.append(_err("AG330", f"operation `{op.id}`: minimum team size {kmin} exceeds the "
                            f"maximum {kmax}", op.ptr("arity"), f"the smaller bound comes first: `team {kmax}..{kmin}`"))
            continue
        if kmin > k_topo:
            out.append(_err(
                "AG331", f"operation `{op.id}` needs at least {kmin} robots, but the manipulation "
                f"topology allows coalitions of at most {k_topo} (k_topo = clique number of G_manip)",
                op.ptr("arity", 0), f"lower the minimum team size to {k_topo} or less"))
        n_inputs = len(set(op.inputs))
        if n_inputs > kmin:
            out.append(_err(
                "AG332", f"operation `{op.id}` consumes {n_inputs} inputs, but its smallest team has "
                f"{kmin} robot{'s' if kmin != 1 else ''}; each input is held by a different member",
                op.ptr("inputs"), f"raise the minimum team size to {n_inputs}"))
    return out


def _check_roles(view: _RecipeView) -> list[Issue]:
    """RC-ROLES: one role per member of the largest team; bindings name inputs, each at most once.

    The canonical assignment (R-ROLE-ASSIGNMENT) gives bound roles to the holders of their inputs
    and the remaining roles, in recipe order, to the remaining members row-major: a size-k team
    instantiates exactly k roles iff there are kmax roles and kmax >= k.
    """
    out: list[Issue] = []
    for op in view.ops:
        roles = op.ir.get("roles")
        if not isinstance(roles, list):
            continue
        arity = arity_of(op)
        if arity is not None and len(roles) != arity[1]:
            out.append(_err(
                "AG340", f"operation `{op.id}` declares {len(roles)} role{'s' if len(roles) != 1 else ''}"
                f" but its largest team has {arity[1]} robot{'s' if arity[1] != 1 else ''}; "
                "v1 needs exactly one role per member", op.ptr("roles"),
                f"declare {arity[1]} roles (material-bound roles first, then helpers in order)"))
        names: set[str] = set()
        bound: dict[str, str] = {}
        inputs = op.inputs
        for r, role in enumerate(roles):
            name, binds = _str(_dict(role).get("name")), _dict(role).get("binds")
            if name is not None:
                if name in names:
                    out.append(_err("AG343", f"operation `{op.id}` declares role `{name}` twice",
                                    op.ptr("roles", r, "name"), "role names are unique within an operation"))
                names.add(name)
            if not isinstance(binds, str):
                continue
            if binds not in inputs:
                out.append(_fixable(_err(
                    "AG341", f"role `{name}` of `{op.id}` is bound to `{binds}`, which `{op.id}` does not "
                    f"consume{_did_you_mean(binds, inputs)}", op.ptr("roles", r, "binds"),
                    f"bind the role to one of the inputs ({_q(inputs)}) or leave it unbound"), binds, inputs))
            elif binds in bound:
                out.append(_err(
                    "AG342", f"input `{binds}` of `{op.id}` is bound to two roles, `{bound[binds]}` and "
                    f"`{name}`; one robot holds it", op.ptr("roles", r, "binds"),
                    "bind each input to at most one role"))
            else:
                bound[binds] = str(name)
    return out


def _check_numbers(ir: Json, view: _RecipeView) -> list[Issue]:
    """RC-DURATION, RC-WEIGHT, RC-VALUE: durations are positive integers, weights and value > 0."""
    out: list[Issue] = []
    for op in view.ops:
        if "duration" in op.ir:
            d = op.ir["duration"]
            if not (_is_int(d) and d >= 1):
                out.append(_err("AG350", f"operation `{op.id}`: duration must be a positive integer "
                                f"number of ticks, got {d!r}", op.ptr("duration"),
                                "productive durations are whole ticks >= 1"))
        if "weight" in op.ir:
            w = op.ir["weight"]
            if not (_is_num(w) and w > 0):
                out.append(_err("AG351", f"operation `{op.id}`: weight must be a number > 0, got {w!r}",
                                op.ptr("weight"), "productive weights are positive (default 1.0)"))
    if "value" in _dict(ir):
        v = ir["value"]
        if not (_is_num(v) and v > 0):
            out.append(_err("AG352", f"recipe `{view.id}`: product value must be a number > 0, got {v!r}",
                            _ptr("value"), "official recipes use value 1.0"))
    return out


def _check_resources(ir: Json, view: _RecipeView) -> list[Issue]:
    """RC-RESOURCES: declared capacities are integers >= 1; operations use declared resources once."""
    out: list[Issue] = []
    declared = _dict(_dict(ir).get("resources"))
    for name, cap in declared.items():
        if not (_is_int(cap) and cap >= 1):
            out.append(_err("AG361", f"resource `{name}`: capacity must be an integer >= 1, got {cap!r}",
                            _ptr("resources", name), "a resource can serve at least one activity at a time"))
    for op in view.ops:
        seen: set[str] = set()
        for m, res in enumerate(_list(op.ir.get("resources"))):
            if not isinstance(res, str):
                continue
            if res in seen:
                out.append(_err("AG362", f"operation `{op.id}` lists resource `{res}` twice",
                                op.ptr("resources", m), "list each exclusive resource once"))
                continue
            seen.add(res)
            if res not in declared:
                out.append(_fixable(_warn(
                    "AG360", f"operation `{op.id}` uses resource `{res}`, which this recipe does not "
                    f"declare{_did_you_mean(res, declared)}; every scenario using the recipe must declare it",
                    op.ptr("resources", m), f"declare `{res}` with a capacity in the recipe's resources"),
                    res, declared))
    return out


def terminal_token(ir: Json) -> str | None:
    """RC-MATERIAL: the terminal product token (the one output no operation consumes), if unique."""
    view = recipe_view(ir)
    consumed = {t for op in view.ops for t in op.inputs}
    produced = list(dict.fromkeys(t for op in view.ops for t in op.outputs if t not in consumed))
    return produced[0] if len(produced) == 1 else None
