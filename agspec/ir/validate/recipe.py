"""Recipe checks (spec chapter 02, RC-*; codes AG30x-AG39x): names, precedence, material flow,
XOR groups, arity, roles, durations, weights, value and resources."""

from __future__ import annotations

import itertools
import math
from collections import Counter
from dataclasses import dataclass, replace
from typing import Iterator, Mapping

import networkx as nx

from agspec.diagnostics import Issue
from agspec.ir import topology
from agspec.ir.validate.common import (
    Json,
    MAX_CYCLES,
    MAX_ROUTES,
    _dict,
    _did_you_mean,
    _err,
    _is_int,
    _is_num,
    _list,
    _ptr,
    _q,
    _str,
    _warn,
)


@dataclass(frozen=True)
class _Op:
    index: int  # position in the IR list (pointers use it)
    id: str
    ir: dict

    @property
    def inputs(self) -> list[str]:
        return [t for t in _list(self.ir.get("inputs")) if isinstance(t, str)]

    @property
    def outputs(self) -> list[str]:
        return [t for t in _list(self.ir.get("outputs")) if isinstance(t, str)]

    @property
    def after(self) -> list[str]:
        return [p for p in _list(self.ir.get("after")) if isinstance(p, str)]

    def ptr(self, *parts: object) -> str:
        return _ptr("operations", self.index, *parts)


@dataclass(frozen=True)
class _RecipeView:
    id: str
    raw: tuple[str, ...]
    ops: tuple[_Op, ...]  # first occurrence of every id, IR order
    groups: dict[str, tuple[int, tuple[str, ...]]]  # group id -> (index, known distinct alternatives)
    group_of: dict[str, str]  # alternative -> its (first) group

    @property
    def op_ids(self) -> set[str]:
        return {op.id for op in self.ops}

    def op(self, op_id: str) -> _Op:
        return next(op for op in self.ops if op.id == op_id)


def recipe_view(ir: Json) -> _RecipeView:
    """A tolerant index of a recipe IR: first occurrence of every operation and group id."""
    ops: list[_Op] = []
    seen: set[str] = set()
    for k, op in enumerate(_list(_dict(ir).get("operations"))):
        oid = _str(_dict(op).get("id"))
        if oid is not None and oid not in seen:
            seen.add(oid)
            ops.append(_Op(k, oid, op))
    groups: dict[str, tuple[int, tuple[str, ...]]] = {}
    group_of: dict[str, str] = {}
    for g, group in enumerate(_list(_dict(ir).get("xor"))):
        gid = _str(_dict(group).get("id"))
        if gid is None or gid in groups or gid in seen:
            continue
        alts = []
        for alt in _list(_dict(group).get("alternatives")):
            if isinstance(alt, str) and alt in seen and alt not in group_of:
                group_of[alt] = gid
                alts.append(alt)
        groups[gid] = (g, tuple(alts))
    raw = tuple(dict.fromkeys(t for t in _list(_dict(ir).get("raw")) if isinstance(t, str)))
    return _RecipeView(str(_dict(ir).get("id")), raw, tuple(ops), groups, group_of)


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
    issues += _check_material(view)
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
                out.append(_err(
                    "AG302", f"operation `{op.id}` runs after `{pred}`, which is neither an operation "
                    f"nor an XOR group of this recipe{_did_you_mean(pred, known)}",
                    op.ptr("after", m), "name an operation or an XOR group declared in this recipe"))
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
                out.append(_err("AG321", f"XOR group `{gid}` lists `{alt}`, which is not an operation "
                                f"of this recipe{_did_you_mean(alt, ids)}", where,
                                "list operations declared in this recipe"))
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
                out.append(_err(
                    "AG341", f"role `{name}` of `{op.id}` is bound to `{binds}`, which `{op.id}` does not "
                    f"consume{_did_you_mean(binds, inputs)}", op.ptr("roles", r, "binds"),
                    f"bind the role to one of the inputs ({_q(inputs)}) or leave it unbound"))
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
                out.append(_warn(
                    "AG360", f"operation `{op.id}` uses resource `{res}`, which this recipe does not "
                    f"declare{_did_you_mean(res, declared)}; every scenario using the recipe must declare it",
                    op.ptr("resources", m), f"declare `{res}` with a capacity in the recipe's resources"))
    return out


