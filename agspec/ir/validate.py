"""Semantic checks on IR documents (spec chapters "Recipes", "Profiles", "Scenarios", "Instances").

Every check returns :class:`~agspec.diagnostics.Issue` values located by a JSON Pointer into the
IR, so that the CLI can place them in the ``.ag`` source through the source map.  All problems of a
document are reported in one run; no check raises on malformed input (schema problems are the
schema's to report, AG2xx — the checks here skip values of the wrong type instead of crashing).

Codes (documented with an example each in spec/09-formats.md):
  AG30x names, precedence and material   AG32x XOR groups   AG33x arity   AG34x roles
  AG35x durations, weights, value         AG36x resources    AG39x limits of the analysis
  AG40x profile   AG41x/AG42x scenario   AG5xx instance realization
Realizability of a scenario under its geometry profile (AG45x) needs the geometry model and
lives in :mod:`agspec.interp.realizability` (ir/ never imports interp/).

Public API::

    validate_recipe(ir, k_topo=None) -> list[Issue]
    validate_profile(ir) -> list[Issue]
    validate_scenario(ir, resolver) -> list[Issue]
    validate_instance(ir) -> list[Issue]
    validate_document(ir, resolver) -> list[Issue]

``resolver`` is anything with ``get(kind, name) -> ir | None`` (:class:`Resolver`).
"""

from __future__ import annotations

import difflib
import itertools
import math
from collections import Counter
from dataclasses import dataclass, replace
from typing import Any, Iterable, Iterator, Mapping, Protocol, Sequence

import networkx as nx

from agspec.diagnostics import Issue, json_pointer
from agspec.ir import topology

Json = Any
MAX_ROUTES = 1024  # AG390: XOR routes analysed per recipe
MAX_CYCLES = 16  # AG303: precedence cycles reported per recipe
REACH_TOLERANCE = 1e-9  # G-REACH


class Resolver(Protocol):
    """Names -> IR documents (``agspec.load.Resolver`` implements it)."""

    def get(self, kind: str, name: str) -> Json | None: ...


# =============================================================================================
# Small helpers
# =============================================================================================


def _ptr(*parts: object) -> str:
    return json_pointer(*parts)


def _err(code: str, message: str, pointer: str, hint: str | None = None) -> Issue:
    return Issue(code=code, message=message, pointer=pointer, hint=hint)


def _warn(code: str, message: str, pointer: str, hint: str | None = None) -> Issue:
    return Issue(code=code, message=message, pointer=pointer, hint=hint, severity="warning")


def _is_num(x: object) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def _is_int(x: object) -> bool:
    """Integers, including integral floats (JSON Schema's "integer" accepts 3.0)."""
    return _is_num(x) and float(x) == int(x)


def _list(x: object) -> list:
    return x if isinstance(x, list) else []


def _dict(x: object) -> dict:
    return x if isinstance(x, dict) else {}


def _str(x: object) -> str | None:
    return x if isinstance(x, str) else None


def _q(names: Iterable[object]) -> str:
    return ", ".join(f"`{n}`" for n in names)


def _did_you_mean(name: object, known: Iterable[str]) -> str:
    matches = difflib.get_close_matches(str(name), sorted(set(known)), n=1)
    return f"; did you mean `{matches[0]}`?" if matches else ""


def _prefixed(prefix: str, issues: Iterable[Issue]) -> list[Issue]:
    return [replace(i, pointer=prefix + i.pointer) for i in issues]


# =============================================================================================
# Recipe view: tolerant indexing of a recipe IR
# =============================================================================================


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


# =============================================================================================
# Profile checks (PR-*)
# =============================================================================================


PROFILE_POSITIVE = ("spacing", "reach", "reference_reach", "reference_time", "speed", "joint_speed", "payload")
PROFILE_NON_NEGATIVE = ("rho_conf", "clearance", "role_target_offset")
PROFILE_FRACTIONS = ("retreat_fraction",)
PROFILE_DURATIONS = ("pick", "handoff", "deliver")
PROFILE_FIELDS = frozenset(
    PROFILE_POSITIVE + PROFILE_NON_NEGATIVE + PROFILE_FRACTIONS
    + ("durations", "robot_model", "tools", "motion_planning", "trajectory_conflicts")
)
NOT_OVERRIDABLE = frozenset({"ir_version", "kind", "id", "variants", "variant", "doc", "meta"})


def validate_profile(ir: Json) -> list[Issue]:
    """PR-*: numeric ranges, logistics durations, handoff feasibility, and variant overrides."""
    profile = _dict(ir)
    issues = _check_profile_values(profile, profile, "")
    issues += _check_handoff_reach(profile, "", None)
    for name, overrides in _dict(profile.get("variants")).items():
        issues += _check_variant(profile, str(name), overrides)
    return issues


