"""Scenario realizability under a geometry profile (paper "Feasibility"; spec S-FEASIBILITY).

A generated instance is feasible only if a policy-independent successful execution exists:
raw material can reach every operation that consumes it, a handoff chain connects the sources to
an output interface, every required operation satisfies kmin <= k_topo and admits at least one
geometrically admissible execution candidate, and resource capacities do not make a required
operation permanently infeasible.  This module decides that for a *scenario*, i.e. for every
realization its generator can draw (RES-FEASIBILITY-ALL-REALIZATIONS):

* only guaranteed shelf access counts — the own-row left-column robot (S-SHELF-ACCESS); extra
  access is random;
* a product may source each raw token from any row stocking it (S-SHELF-LAYOUT), so every such
  row must work;
* XOR routes are the policy's choice, so one working route per realization suffices.

Material moves only by handoff along the *geometrically usable* edges of G_handoff (both bases
reach the midpoint, G-HANDOFF-POINT), so it lives in the connected components of that graph.
Because every token is consumed exactly once (RC-MATERIAL), the material flow of a route is an
in-tree and the set of components where each token can be made is propagated exactly: an
operation can produce its output in component c iff some admissible candidate (a clique of
G_manip of an admissible size with a holder for every input in a component where that input can
be, R-CANDIDATES, R-ROLE-ASSIGNMENT, G-SITE, G-ROLE-TARGET, G-REACH) hands the output to a member
in c (R-COMPLETION: the rightmost, then topmost, input-bound member).

Codes: AG450 raw token unpickable, AG451 output point unreachable, AG452 no handoff chain to the
output, AG453 no admissible candidate, AG454 inputs can never meet, AG455 resource capacity;
AG459 products heavier than the payload; warnings AG456 geometrically unusable handoff pairs, AG457
team sizes never admissible, AG458 analysis truncated.  kmin > k_topo is AG421 of
:func:`agspec.ir.validate.validate_scenario`; recipes with AG3xx errors are skipped here.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field, replace
from typing import Any, Iterable, Mapping

import networkx as nx

from agspec.formats.diagnostics import Issue, json_pointer
from agspec.interp import geometry
from agspec.ir import topology
from agspec.ir import validate as V

Cell = tuple[int, int]
Shape = tuple[Cell, ...]  # clique members translated so that min row = min col = 0, row-major
MAX_ASSIGNMENTS = 4096  # source-row combinations analysed per recipe


def _err(code: str, message: str, pointer: str, hint: str) -> Issue:
    return Issue(code=code, message=message, pointer=pointer, hint=hint)


def _warn(code: str, message: str, pointer: str, hint: str) -> Issue:
    return Issue(code=code, message=message, pointer=pointer, hint=hint, severity="warning")


def _dict(x: object) -> dict:
    return x if isinstance(x, dict) else {}


def _list(x: object) -> list:
    return x if isinstance(x, list) else []


def _is_num(x: object) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and float(x) == float(x) and abs(x) != float("inf")


def _is_int(x: object) -> bool:
    return _is_num(x) and float(x).is_integer()


def _q(names: Iterable[object]) -> str:
    return ", ".join(f"`{n}`" for n in names)


# =============================================================================================
# The grid under the profile
# =============================================================================================


@dataclass
class _Grid:
    rows: int
    cols: int
    k_topo: int
    profile: Mapping[str, Any]
    manip: nx.Graph
    handoff: nx.Graph  # geometrically usable handoff pairs only
    dropped_handoffs: list[tuple[Cell, Cell]]
    component: dict[Cell, int]
    pickers: dict[int, Cell]  # shelf row -> its own-row left-column robot, if that robot reaches it
    deliverers: list[Cell]  # right-column robots that reach their output point
    cliques: dict[Shape, list[Cell]] = field(default_factory=dict)  # shape -> placements (offsets)

    @property
    def spacing(self) -> float:
        return float(self.profile["spacing"])

    @property
    def delivery_components(self) -> set[int]:
        return {self.component[c] for c in self.deliverers}


def _rest(cell: Cell, profile: Mapping[str, Any]) -> geometry.RobotPose:
    return geometry.rest_pose(cell, float(profile["spacing"]))


def _plan_ok(members: Iterable[tuple[Cell, geometry.Point]], process: int, profile, site=None) -> bool:
    """G-MOTION, G-REACH: an activity from rest is admissible iff its plan exists."""
    spec = [(cell, _rest(cell, profile), target) for cell, target in members]
    return geometry.plan_activity(spec, process, profile, common_target=site) is not None


def _duration(profile: Mapping[str, Any], key: str) -> int:
    value = _dict(profile.get("durations")).get(key, 1)
    return int(value) if _is_int(value) and value >= 1 else 1


def _usable_handoff(a: Cell, b: Cell, profile) -> bool:
    """R-HANDOFF, G-HANDOFF-POINT: both bases reach the midpoint of the pair."""
    mid = geometry.handoff_point(a, b, float(profile["spacing"]))
    return _plan_ok([(a, mid), (b, mid)], _duration(profile, "handoff"), profile)


def _build_grid(rows: int, cols: int, topo: str, radius: int, profile) -> _Grid:
    spacing = float(profile["spacing"])
    manip = topology.manipulation_graph(rows, cols, topo, radius)
    full = topology.handoff_graph(rows, cols, topo, radius)
    usable = nx.Graph()
    usable.add_nodes_from(full.nodes)
    dropped = []
    for a, b in sorted(full.edges):
        if _usable_handoff(a, b, profile):
            usable.add_edge(a, b)
        else:
            dropped.append((a, b))
    component = {cell: k for k, comp in enumerate(sorted(map(sorted, nx.connected_components(usable))))
                 for cell in comp}
    pickers = {
        r: (r, 0) for r in range(rows)
        if _plan_ok([((r, 0), geometry.shelf_point(r, spacing))], _duration(profile, "pick"), profile)
    }
    deliverers = [
        (i, cols - 1) for i in range(rows)
        if _plan_ok([((i, cols - 1), geometry.output_point(i, cols, spacing))], _duration(profile, "deliver"), profile)
    ]
    grid = _Grid(rows, cols, topology.k_topo(manip), profile, manip, usable, dropped, component, pickers, deliverers)
    for clique in nx.enumerate_all_cliques(manip):
        members = tuple(sorted(clique))
        i0, j0 = min(i for i, _ in members), min(j for _, j in members)
        shape = tuple((i - i0, j - j0) for i, j in members)
        grid.cliques.setdefault(shape, []).append((i0, j0))
    return grid


# =============================================================================================
# Candidates of one operation (R-CANDIDATES, R-ROLE-ASSIGNMENT, G-SITE, G-ROLE-TARGET)
# =============================================================================================


@dataclass(frozen=True)
class _OpSpec:
    id: str
    inputs: tuple[str, ...]  # distinct, IR order
    output: str
    kmin: int
    kmax: int
    roles: tuple[tuple[str, str | None], ...]
    duration: int
    resources: tuple[str, ...]


def _op_spec(op) -> _OpSpec | None:
    arity = V.arity_of(op)
    if arity is None or len(op.outputs) != 1:
        return None
    roles = tuple((str(r.get("name")), r.get("binds") if isinstance(r.get("binds"), str) else None)
                  for r in _list(op.ir.get("roles")) if isinstance(r, dict))
    duration = op.ir.get("duration", 1)
    return _OpSpec(op.id, tuple(dict.fromkeys(op.inputs)), op.outputs[0], arity[0], arity[1], roles,
                   int(duration) if _is_int(duration) else 1,
                   tuple(r for r in _list(op.ir.get("resources")) if isinstance(r, str)))


def assign_roles(spec: _OpSpec, members: tuple[Cell, ...], holder_of: Mapping[str, Cell]) -> list[tuple[Cell, str]] | None:
    """R-ROLE-ASSIGNMENT: bound roles go to the holders of their inputs; the remaining roles, in
    recipe order, to the remaining members in row-major order.  None if roles run out."""
    assigned: dict[Cell, str] = {}
    for name, binds in spec.roles:
        if binds is not None and binds in holder_of:
            assigned[holder_of[binds]] = name
    free = [name for name, binds in spec.roles if binds is None or binds not in holder_of]
    rest = [m for m in members if m not in assigned]
    if len(rest) > len(free):
        return None
    assigned.update(zip(rest, free))
    return [(m, assigned[m]) for m in members]


def _admissible(spec: _OpSpec, members: tuple[Cell, ...], holders: tuple[Cell, ...], profile) -> bool:
    """Hard constraint x_u(c) in W(u) for all members: role targets around the site within reach."""
    holder_of = dict(zip(spec.inputs, holders))
    roles = assign_roles(spec, members, holder_of)
    if roles is None:
        return False
    spacing = float(profile["spacing"])
    site = geometry.operation_site(holders, members, spacing)
    targets = geometry.role_targets(site, roles, float(profile.get("role_target_offset", 0.0)), spacing)
    return _plan_ok([(m, targets[m]) for m in members], spec.duration, profile, site)


def _receiver(spec: _OpSpec, members: tuple[Cell, ...], holders: tuple[Cell, ...]) -> Cell:
    """R-COMPLETION: the output goes to the rightmost, then topmost, input-bound member (else member)."""
    bound_tokens = {b for _, b in spec.roles if b is not None}
    bound = [h for tok, h in zip(spec.inputs, holders) if tok in bound_tokens] or list(members)
    return max(bound, key=lambda c: (c[1], -c[0]))


def _sizes(spec: _OpSpec, k_topo: int) -> range:
    """R-CANDIDATES: kmin <= |C| <= min(kmax, k_topo), and every input has its own holder."""
    return range(max(spec.kmin, len(spec.inputs)), min(spec.kmax, k_topo) + 1)


def _holder_choices(shape: Shape, n_inputs: int) -> Iterable[tuple[int, ...]]:
    return itertools.permutations(range(len(shape)), n_inputs)


def _feasible_patterns(spec: _OpSpec, grid: _Grid) -> list[tuple[Shape, tuple[int, ...]]]:
    """(clique shape, holder indices) pairs that make an admissible candidate (translation-invariant)."""
    sizes = _sizes(spec, grid.k_topo)
    out = []
    for shape in grid.cliques:
        if len(shape) not in sizes:
            continue
        for pick in _holder_choices(shape, len(spec.inputs)):
            if _admissible(spec, shape, tuple(shape[k] for k in pick), grid.profile):
                out.append((shape, pick))
    return out


Option = tuple[tuple[int, ...], int]  # (component of each input's holder, component of the receiver)


def _options(spec: _OpSpec, grid: _Grid, patterns) -> set[Option]:
    """Every (input components, output component) an admissible candidate placement realizes."""
    if len(set(grid.component.values())) == 1:  # one handoff component: material goes anywhere
        return {((0,) * len(spec.inputs), 0)}
    out: set[Option] = set()
    for shape, pick in patterns:
        for i0, j0 in grid.cliques[shape]:
            members = tuple((i + i0, j + j0) for i, j in shape)
            holders = tuple(members[k] for k in pick)
            receiver = _receiver(spec, members, holders)
            out.add((tuple(grid.component[h] for h in holders), grid.component[receiver]))
    return out


# =============================================================================================
# Per-recipe analysis
# =============================================================================================


@dataclass
class _RecipeCheck:
    name: str
    pointer: str  # /recipes/m in the scenario
    view: Any
    specs: dict[str, _OpSpec]
    static: dict[str, list[Issue]]  # op id -> reasons it can never run (AG453/AG455; [] = fine)
    arity_blocked: set[str]  # kmin > k_topo etc. (AG421 reports it)
    options: dict[str, set[Option]]
    notes: list[Issue]  # warnings (AG457)


def _resource_issues(spec: _OpSpec, recipe: Mapping, scenario: Mapping, where: str, name: str) -> list[Issue]:
    """S-FEASIBILITY (resources): every resource an operation needs has capacity >= 1."""
    out = []
    declared_scenario = _dict(scenario.get("resources"))
    declared_recipe = _dict(recipe.get("resources"))
    for res in spec.resources:
        if res in declared_scenario:
            cap, ptr, origin = declared_scenario[res], json_pointer("resources", res), "the scenario"
        elif res in declared_recipe:
            cap, ptr, origin = declared_recipe[res], where, f"recipe `{name}`"
        else:
            out.append(_err("AG455", f"recipe `{name}`: operation `{spec.id}` needs resource `{res}`, which "
                              "neither the recipe nor the scenario declares", where,
                              f"declare `{res}` with a capacity >= 1 in the scenario's resources"))
            continue
        if _is_int(cap) and cap < 1:
            out.append(_err("AG455", f"recipe `{name}`: operation `{spec.id}` needs resource `{res}`, whose "
                              f"capacity in {origin} is {cap}; the operation can never run", ptr,
                              f"give `{res}` a capacity of at least 1"))
    return out


def _prepare_recipe(name: str, m: int, recipe: Mapping, scenario: Mapping, grid: _Grid) -> _RecipeCheck:
    where = json_pointer("recipes", m)
    view = V.recipe_view(recipe)
    specs, static, blocked, options, notes = {}, {}, set(), {}, []
    for op in view.ops:
        spec = _op_spec(op)
        if spec is None:
            continue
        specs[op.id] = spec
        reasons = _resource_issues(spec, recipe, scenario, where, name)
        sizes = _sizes(spec, grid.k_topo)
        if not sizes:
            blocked.add(op.id)
        else:
            patterns = _feasible_patterns(spec, grid)
            if not patterns:
                reasons.append(_err(
                    "AG453", f"recipe `{name}`: operation `{op.id}` has no geometrically admissible execution "
                    f"candidate: for every team of {sizes.start}..{sizes.stop - 1} pairwise-adjacent robots some "
                    f"role target lies beyond reach {grid.profile['reach']}", where,
                    "allow other team sizes, or use a profile with a longer reach, a smaller spacing or a "
                    "smaller role-target offset"))
            else:
                options[op.id] = _options(spec, grid, patterns)
                notes += _size_notes(name, spec, sizes, patterns, grid, where)
        static[op.id] = reasons
    return _RecipeCheck(name, where, view, specs, static, blocked, options, notes)


def _size_notes(name: str, spec: _OpSpec, sizes: range, patterns, grid: _Grid, where: str) -> list[Issue]:
    """AG457 (warning): declared team sizes (within k_topo) that no placement makes admissible."""
    dead = [k for k in sizes if k not in {len(shape) for shape, _ in patterns}]
    if not dead:
        return []
    return [_warn("AG457", f"recipe `{name}`: operation `{spec.id}` can never run with {' or '.join(map(str, dead))} "
                  f"robots: some role target of every such team lies beyond reach {grid.profile['reach']}", where,
                  "those candidates are always rejected as motion-infeasible; narrow the arity if that is unintended")]


def _statically_ok(check: _RecipeCheck, route) -> bool:
    return all(not check.static.get(op.id) and op.id not in check.arity_blocked and op.id in check.specs
               for op in V.route_ops(check.view, route))


def _static_issues(check: _RecipeCheck, all_routes: list) -> tuple[list[Issue], list]:
    """Static reasons (AG453/AG455): errors when no route avoids them, warnings otherwise."""
    good = [r for r in all_routes if _statically_ok(check, r)]
    on_good = {op.id for r in good for op in V.route_ops(check.view, r)}
    out = []
    for op_id, reasons in check.static.items():
        for issue in reasons:
            if not good:
                out.append(issue)
            elif op_id not in on_good:
                out.append(replace(issue, severity="warning",
                                     message=issue.message + "; products can still use another XOR alternative"))
    return out, good


def _source_choices(check: _RecipeCheck, grid: _Grid, stocking: Mapping[str, list[int]]):
    """S-SHELF-LAYOUT x S-SHELF-ACCESS: per raw token, the distinct components where a product's
    unit appears (one per stocking row with a guaranteed picker), with an example row each."""
    out: dict[str, dict[int, int]] = {}
    for tok in check.view.raw:
        comps: dict[int, int] = {}
        for row in stocking.get(tok, []):
            if row in grid.pickers:
                comps.setdefault(grid.component[grid.pickers[row]], row)
        out[tok] = comps
    return out


def _route_failures(check: _RecipeCheck, grid: _Grid, route, avail0: Mapping[str, set[int]], example: str) -> list[Issue]:
    """Propagate where each token can be made along one route; report why the route fails."""
    graph = V.route_graph(check.view, route)
    avail = {tok: set(c) for tok, c in avail0.items()}
    failures: list[Issue] = []
    for op_id in nx.lexicographical_topological_sort(graph):
        spec = check.specs[op_id]
        have = [avail.get(tok, set()) for tok in spec.inputs]
        if any(not h for h in have):
            avail[spec.output] = set()  # a root cause upstream is reported
            continue
        made = {oc for ics, oc in check.options.get(op_id, ()) if all(c in h for c, h in zip(ics, have))}
        if not made:
            failures.append(_err(
                "AG454", f"recipe `{check.name}`: operation `{op_id}` can never gather its inputs "
                f"{_q(spec.inputs)}{example}: no admissible coalition has holders that can all receive "
                "them by handoff", check.pointer,
                "material moves only by handoff: use a topology whose handoff graph links the source rows "
                "(e.g. `moore`), or feed the inputs from the same rows"))
        avail[spec.output] = made
    terminal = _route_terminal(check, route)
    if terminal is not None and avail.get(terminal) and not (avail[terminal] & grid.delivery_components):
        failures.append(_err(
            "AG452", f"recipe `{check.name}`: the finished product `{terminal}` can never reach the output "
            f"column{example}: no handoff chain links where it is made to a right-column robot that can deliver",
            check.pointer, "the handoff graph must connect the operation sites to the right column"))
    return failures


def _route_terminal(check: _RecipeCheck, route) -> str | None:
    ops = [check.specs[op.id] for op in V.route_ops(check.view, route) if op.id in check.specs]
    consumed = {t for s in ops for t in s.inputs}
    left = [s.output for s in ops if s.output not in consumed]
    return left[0] if len(left) == 1 else None


def _flow_issues(check: _RecipeCheck, grid: _Grid, good_routes: list, stocking) -> list[Issue]:
    """S-FEASIBILITY (material, handoff chain): every source-row draw must leave a working route."""
    choices = _source_choices(check, grid, stocking)
    if any(not comps for comps in choices.values()):
        return []  # AG450 reports the token
    tokens = list(choices)
    total = 1
    for t in tokens:
        total *= len(choices[t])
    combos = itertools.islice(itertools.product(*(sorted(choices[t]) for t in tokens)), MAX_ASSIGNMENTS)
    many = len(set(grid.component.values())) > 1
    notes = [] if total <= MAX_ASSIGNMENTS else [_warn(
        "AG458", f"recipe `{check.name}`: only {MAX_ASSIGNMENTS} of {total} source-row combinations were "
        "analysed for realizability", check.pointer, "a smaller grid or fewer raw materials keeps the check exact")]
    for combo in combos:
        avail = {tok: {comp} for tok, comp in zip(tokens, combo)}
        example = ""
        if many:
            rows = " and ".join(f"`{t}` comes from shelf row {choices[t][c]}" for t, c in zip(tokens, combo))
            example = f" when {rows}"
        failures: dict[tuple[str, str, str], Issue] = {}
        for route in good_routes:
            found = _route_failures(check, grid, route, avail, example)
            if not found:
                break
            for issue in found:
                failures.setdefault((issue.code, issue.pointer, issue.message), issue)
        else:
            return notes + list(failures.values())
    return notes


# =============================================================================================
# Boundary checks (S-FEASIBILITY: shelves, output interface, handoffs)
# =============================================================================================


def _shelf_issues(scenario: Mapping, recipes: Mapping[str, Mapping], grid: _Grid, stocking) -> list[Issue]:
    """AG450: every raw token must be pickable from every shelf row that stocks it by that row's
    left-column robot (G-SHELF-POINT, G-REACH); access from other rows is random (S-SHELF-ACCESS)."""
    out = []
    reported: set[str] = set()
    for m, name in enumerate(_list(scenario.get("recipes"))):
        for tok in V.recipe_view(recipes.get(name)).raw if isinstance(name, str) else ():
            rows = stocking.get(tok, [])
            missing = [r for r in rows if r not in grid.pickers]
            if tok in reported or not missing:
                continue
            reported.add(tok)
            distance = abs(geometry.shelf_point(0, grid.spacing)[0])
            out.append(_err(
                "AG450", f"raw material `{tok}` cannot be picked from shelf row{'s' if len(missing) > 1 else ''} "
                f"{', '.join(map(str, missing))}: the shelf point is {distance:g} from the left-column base, "
                f"beyond reach {grid.profile['reach']}", json_pointer("recipes", m),
                "use a profile whose reach is at least half the cell spacing"))
    return out


def _output_issues(grid: _Grid) -> list[Issue]:
    """AG451: some right-column robot must reach its output point (G-OUTPUT-POINT, G-REACH)."""
    if grid.deliverers:
        return []
    return [_err("AG451", f"no right-column robot can reach the output point, {grid.spacing:g} from its base "
                   f"(reach {grid.profile['reach']}); no product can ever be delivered", json_pointer("profile"),
                   "use a profile whose reach is at least the cell spacing")]


def _handoff_issues(grid: _Grid) -> list[Issue]:
    """AG456 (warning): neighbour pairs of G_handoff whose handoff point is out of reach."""
    if not grid.dropped_handoffs:
        return []
    (a, b), n = grid.dropped_handoffs[0], len(grid.dropped_handoffs)
    return [_warn("AG456", f"{n} neighbour pair{'s' if n > 1 else ''} of the handoff graph cannot hand off: "
                    f"the midpoint of their bases is out of reach (e.g. {a} and {b})", json_pointer("profile"),
                    "material detours around them; check the profile's reach against its spacing")]


# =============================================================================================
# Entry points
# =============================================================================================


def _profile_usable(profile: Mapping[str, Any]) -> bool:
    """The geometry can be evaluated: the numbers it reads are present and in range (validate_profile
    reports them, AG401-AG403).  Reach problems (e.g. AG404) are what this module measures."""
    def number(key: str, low: float, high: float = float("inf"), strict: bool = True) -> bool:
        value = profile.get(key)
        return _is_num(value) and (value > low if strict else value >= low) and value <= high

    return (all(number(k, 0.0) for k in ("spacing", "reach", "speed", "joint_speed"))
            and number("retreat_fraction", 0.0, 1.0, strict=False)
            and ("role_target_offset" not in profile or number("role_target_offset", 0.0, strict=False)))


def check_realizability(
    scenario_ir: Mapping[str, Any], recipes: Mapping[str, Mapping[str, Any]], resolved_profile: Mapping[str, Any]
) -> list[Issue]:
    """S-FEASIBILITY: whether every realization of the scenario admits a successful execution.

    ``recipes`` maps recipe ids to recipe IR; ``resolved_profile`` is the profile with the
    scenario's variant applied.  Structurally invalid inputs (bad grid, invalid profile, recipes
    with AG3xx errors, unknown recipes) are skipped: their validators report them.
    """
    from agspec.ir.instance import rows_stocking, shelf_layout

    scenario = _dict(scenario_ir)
    spec = _grid_of(scenario)
    if spec is None or not isinstance(resolved_profile, Mapping) or not _profile_usable(resolved_profile):
        return []
    rows, cols, topo, radius = spec
    grid = _build_grid(rows, cols, topo, radius, resolved_profile)
    names = [n for n in _list(scenario.get("recipes")) if isinstance(n, str)]
    mix = [n for n in dict.fromkeys(names) if n in recipes]
    raws = list(dict.fromkeys(tok for name in mix for tok in V.recipe_view(recipes[name]).raw))
    stocking = rows_stocking(shelf_layout(rows, raws, 1))  # S-SHELF-LAYOUT: which rows stock what

    issues = _shelf_issues(scenario, recipes, grid, stocking)
    issues += _output_issues(grid)
    issues += _handoff_issues(grid)
    for m, name in enumerate(_list(scenario.get("recipes"))):
        if name not in mix or V.errors(V.validate_recipe(recipes[name], grid.k_topo)):
            continue
        mix.remove(name)  # first occurrence only
        check = _prepare_recipe(name, m, recipes[name], scenario, grid)
        all_routes = V.routes(check.view)
        static, good = _static_issues(check, all_routes)
        issues += static + check.notes
        if good and grid.deliverers:
            issues += _flow_issues(check, grid, good, stocking)
    return issues


def _grid_of(scenario: Mapping) -> tuple[int, int, str, int] | None:
    grid = _dict(scenario.get("grid"))
    rows, cols = grid.get("rows"), grid.get("cols")
    topo = grid.get("topology", topology.DEFAULT_TOPOLOGY)
    radius = grid.get("radius", topology.DEFAULT_RADIUS)
    if not (_is_int(rows) and _is_int(cols) and _is_int(radius) and rows >= 1 and cols >= 2 and radius >= 1):
        return None
    if topo not in topology.TOPOLOGIES:
        return None
    return int(rows), int(cols), topo, int(radius)


def validate_scenario_full(scenario_ir: Mapping[str, Any], resolver: V.Resolver) -> list[Issue]:
    """S-*, S-FEASIBILITY: :func:`validate_scenario`, then — if it found no error — realizability
    with the resolved recipes and profile (the check ``agspec validate`` runs on scenarios)."""
    from agspec.ir.instance import InstanceError, resolve_profile

    issues = V.validate_scenario(scenario_ir, resolver)
    if V.errors(issues):
        return issues
    scenario = _dict(scenario_ir)
    recipes = {n: resolver.get("recipe", n) for n in _list(scenario.get("recipes")) if isinstance(n, str)}
    ref = _dict(scenario.get("profile"))
    if not isinstance(ref.get("id"), str) or not isinstance(ref.get("variant"), (str, type(None))):
        return issues
    profile = resolver.get("profile", ref["id"])
    if not isinstance(profile, Mapping) or any(not isinstance(r, Mapping) for r in recipes.values()):
        return issues
    try:
        resolved = resolve_profile(profile, ref.get("variant"))
    except InstanceError:
        return issues
    return issues + check_payload(scenario, resolved) + check_realizability(scenario, recipes, resolved)


def check_payload(scenario: Mapping[str, Any], profile: Mapping[str, Any]) -> list[Issue]:
    """S-FEASIBILITY 7 (AG459): every product the scenario can draw is light enough to be handed off.

    A handoff needs ``mass_z <= payload`` (R-HANDOFF) and material always changes hands at least once
    (raw material enters at the left column, products leave at the right one, S-GRID: ``cols >= 2``),
    so a product heavier than the payload is never delivered; the candidate condition
    ``mass_z / b <= payload`` (R-CANDIDATES) is then implied for every ``b >= 1``.
    """
    mass = _dict(scenario.get("products")).get("mass")
    payload = profile.get("payload")
    if not (isinstance(mass, list) and len(mass) == 2 and all(_is_num(m) for m in mass) and _is_num(payload)):
        return []
    low, high = mass
    if high <= payload:
        return []
    which = "no product" if low > payload else f"no product heavier than {payload}"
    return [_err("AG459", f"product mass {low}..{high} exceeds the robots' payload {payload}: {which} can ever be "
                 "handed off, so it is never delivered", "/products/mass",
                 f"keep `products mass` at most {payload}, or raise the profile's `payload`")]