# ---------------------------------------------------------------------------------------------
# Material semantics per XOR route (RC-MATERIAL)
# ---------------------------------------------------------------------------------------------


Route = Mapping[str, str]  # XOR group id -> chosen alternative


def routes(view: _RecipeView, limit: int = MAX_ROUTES) -> list[dict[str, str]]:
    """RC-XOR: the routes of a recipe — one chosen alternative per XOR group (at most ``limit``)."""
    groups = [(gid, alts) for gid, (_, alts) in view.groups.items() if alts]
    choices = itertools.product(*(alts for _, alts in groups))
    return [dict(zip((gid for gid, _ in groups), pick)) for pick in itertools.islice(choices, limit)]


def _route_count(view: _RecipeView) -> int:
    return math.prod(len(alts) for _, alts in view.groups.values() if alts)


def route_ops(view: _RecipeView, route: Route) -> list[_Op]:
    """RC-XOR: the operations executed on a route: all but the alternatives not chosen."""
    excluded = {alt for gid, (_, alts) in view.groups.items() for alt in alts if route.get(gid) != alt}
    return [op for op in view.ops if op.id not in excluded]


def route_graph(view: _RecipeView, route: Route) -> nx.DiGraph:
    """RC-PRECEDENCE on one route: a group entry in `after` stands for the chosen alternative."""
    ops = route_ops(view, route)
    on_route = {op.id for op in ops}
    graph = nx.DiGraph()
    graph.add_nodes_from(on_route)
    for op in ops:
        for pred in op.after:
            src = route.get(pred) if pred in view.groups else pred
            if src in on_route:
                graph.add_edge(src, op.id)
    return graph


@dataclass(frozen=True)
class _Finding:
    issue: Issue

    @property
    def key(self) -> tuple[str, str]:
        return (self.issue.code, self.issue.pointer)


def _route_findings(view: _RecipeView, route: Route) -> list[_Finding]:
    """RC-MATERIAL on one route: inputs available from raw material or a (transitive) predecessor,
    every token produced and consumed at most once, exactly one terminal output, raws all used."""
    ops = route_ops(view, route)
    graph = route_graph(view, route)
    producers: dict[str, list[tuple[_Op, int]]] = {}
    consumers: dict[str, list[tuple[_Op, int]]] = {}
    for op in ops:
        for n, tok in enumerate(_list(op.ir.get("outputs"))):
            if isinstance(tok, str):
                producers.setdefault(tok, []).append((op, n))
        for m, tok in enumerate(_list(op.ir.get("inputs"))):
            if isinstance(tok, str):
                consumers.setdefault(tok, []).append((op, m))
    found: list[_Finding] = []
    found += _unavailable_inputs(view, ops, graph, producers)
    found += _multiple_uses(consumers, producers)
    found += _terminal_outputs(ops, graph, producers, consumers)
    found += _unused_raw(view, consumers)
    return found


def _unavailable_inputs(view, ops, graph, producers) -> Iterator[_Finding]:
    for op in ops:
        before = nx.ancestors(graph, op.id)
        for m, tok in enumerate(_list(op.ir.get("inputs"))):
            if not isinstance(tok, str) or tok in view.raw:
                continue
            makers = [p.id for p, _ in producers.get(tok, [])]
            if any(p in before for p in makers):
                continue
            if makers:
                maker = makers[0]
                ref = view.group_of.get(maker, maker)
                msg = (f"operation `{op.id}` consumes `{tok}`, which `{maker}` produces, but `{maker}` is not "
                       f"a predecessor of `{op.id}`")
                hint = f"add `after {ref}` to `{op.id}`"
            else:
                msg = (f"operation `{op.id}` consumes `{tok}`, which no predecessor produces and which "
                       "is not a raw material")
                hint = f"declare `{tok}` as raw material, or produce it in an operation `{op.id}` runs after"
            yield _Finding(_err("AG305", msg, op.ptr("inputs", m), hint))