def _check_profile_values(values: Mapping, scope: Mapping, prefix: str) -> list[Issue]:
    """PR-RANGES: check the profile fields present in ``scope`` (with values from ``values``)."""
    out: list[Issue] = []
    for key in PROFILE_POSITIVE:
        if key in scope and not (_is_num(values[key]) and values[key] > 0):
            out.append(_err("AG401", f"profile `{key}` must be a number > 0, got {values[key]!r}",
                            prefix + _ptr(key), "distances, speeds and times are positive"))
    for key in PROFILE_NON_NEGATIVE:
        if key in scope and not (_is_num(values[key]) and values[key] >= 0):
            out.append(_err("AG402", f"profile `{key}` must be a number >= 0, got {values[key]!r}",
                            prefix + _ptr(key), f"use 0 to switch the `{key}` effect off"))
    for key in PROFILE_FRACTIONS:
        if key in scope and not (_is_num(values[key]) and 0 <= values[key] <= 1):
            out.append(_err("AG403", f"profile `{key}` must lie in [0, 1], got {values[key]!r}",
                            prefix + _ptr(key), "the retreat is a fraction of the approach time (v1: 0.25)"))
    durations = _dict(values.get("durations"))
    for key in PROFILE_DURATIONS:
        if key in _dict(scope.get("durations")) and not (_is_int(durations[key]) and durations[key] >= 1):
            out.append(_err("AG405", f"profile `{key}` duration must be a positive integer number of "
                            f"ticks, got {durations[key]!r}", prefix + _ptr("durations", key),
                            "v1 uses pick 2, handoff 1, deliver 2"))
    return out


def _check_handoff_reach(values: Mapping, prefix: str, overrides: Mapping | None) -> list[Issue]:
    """PR-HANDOFF-REACH: the midpoint of two diagonal Moore neighbours must be within reach.

    G-HANDOFF-POINT puts a handoff at the midpoint of the two bases, s*sqrt(2)/2 from each base for
    diagonal neighbours (G-BASE); G-REACH needs that distance <= reach + 1e-9.
    """
    spacing, reach = values.get("spacing"), values.get("reach")
    if not (_is_num(spacing) and _is_num(reach) and spacing > 0 and reach > 0):
        return []
    needed = math.hypot(0.5 * spacing, 0.5 * spacing)
    if needed <= reach + REACH_TOLERANCE:
        return []
    key = "spacing" if overrides is not None and "spacing" in overrides else "reach"
    if overrides is not None and key not in overrides:
        return []  # the base profile already has the problem; reported there
    return [_err(
        "AG404", f"reach {reach} is shorter than the distance {needed:.4f} from a base to the handoff "
        f"point of two diagonal neighbours (spacing {spacing} x sqrt(2)/2); diagonal handoffs are impossible",
        prefix + _ptr(key), f"use a reach of at least {needed:.4f} or a spacing of at most {reach * math.sqrt(2):.4f}")]


def _merge(base: Mapping, overrides: Mapping) -> dict:
    out = dict(base)
    for key, value in overrides.items():
        if isinstance(value, Mapping) and isinstance(out.get(key), Mapping):
            out[key] = _merge(out[key], value)
        else:
            out[key] = value
    return out


def _check_variant(profile: Mapping, name: str, overrides: object) -> list[Issue]:
    """PR-VARIANT: a variant overrides known profile fields only, and the result is valid."""
    prefix = _ptr("variants", name)
    if not isinstance(overrides, Mapping):
        return []
    out: list[Issue] = []
    allowed = (PROFILE_FIELDS | set(profile)) - NOT_OVERRIDABLE
    for key, value in overrides.items():
        if key not in allowed:
            out.append(_err("AG406", f"variant `{name}` overrides `{key}`, which is not a profile "
                            f"parameter{_did_you_mean(key, allowed)}", prefix + _ptr(key),
                            "variants override profile parameters such as `rho_conf` or `spacing`"))
        elif key == "durations" and isinstance(value, Mapping):
            for sub in value:
                if sub not in PROFILE_DURATIONS and sub not in _dict(profile.get("durations")):
                    out.append(_err("AG406", f"variant `{name}` overrides duration `{sub}`, which is not "
                                    "a logistics duration", prefix + _ptr("durations", sub),
                                    f"known durations: {_q(PROFILE_DURATIONS)}"))
    merged = _merge(profile, {k: v for k, v in overrides.items() if k in allowed})
    out += _check_profile_values(merged, overrides, prefix)
    if not _check_handoff_reach(profile, "", None):  # else the base profile's AG404 covers it
        out += _check_handoff_reach(merged, prefix, overrides)
    return out


# =============================================================================================
# Scenario checks (S-*)
# =============================================================================================


def validate_scenario(ir: Json, resolver: Resolver) -> list[Issue]:
    """S-*: grid, references, release, evaluation, shelves, products, resources, and the coupling
    of every recipe's coalition demand with this grid's k_topo (S-FEASIBILITY, D-KTOPO)."""
    return _validate_scenario(ir, resolver, check_variant=True)


def _validate_scenario(ir: Json, resolver: Resolver, *, check_variant: bool) -> list[Issue]:
    scenario = _dict(ir)
    issues = _check_grid(scenario)
    issues += _check_recipe_refs(scenario, resolver)
    issues += _check_profile_ref(scenario, resolver, check_variant)
    issues += _check_scenario_numbers(scenario)
    issues += _check_scenario_resources(scenario)
    issues += _check_k_topo(scenario, resolver)
    return issues


