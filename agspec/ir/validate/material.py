"""Material semantics per XOR route (spec chapter 02, RC-MATERIAL, RC-XOR; codes AG305-AG310,
AG390): the routes of a recipe, the operations and precedence on each, and the material checks
run on every route and merged."""

from __future__ import annotations

import itertools
import math
from collections import Counter
from dataclasses import dataclass, replace
from typing import Iterator, Mapping

import networkx as nx

from agspec.formats.diagnostics import Issue
from agspec.ir.validate.common import MAX_ROUTES, _err, _list, _ptr, _warn
from agspec.ir.validate.view import _Op, _RecipeView
from agspec.suggest import Change

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
            change = None
            if makers:
                maker = makers[0]
                ref = view.group_of.get(maker, maker)
                msg = (f"operation `{op.id}` consumes `{tok}`, which `{maker}` produces, but `{maker}` is not "
                       f"a predecessor of `{op.id}`")
                if _runs_after(view, ref, op.id):  # `after ref` would close a cycle (AG303): no edit repairs it
                    hint = (f"`{maker}` already runs after `{op.id}`, so `{op.id}` cannot wait for `{tok}`: consume "
                            f"`{tok}` in an operation that runs after `{maker}`, or change the order")
                else:
                    hint = f"add `after {ref}` to `{op.id}`"
                    change = Change("append", op.ptr("after"), ref, hint)
            else:
                msg = (f"operation `{op.id}` consumes `{tok}`, which no predecessor produces and which "
                       "is not a raw material")
                hint = f"declare `{tok}` as raw material, or produce it in an operation `{op.id}` runs after"
            yield _Finding(replace(_err("AG305", msg, op.ptr("inputs", m), hint), change=change))


def _runs_after(view: _RecipeView, ref: str, op_id: str) -> bool:
    """Whether ``ref`` (an operation, or any alternative of an XOR group) runs after ``op_id`` on some
    route, or is it: then ``after ref`` in ``op_id`` would be a precedence cycle (RC-PRECEDENCE)."""
    graph = nx.DiGraph()
    graph.add_nodes_from(view.op_ids)
    for op in view.ops:
        for pred in op.after:
            for src in view.groups[pred][1] if pred in view.groups else (pred,):
                graph.add_edge(src, op.id)
    targets = view.groups[ref][1] if ref in view.groups else (ref,)
    return any(t == op_id or (t in graph and nx.has_path(graph, op_id, t)) for t in targets)


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


def check_material(view: _RecipeView) -> list[Issue]:
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