def _multiple_uses(consumers, producers) -> Iterator[_Finding]:
    for tok, uses in consumers.items():
        for op, m in uses[1:]:
            first = uses[0][0].id
            yield _Finding(_err(
                "AG308", f"`{tok}` is consumed twice (by `{first}` and by `{op.id}`); a material item "
                "is used up by the operation that consumes it", op.ptr("inputs", m),
                "consume every token once; produce a second token if two operations need material"))
    for tok, makes in producers.items():
        for op, n in makes[1:]:
            yield _Finding(_err(
                "AG309", f"`{tok}` is produced twice (by `{makes[0][0].id}` and by `{op.id}`)",
                op.ptr("outputs", n),
                "give each intermediate its own name, or make the producers alternatives of an XOR group"))


def _terminal_outputs(ops, graph, producers, consumers) -> Iterator[_Finding]:
    unconsumed = [tok for tok in producers if tok not in consumers]
    if not unconsumed:
        yield _Finding(_err("AG307", "the recipe has no terminal output: every produced token is "
                            "consumed again (or there are no operations)", _ptr("operations"),
                            "the last operation should produce the finished product, e.g. `FINAL`"))
        return
    if len(unconsumed) == 1:
        return
    if "FINAL" in unconsumed:
        terminal = "FINAL"
    else:  # the output of the deepest operation (most predecessors), later declaration on ties
        def depth(tok: str) -> tuple[int, int]:
            op = producers[tok][0][0]
            return (len(nx.ancestors(graph, op.id)), op.index)
        terminal = max(unconsumed, key=depth)
    for tok in unconsumed:
        if tok == terminal:
            continue
        op, n = producers[tok][0]
        yield _Finding(_err(
            "AG306", f"`{tok}`, the output of `{op.id}`, is never consumed; only the terminal product "
            f"(`{terminal}`) may be left over", op.ptr("outputs", n),
            f"consume `{tok}` in a later operation (which runs after `{op.id}`), or remove `{op.id}`"))


def _unused_raw(view, consumers) -> Iterator[_Finding]:
    for m, tok in enumerate(view.raw):
        if tok not in consumers:
            yield _Finding(_warn("AG310", f"raw material `{tok}` is never consumed", _ptr("raw", m),
                                 f"consume `{tok}` in an operation, or remove it from the raw materials "
                                 "(it is never offered for picking)"))


def _route_text(route: Route) -> str:
    return ", ".join(f"`{g}` chooses `{a}`" for g, a in route.items())


def _check_material(view: _RecipeView) -> list[Issue]:
    """RC-MATERIAL: run the per-route checks on every route and merge identical findings.

    A finding present on every route is reported once as is; one present on some routes only is
    reported once, naming the first route where it occurs.
    """
    all_routes = routes(view)
    out: list[Issue] = []
    if _route_count(view) > len(all_routes):
        out.append(_warn("AG390", f"recipe has {_route_count(view)} XOR routes; only the first "
                         f"{len(all_routes)} were checked", _ptr("xor"),
                         "split the recipe or reduce the number of alternatives"))
    first: dict[tuple[str, str], tuple[Issue, Route]] = {}
    seen_on: Counter[tuple[str, str]] = Counter()
    for route in all_routes:
        keys_here = set()
        for finding in _route_findings(view, route):
            if finding.key in keys_here:
                continue
            keys_here.add(finding.key)
            first.setdefault(finding.key, (finding.issue, route))
            seen_on[finding.key] += 1
    for key, (issue, route) in first.items():
        if seen_on[key] < len(all_routes):
            issue = replace(issue, message=f"{issue.message} (on the route where {_route_text(route)})")
        out.append(issue)
    return out


def terminal_token(ir: Json) -> str | None:
    """RC-MATERIAL: the terminal product token (the one output no operation consumes), if unique."""
    view = recipe_view(ir)
    consumed = {t for op in view.ops for t in op.inputs}
    produced = list(dict.fromkeys(t for op in view.ops for t in op.outputs if t not in consumed))
    return produced[0] if len(produced) == 1 else None