def _grid_k_topo(scenario: Mapping) -> tuple[int, str] | None:
    """(k_topo, description) of a well-formed scenario grid, else None."""
    grid = _dict(scenario.get("grid"))
    rows, cols = grid.get("rows"), grid.get("cols")
    if not (_is_int(rows) and _is_int(cols) and rows >= 1 and cols >= 1):
        return None
    topo, radius = grid.get("topology", topology.DEFAULT_TOPOLOGY), grid.get("radius", topology.DEFAULT_RADIUS)
    if not (_is_int(radius) and isinstance(topo, str)):
        return None
    try:
        k = topology.grid_k_topo(int(rows), int(cols), topo, int(radius))
    except topology.TopologyError:
        return None
    return k, f"a {int(rows)}x{int(cols)} {topo} grid (radius {int(radius)})"


def _check_grid(scenario: Mapping) -> list[Issue]:
    """S-GRID: at least 1 row and 2 columns (input and output columns differ); known topology."""
    out: list[Issue] = []
    grid = _dict(scenario.get("grid"))
    if "rows" in grid and not (_is_int(grid["rows"]) and grid["rows"] >= 1):
        out.append(_err("AG410", f"the grid needs at least 1 row, got {grid['rows']!r}", _ptr("grid", "rows"),
                        "official grids have 4 to 6 rows"))
    if "cols" in grid and not (_is_int(grid["cols"]) and grid["cols"] >= 2):
        out.append(_err("AG410", f"the grid needs at least 2 columns, got {grid['cols']!r}",
                        _ptr("grid", "cols"),
                        "raw material enters in the left column and leaves from the right one; they must differ"))
    topo = grid.get("topology", topology.DEFAULT_TOPOLOGY)
    if isinstance(topo, str) and topo not in topology.TOPOLOGIES:
        out.append(_err("AG411", f"unknown topology `{topo}`{_did_you_mean(topo, topology.TOPOLOGIES)}",
                        _ptr("grid", "topology"), f"use one of {_q(topology.TOPOLOGIES)}"))
    radius = grid.get("radius", topology.DEFAULT_RADIUS)
    if not (_is_int(radius) and radius >= 1):
        out.append(_err("AG411", f"topology radius must be an integer >= 1, got {radius!r}",
                        _ptr("grid", "radius"), "AssemblyGrid v1 uses radius 1"))
    return out


def _check_recipe_refs(scenario: Mapping, resolver: Resolver) -> list[Issue]:
    """S-MIX: the product mix is non-empty and names known recipes (a repeat skews the mix)."""
    out: list[Issue] = []
    recipes = scenario.get("recipes")
    if isinstance(recipes, list) and not recipes:
        out.append(_err("AG420", "the product mix is empty", _ptr("recipes"),
                        "list at least one recipe, e.g. `recipes supported_insert`"))
    seen: set[str] = set()
    for m, name in enumerate(_list(recipes)):
        if not isinstance(name, str):
            continue
        if name in seen:
            out.append(_warn("AG413", f"recipe `{name}` is listed twice in the product mix; releases choose "
                             "uniformly from the list, so it is drawn more often", _ptr("recipes", m),
                             "remove the repeat unless the skew is intended"))
            continue
        seen.add(name)
        if _resolve(resolver, "recipe", name) is None:
            out.append(_err("AG412", f"unknown recipe `{name}`", _ptr("recipes", m),
                            "declare the recipe in a .ag file on the search path or use a catalogue recipe"))
    return out


def _resolve(resolver: Resolver | None, kind: str, name: str) -> Json | None:
    if resolver is None:
        return None
    try:
        doc = resolver.get(kind, name)
    except (KeyError, LookupError, ValueError, OSError):
        return None
    return doc if isinstance(doc, Mapping) else None


def _check_profile_ref(scenario: Mapping, resolver: Resolver, check_variant: bool) -> list[Issue]:
    """S-PROFILE: the geometry profile exists and declares the chosen variant."""
    ref = _dict(scenario.get("profile"))
    pid = _str(ref.get("id"))
    if pid is None:
        return []
    profile = _resolve(resolver, "profile", pid)
    if profile is None:
        return [_err("AG414", f"unknown geometry profile `{pid}`", _ptr("profile", "id"),
                     "official scenarios use `abstract-v1`")]
    variant = ref.get("variant")
    variants = _dict(profile.get("variants"))
    if check_variant and isinstance(variant, str) and variant not in variants:
        known = _q(sorted(variants)) or "none"
        return [_err("AG415", f"profile `{pid}` has no variant `{variant}`{_did_you_mean(variant, variants)}",
                     _ptr("profile", "variant"), f"declared variants: {known}")]
    return []


# (section, key, kind): kind "pos_int" > 0 integer, "nonneg_int" >= 0 integer, "pos" > 0 number,
# "nonneg" >= 0 number, "prob" in [0, 1].
SCENARIO_NUMBERS: tuple[tuple[str, str, str], ...] = (
    ("release", "interval", "pos_int"),
    ("release", "wip_cap", "pos_int"),
    ("evaluation", "horizon", "pos_int"),
    ("evaluation", "batch_size", "pos_int"),
    ("evaluation", "timeout", "pos_int"),
    ("shelves", "capacity", "pos_int"),
    ("shelves", "replenish_interval", "pos_int"),
    ("shelves", "extra_access_probability", "prob"),
    ("coordination", "support_timeout", "nonneg_int"),
    ("coordination", "switch_lock", "nonneg_int"),
    ("products", "due_slack", "pos"),
    ("products", "due_slack_jitter", "nonneg"),
)

_NUMBER_RULES = {
    "pos_int": ("AG416", "an integer >= 1", lambda x: _is_int(x) and x >= 1),
    "pos": ("AG416", "a number > 0", lambda x: _is_num(x) and x > 0),
    "nonneg_int": ("AG417", "an integer >= 0", lambda x: _is_int(x) and x >= 0),
    "nonneg": ("AG417", "a number >= 0", lambda x: _is_num(x) and x >= 0),
    "prob": ("AG418", "a probability in [0, 1]", lambda x: _is_num(x) and 0 <= x <= 1),
}


def _check_scenario_numbers(scenario: Mapping) -> list[Issue]:
    """S-RELEASE, S-EVALUATION, S-SHELVES, S-COORDINATION, S-PRODUCTS: value ranges."""
    out: list[Issue] = []
    for section, key, kind in SCENARIO_NUMBERS:
        values = _dict(scenario.get(section))
        if key not in values:
            continue
        code, what, ok = _NUMBER_RULES[kind]
        if not ok(values[key]):
            out.append(_err(code, f"`{section}.{key}` must be {what}, got {values[key]!r}",
                            _ptr(section, key), _NUMBER_HINTS.get(key)))
    mass = _dict(scenario.get("products")).get("mass")
    if isinstance(mass, list):
        if not (len(mass) == 2 and all(_is_num(m) for m in mass) and 0 <= mass[0] <= mass[1]):
            out.append(_err("AG419", f"`products.mass` must be a range [min, max] with 0 <= min <= max, "
                            f"got {mass!r}", _ptr("products", "mass"), "official scenarios use [0.5, 2.0]"))
    return out


_NUMBER_HINTS = {
    "interval": "a product is offered every `interval` ticks",
    "wip_cap": "at most `wip_cap` unfinished products are in the system; at least 1",
    "horizon": "official evaluations run 400 ticks",
    "batch_size": "a batch has at least one product",
    "timeout": "a batch evaluation stops after `timeout` ticks",
    "capacity": "official shelves hold 6 units per raw material",
    "replenish_interval": "official shelves gain a unit every 5 ticks",
    "extra_access_probability": "official scenarios use 0.30",
    "support_timeout": "official scenarios use 3 ticks",
    "switch_lock": "official scenarios use 1 tick",
    "due_slack": "official scenarios use 2.2",
    "due_slack_jitter": "official scenarios use 0.5",
}


def _check_scenario_resources(scenario: Mapping) -> list[Issue]:
    """S-RESOURCES: scenario resource capacities are integers >= 0 (0 disables a resource; an
    operation that needs it is then reported by the realizability check, AG455)."""
    out: list[Issue] = []
    for name, cap in _dict(scenario.get("resources")).items():
        if not (_is_int(cap) and cap >= 0):
            out.append(_err("AG422", f"resource `{name}`: capacity must be an integer >= 0, got {cap!r}",
                            _ptr("resources", name), "capacity = how many activities may hold it at once"))
    return out


def _check_k_topo(scenario: Mapping, resolver: Resolver) -> list[Issue]:
    """S-FEASIBILITY (coalition size): kmin <= k_topo of THIS grid for every operation of the mix."""
    grid = _grid_k_topo(scenario)
    if grid is None:
        return []
    k, where = grid
    out: list[Issue] = []
    seen: set[str] = set()
    for m, name in enumerate(_list(scenario.get("recipes"))):
        if not isinstance(name, str) or name in seen:
            continue
        seen.add(name)
        recipe = _resolve(resolver, "recipe", name)
        if recipe is None:
            continue
        for op in recipe_view(recipe).ops:
            arity = arity_of(op)
            if arity is not None and arity[0] > k:
                out.append(_err(
                    "AG421", f"recipe `{name}`: operation `{op.id}` needs at least {arity[0]} robots, but "
                    f"{where} allows coalitions of at most {k} (k_topo)", _ptr("recipes", m),
                    "use a grid/topology whose manipulation graph has larger cliques (moore radius 1: 4), "
                    "or a recipe with smaller teams"))
    return out


# =============================================================================================
# Instance checks (I-*)
# =============================================================================================


class _EmbeddedResolver:
    """Resolves names against the documents embedded in an instance."""

    def __init__(self, instance: Mapping) -> None:
        self._recipes = _dict(instance.get("recipes"))
        self._profile = _dict(instance.get("profile"))

    def get(self, kind: str, name: str) -> Json | None:
        if kind == "recipe":
            return self._recipes.get(name)
        if kind == "profile" and self._profile.get("id") == name:
            return self._profile
        return None


def validate_instance(ir: Json) -> list[Issue]:
    """I-*: embedded documents are valid and of the right kind, and the realization is consistent
    with the scenario (shelves, shelf access, raw types, products)."""
    inst = _dict(ir)
    issues = _check_embedded(inst)
    issues += _check_profile_binding(inst)
    issues += _check_realization(inst)
    return issues


def _check_embedded(inst: Mapping) -> list[Issue]:
    """I-EMBEDDED: kinds, recipe keys, the recipes of the mix, and each embedded document's checks."""
    out: list[Issue] = []
    scenario, profile = _dict(inst.get("scenario")), _dict(inst.get("profile"))
    for key, doc, kind in (("scenario", scenario, "scenario"), ("profile", profile, "profile")):
        if doc and doc.get("kind") != kind:
            out.append(_err("AG501", f"the embedded {key} has kind {doc.get('kind')!r}, expected `{kind}`",
                            _ptr(key, "kind"), f"embed the {kind} IR itself"))
    recipes = _dict(inst.get("recipes"))
    for key, recipe in recipes.items():
        recipe = _dict(recipe)
        if recipe.get("kind") != "recipe":
            out.append(_err("AG501", f"embedded recipe `{key}` has kind {recipe.get('kind')!r}, expected "
                            "`recipe`", _ptr("recipes", key, "kind"), "embed recipe IR documents"))
        if recipe.get("id") != key:
            out.append(_err("AG502", f"embedded recipe is keyed `{key}` but its id is {recipe.get('id')!r}",
                            _ptr("recipes", key, "id"), "key every embedded recipe by its own id"))
        out += _prefixed(_ptr("recipes", key), validate_recipe(recipe))
    mix = [n for n in _list(scenario.get("recipes")) if isinstance(n, str)]
    for m, name in enumerate(_list(scenario.get("recipes"))):
        if isinstance(name, str) and name not in recipes:
            out.append(_err("AG503", f"recipe `{name}` of the product mix is not embedded in the instance",
                            _ptr("scenario", "recipes", m), "an instance embeds every recipe of its mix"))
    for key in recipes:
        if key not in mix:
            out.append(_warn("AG503", f"embedded recipe `{key}` is not in the scenario's product mix",
                             _ptr("recipes", key), "remove it; only recipes of the mix are released"))
    if profile:
        out += _prefixed(_ptr("profile"), validate_profile(profile))
    if scenario:
        embedded = _EmbeddedResolver(inst)
        checked = _validate_scenario(scenario, embedded, check_variant=False)
        # AG503 already reports a mix recipe that is not embedded (AG412 would repeat it); AG504
        # reports a profile mismatch (AG414 would repeat it).
        out += _prefixed(_ptr("scenario"), [i for i in checked if i.code not in ("AG412", "AG414")])
    return out


def _check_profile_binding(inst: Mapping) -> list[Issue]:
    """I-PROFILE: the embedded profile is the scenario's profile, resolved for its variant."""
    profile = _dict(inst.get("profile"))
    ref = _dict(_dict(inst.get("scenario")).get("profile"))
    if not profile or not ref:
        return []
    out: list[Issue] = []
    if profile.get("id") != ref.get("id"):
        out.append(_err("AG504", f"the embedded profile is {profile.get('id')!r} but the scenario uses "
                        f"{ref.get('id')!r}", _ptr("profile", "id"), "embed the scenario's profile"))
    if profile.get("variant") != ref.get("variant"):
        out.append(_err("AG504", f"the embedded profile is resolved for {_variant(profile.get('variant'))} "
                        f"but the scenario chooses {_variant(ref.get('variant'))}", _ptr("profile", "variant"),
                        "resolve the profile with the scenario's variant"))
    if "variants" in profile:
        out.append(_err("AG504", "the embedded profile still lists its variants; an instance embeds the "
                        "resolved profile", _ptr("profile", "variants"),
                        "apply the chosen variant and drop `variants`"))
    return out


def _variant(name: object) -> str:
    return "no variant" if name is None else f"variant `{name}`"


@dataclass(frozen=True)
class _Layout:
    rows: int
    cols: int
    spacing: float
    reach: float
    capacity: int | None


def _layout(inst: Mapping) -> _Layout | None:
    scenario, profile = _dict(inst.get("scenario")), _dict(inst.get("profile"))
    grid = _dict(scenario.get("grid"))
    rows, cols = grid.get("rows"), grid.get("cols")
    spacing, reach = profile.get("spacing"), profile.get("reach")
    if not (_is_int(rows) and _is_int(cols) and rows >= 1 and cols >= 1):
        return None
    if not (_is_num(spacing) and _is_num(reach) and spacing > 0 and reach > 0):
        return None
    cap = _dict(scenario.get("shelves")).get("capacity")
    return _Layout(int(rows), int(cols), float(spacing), float(reach), int(cap) if _is_int(cap) else None)


def _check_realization(inst: Mapping) -> list[Issue]:
    """I-REALIZATION: checks that depend on a broken part (missing recipe, malformed shelves,
    invalid recipe or profile) are skipped so that one mistake is reported once."""
    real = _dict(inst.get("realization"))
    layout = _layout(inst)
    if not real or layout is None:
        return []
    scenario = _dict(inst.get("scenario"))
    recipes = {k: _dict(v) for k, v in _dict(inst.get("recipes")).items()}
    mix_complete = all(n in recipes for n in _list(scenario.get("recipes")) if isinstance(n, str))
    out = _check_raw_types(real, scenario, recipes) if mix_complete else []
    shelves = _check_shelves(real, layout)
    out += shelves + _check_shelf_access(real, layout)
    out += _check_products(inst, real, layout, recipes, shelves_ok=not errors(shelves))
    return out


def _expected_raw_types(scenario: Mapping, recipes: Mapping[str, Mapping]) -> list[str]:
    """S-SHELF-LAYOUT: raw tokens of the mix's recipes in first-appearance order."""
    seen: list[str] = []
    for name in _list(scenario.get("recipes")):
        for tok in _list(_dict(recipes.get(name)).get("raw")) if isinstance(name, str) else []:
            if isinstance(tok, str) and tok not in seen:
                seen.append(tok)
    return seen


def _check_raw_types(real: Mapping, scenario: Mapping, recipes: Mapping[str, Mapping]) -> list[Issue]:
    """I-RAW-TYPES: the recorded raw types are those of the mix, in first-appearance order."""
    expected = _expected_raw_types(scenario, recipes)
    got = real.get("raw_types")
    if isinstance(got, list) and got != expected:
        return [_err("AG505", f"realization raw types are {got!r}, but the product mix needs {expected!r} "
                     "(first-appearance order)", _ptr("realization", "raw_types"),
                     "regenerate the instance with `agspec instance`")]
    return []


def _check_shelves(real: Mapping, layout: _Layout) -> list[Issue]:
    """I-SHELVES: one shelf per grid row, in row order; stock of raw types within [0, capacity];
    every raw type stocked somewhere; the S-SHELF-LAYOUT pattern (warning if it deviates)."""
    shelves = real.get("shelves")
    if not isinstance(shelves, list):
        return []
    out: list[Issue] = []
    raws = [t for t in _list(real.get("raw_types")) if isinstance(t, str)]
    stocked: set[str] = set()
    for k, shelf in enumerate(shelves):
        row = _dict(shelf).get("row")
        if row != k:
            out.append(_err("AG506", f"shelf {k} is for row {row!r}; shelves list rows 0..{layout.rows - 1} "
                            "in order, one per grid row", _ptr("realization", "shelves", k, "row"),
                            "regenerate the instance with `agspec instance`"))
        for tok, amount in _dict(_dict(shelf).get("stock")).items():
            where = _ptr("realization", "shelves", k, "stock", tok)
            if tok not in raws:
                out.append(_err("AG507", f"shelf row {row} stocks `{tok}`, which is not a raw material of "
                                "the product mix", where, f"raw types: {_q(raws)}"))
            elif not (_is_int(amount) and 0 <= amount <= (layout.capacity if layout.capacity is not None else amount)):
                out.append(_err("AG507", f"shelf row {row} holds {amount!r} units of `{tok}`; stock must be an "
                                f"integer in [0, {layout.capacity}]", where, "shelf capacity is per token and row"))
            stocked.add(tok)
    if len(shelves) != layout.rows:
        out.append(_err("AG506", f"the realization lists {len(shelves)} shelves for a grid of {layout.rows} rows",
                        _ptr("realization", "shelves"), "one shelf per grid row"))
    for tok in raws:
        if tok not in stocked:
            out.append(_err("AG507", f"no shelf stocks raw material `{tok}`", _ptr("realization", "shelves"),
                            "products could never source it"))
    if not out and layout.capacity is not None:
        out += _check_shelf_pattern(shelves, raws, layout)
    return out


def _check_shelf_pattern(shelves: list, raws: list[str], layout: _Layout) -> list[Issue]:
    """S-SHELF-LAYOUT: row r stocks raws[r mod n] (plus raw k on row k mod M), all at capacity."""
    from agspec.ir.instance import shelf_layout  # the generator's own layout rule

    expected = shelf_layout(layout.rows, raws, layout.capacity)
    for k, (got, want) in enumerate(zip(shelves, expected)):
        if _dict(got).get("stock") != want["stock"]:
            return [_warn("AG515", f"shelf row {k} starts with stock {_dict(got).get('stock')!r}; the "
                          f"S-SHELF-LAYOUT pattern gives {want['stock']!r}",
                          _ptr("realization", "shelves", k, "stock"),
                          "fine for a hand-made test instance; generated instances follow the pattern")]
    return []


def _reaches_shelf(robot_row: int, shelf_row: int, layout: _Layout) -> bool:
    """G-SHELF-POINT, G-REACH: robot (i, 0) reaches the shelf point (-s/2, r*s) of row r."""
    dist = math.hypot(0.5 * layout.spacing, (shelf_row - robot_row) * layout.spacing)
    return dist <= layout.reach + REACH_TOLERANCE


def _check_shelf_access(real: Mapping, layout: _Layout) -> list[Issue]:
    """I-SHELF-ACCESS (S-SHELF-ACCESS): per shelf row, in row order, the ascending left-column robot
    rows allowed to pick there: rows that reach the shelf point, always including the own row."""
    access = real.get("shelf_access")
    if not isinstance(access, list):
        return []
    out: list[Issue] = []
    if len(access) != layout.rows:
        out.append(_err("AG508", f"shelf access lists {len(access)} shelves for a grid of {layout.rows} rows",
                        _ptr("realization", "shelf_access"), "one entry per shelf row"))
    for k, entry in enumerate(access):
        shelf_row, robot_rows = _dict(entry).get("shelf_row"), _dict(entry).get("robot_rows")
        if shelf_row != k:
            out.append(_err("AG508", f"shelf access entry {k} is for shelf row {shelf_row!r}; entries list "
                            "shelf rows in order", _ptr("realization", "shelf_access", k, "shelf_row"),
                            "regenerate the instance with `agspec instance`"))
            continue
        rows = _list(robot_rows)
        for m, row in enumerate(rows):
            where = _ptr("realization", "shelf_access", k, "robot_rows", m)
            if not (_is_int(row) and 0 <= row < layout.rows):
                out.append(_err("AG508", f"shelf row {k}: robot row {row!r} is outside the grid", where,
                                f"rows are 0..{layout.rows - 1}"))
            elif m > 0 and _is_int(rows[m - 1]) and row <= rows[m - 1]:
                out.append(_err("AG508", f"shelf row {k}: robot rows must be ascending and distinct", where,
                                "sort the rows"))
            elif not _reaches_shelf(int(row), k, layout):
                out.append(_err("AG508", f"shelf row {k}: the left-column robot of row {row} cannot reach the "
                                "shelf point, so it cannot pick there", where,
                                "only rows within reach of the shelf point may get access"))
        if _reaches_shelf(k, k, layout) and isinstance(robot_rows, list) and k not in robot_rows:
            out.append(_err("AG508", f"shelf row {k}: its own row's robot reaches the shelf but has no "
                            "access", _ptr("realization", "shelf_access", k, "robot_rows"),
                            "the own row always has access (no draw)"))
    return out


def _check_products(
    inst: Mapping, real: Mapping, layout: _Layout, recipes: Mapping[str, Mapping], *, shelves_ok: bool
) -> list[Issue]:
    """I-PRODUCTS: ids 0..n-1 in release order, as many as can be released, recipes of the mix,
    source rows that stock the token, attributes within the scenario's ranges."""
    products = real.get("products")
    if not isinstance(products, list):
        return []
    scenario = _dict(inst.get("scenario"))
    out: list[Issue] = []
    expected = _expected_product_count(scenario)
    if expected is not None and len(products) != expected:
        out.append(_err("AG511", f"the realization lists {len(products)} products; this scenario can release "
                        f"{expected}", _ptr("realization", "products"),
                        "continuing mode: 1 + horizon // interval; batch mode: batch_size"))
    stock = [_dict(_dict(s).get("stock")) for s in _list(real.get("shelves"))]  # index = row if shelves_ok
    mix = [n for n in _list(scenario.get("recipes")) if isinstance(n, str)]
    sound = {n for n in mix if n in recipes and not errors(validate_recipe(recipes[n]))}
    profile_ok = not errors(validate_profile(_dict(inst.get("profile"))))
    for k, product in enumerate(products):
        product = _dict(product)
        if product.get("id") != k:
            out.append(_err("AG510", f"product {k} has id {product.get('id')!r}; products are numbered "
                            "0, 1, 2, ... in release order", _ptr("realization", "products", k, "id"),
                            "regenerate the instance with `agspec instance`"))
        recipe_id = product.get("recipe")
        if not isinstance(recipe_id, str) or recipe_id not in mix:
            out.append(_err("AG509", f"product {k} is a `{recipe_id}`, which is not in the product mix "
                            f"{_q(mix)}", _ptr("realization", "products", k, "recipe"),
                            "products are drawn from the scenario's recipes"))
            continue
        if recipe_id not in recipes:
            continue  # AG503 reports the missing recipe
        if shelves_ok:
            out += _check_source_rows(k, product, recipes[recipe_id], stock, layout)
        out += _check_product_draws(inst, k, product, recipes[recipe_id], layout,
                                    due=recipe_id in sound and profile_ok)
    return out


def _expected_product_count(scenario: Mapping) -> int | None:
    """P-RELEASE: continuing 1 + horizon // interval; batch: batch_size."""
    evaluation, release = _dict(scenario.get("evaluation")), _dict(scenario.get("release"))
    if evaluation.get("mode") == "batch":
        size = evaluation.get("batch_size")
        return int(size) if _is_int(size) else None
    horizon, interval = evaluation.get("horizon"), release.get("interval")
    if _is_int(horizon) and _is_int(interval) and interval >= 1:
        return 1 + int(horizon) // int(interval)
    return None


def _check_source_rows(k: int, product: Mapping, recipe: Mapping, stock: list, layout: _Layout) -> list[Issue]:
    """I-SOURCE-ROWS: one source row per raw token of the recipe, each a row stocking the token."""
    out: list[Issue] = []
    sources = product.get("source_rows")
    if not isinstance(sources, Mapping):
        return []
    raw = [t for t in _list(recipe.get("raw")) if isinstance(t, str)]
    base = _ptr("realization", "products", k, "source_rows")
    for tok in raw:
        if tok not in sources:
            out.append(_err("AG512", f"product {k} has no source row for raw material `{tok}`", base,
                            "every raw token of the recipe needs a source row"))
    for tok, row in sources.items():
        where = base + _ptr(tok)
        if tok not in raw:
            out.append(_err("AG512", f"product {k} has a source row for `{tok}`, which its recipe does not "
                            "use", where, f"the recipe's raw materials: {_q(raw)}"))
        elif not (_is_int(row) and 0 <= row < layout.rows):
            out.append(_err("AG512", f"product {k}: source row {row!r} of `{tok}` is outside the grid", where,
                            f"rows are 0..{layout.rows - 1}"))
        elif int(row) >= len(stock) or tok not in stock[int(row)]:
            out.append(_err("AG512", f"product {k} sources `{tok}` from shelf row {row}, which does not stock "
                            "it", where, "source rows are drawn among the rows stocking the token"))
    return out


def _check_product_draws(
    inst: Mapping, k: int, product: Mapping, recipe: Mapping, layout: _Layout, *, due: bool
) -> list[Issue]:
    """P-RELEASE-DRAWS, P-DUE: mass and slack within the scenario ranges; due offset = ceil(slack * LB)."""
    out: list[Issue] = []
    params = _dict(_dict(inst.get("scenario")).get("products"))
    check_due = due
    mass, slack, due = product.get("mass"), product.get("slack"), product.get("due_offset")
    rng = params.get("mass")
    if isinstance(rng, list) and len(rng) == 2 and all(_is_num(x) for x in rng) and _is_num(mass):
        if not rng[0] <= mass <= rng[1]:
            out.append(_err("AG513", f"product {k} has mass {mass}, outside the scenario range {rng}",
                            _ptr("realization", "products", k, "mass"), "mass ~ U(min, max)"))
    ds, jitter = params.get("due_slack"), params.get("due_slack_jitter")
    if _is_num(ds) and _is_num(jitter) and _is_num(slack):
        lo, hi = max(1, ds - jitter), ds + jitter
        if not lo <= slack <= hi:
            out.append(_err("AG513", f"product {k} has due slack {slack}, outside [{lo}, {hi}]",
                            _ptr("realization", "products", k, "slack"),
                            "slack ~ U(max(1, due_slack - jitter), due_slack + jitter)"))
        elif check_due and _is_int(due):
            bound = _lower_bound(recipe, _dict(inst.get("profile")), layout.cols)
            if bound is not None and int(due) != math.ceil(slack * bound):
                out.append(_err("AG513", f"product {k} has due offset {due}, but ceil(slack x LB) = "
                                f"ceil({slack} x {bound}) = {math.ceil(slack * bound)}",
                                _ptr("realization", "products", k, "due_offset"),
                                "LB = max(pick + critical path + deliver, N - 1)"))
    return out


def _lower_bound(recipe: Mapping, profile: Mapping, cols: int) -> int | None:
    """P-DUE: LB = max(pick + critical_path + deliver, N - 1), or None if it cannot be computed."""
    from agspec.ir.instance import flow_time_lower_bound

    try:
        return int(flow_time_lower_bound(recipe, profile, cols))
    except (ValueError, KeyError, TypeError):
        return None


# =============================================================================================
# Dispatch
# =============================================================================================


def value_issues(ir: Json) -> list[Issue]:
    """The rules about single values (RC-DURATION, RC-WEIGHT, RC-VALUE, RC-RESOURCES, PR-RANGES,
    S-GRID, S-RELEASE ... S-RESOURCES) on any IR, schema-valid or not: their checks tolerate wrong types."""
    doc = _dict(ir)
    kind = doc.get("kind")
    if kind == "recipe":
        view = recipe_view(doc)
        return _check_numbers(doc, view) + [i for i in _check_resources(doc, view) if i.code == "AG361"]
    if kind == "profile":
        return _check_profile_values(doc, doc, "")
    if kind == "scenario":
        return _check_grid(doc) + _check_scenario_numbers(doc) + _check_scenario_resources(doc)
    return []


# schema codes that a rule's own code replaces at the same pointer: wrong type, out of range, not allowed
_SCHEMA_VALUE_CODES = frozenset({"AG202", "AG203", "AG205"})


def rule_codes(ir: Json, schema_issues: Sequence[Issue]) -> list[Issue]:
    """Schema issues with the code and message of the spec rule a bad value breaks (F-CODES: a duration
    of 2.5 is AG350, not the generic AG202), where a rule covers that value."""
    if not any(i.code in _SCHEMA_VALUE_CODES for i in schema_issues):
        return list(schema_issues)
    by_pointer: dict[str, Issue] = {}
    for issue in value_issues(ir):
        by_pointer.setdefault(issue.pointer, issue)
    return [by_pointer.get(i.pointer, i) if i.code in _SCHEMA_VALUE_CODES else i for i in schema_issues]


def validate_document(ir: Json, resolver: Resolver | None = None) -> list[Issue]:
    """Validate any IR document by its ``kind``.

    Recipes are checked against the default topology (D-KTOPO: 4); scenarios resolve their
    references through ``resolver``.  An unknown kind is a usage error the loader reports (AG0xx)
    before validation, so it raises ``ValueError`` here.
    """
    kind = _dict(ir).get("kind")
    if kind == "recipe":
        return validate_recipe(ir)
    if kind == "profile":
        return validate_profile(ir)
    if kind == "scenario":
        return validate_scenario(ir, resolver if resolver is not None else _NoResolver())
    if kind == "instance":
        return validate_instance(ir)
    raise ValueError(f"cannot validate a document of kind {kind!r}")


class _NoResolver:
    def get(self, kind: str, name: str) -> Json | None:
        return None


def errors(issues: Sequence[Issue]) -> list[Issue]:
    """The issues of severity ``error``."""
    return [i for i in issues if i.severity == "error"]
