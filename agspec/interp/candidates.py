"""Readiness and execution candidates (spec R-READY, R-CANDIDATES, R-ROLE-ASSIGNMENT).

Candidates are built from the global state once per decision epoch, before any action is
applied.  They are *not* filtered by running activities or remote conflicts (O-EXPOSURE): that is
left to joint admission (R-JOINT-ADMISSIBLE) and to the capacity diagnostic (M-CAPACITY).
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations
from typing import Any

from agspec.interp import geometry
from agspec.interp.model import Model, OperationSpec
from agspec.interp.state import Cell, Product, State


@dataclass(frozen=True)
class Candidate:
    cid: str
    pid: int
    recipe: str
    op: OperationSpec
    members: tuple[Cell, ...]  # row-major
    roles: tuple[tuple[Cell, str], ...]  # member -> role, member order
    holders: tuple[Cell, ...]
    plan: Any  # geometry.Plan
    target: tuple[float, float]  # operation site
    resources: frozenset[str]

    @property
    def size(self) -> int:
        return len(self.members)

    @property
    def group(self) -> tuple[int, str]:
        """The operation occurrence (z, tau); its realizations are mutually exclusive."""
        return (self.pid, self.op.id)


def candidate_id(pid: int, op_id: str, members: tuple[Cell, ...]) -> str:
    """R-IDS: candidate id string "op:{pid}:{op}:{i},{j};{i},{j}" with members row-major."""
    return f"op:{pid}:{op_id}:" + ";".join(f"{i},{j}" for i, j in members)


def xor_closed(product: Product, op: OperationSpec) -> bool:
    """RC-XOR: an alternative is closed once a sibling has been chosen for this product."""
    if op.xor_group is None:
        return False
    chosen = product.xor_choice.get(op.xor_group)
    return chosen is not None and chosen != op.id


def predecessors_done(product: Product, op: OperationSpec, model: Model) -> bool:
    """RC-PRECEDENCE: every `after` entry is completed; a group entry needs its chosen alternative."""
    groups = model.recipes[product.recipe].xor_groups
    for pred in op.after:
        if pred in groups:
            chosen = product.xor_choice.get(pred)
            if chosen is None or chosen not in product.completed:
                return False
        elif pred not in product.completed:
            return False
    return True


def logically_ready(product: Product, op: OperationSpec, model: Model) -> bool:
    """R-READY: not delivered, not completed, not executing, predecessors done, not XOR-closed."""
    return (
        not product.delivered
        and op.id not in product.completed
        and op.id not in product.in_progress
        and not xor_closed(product, op)
        and predecessors_done(product, op, model)
    )


def inputs_present(state: State, product: Product, op: OperationSpec) -> bool:
    """R-READY (material): every input item of the occurrence is currently held by some robot."""
    return all((product.pid, tok) in state.item_holder for tok in op.inputs)


def logically_ready_occurrences(state: State, model: Model) -> list[tuple[Product, OperationSpec]]:
    """R-READY: logically ready occurrences (material not required), products ascending, ops topological."""
    out = []
    for product in state.products:
        if product.delivered:
            continue
        done, running = product.completed, product.in_progress
        for op in model.recipes[product.recipe].operations:
            # completed and executing operations are most of a product's: they are passed over here
            if op.id not in done and op.id not in running and logically_ready(product, op, model):
                out.append((product, op))
    return out


def assign_roles(op: OperationSpec, members: tuple[Cell, ...], holder_of: dict[str, Cell]) -> tuple[tuple[Cell, str], ...] | None:
    """R-ROLE-ASSIGNMENT: bound roles to the holders of their inputs, the rest row-major in recipe order."""
    assigned: dict[Cell, str] = {}
    for name, binds in op.roles:
        if binds is not None:
            holder = holder_of.get(binds)
            if holder is None or holder in assigned:
                return None
            assigned[holder] = name
    free_roles = [name for name, binds in op.roles if binds is None]
    rest = [m for m in members if m not in assigned]
    for k, member in enumerate(rest):
        # Extra members beyond the declared roles cannot occur once RC-ROLES validated the recipe.
        assigned[member] = free_roles[k] if k < len(free_roles) else f"helper_extra_{k}"
    return tuple((m, assigned[m]) for m in members)


def build_candidates(state: State, model: Model, ready: list[tuple[Product, OperationSpec]] | None = None,
                     ) -> tuple[list[Candidate], int]:
    """R-CANDIDATES: every admissible realization of every ready occurrence, at most once per key.

    Returns the candidates sorted by (product id, operation id, members) and the number of
    realizations rejected as motion-infeasible (M-GEOMETRY-REJECTIONS).  ``ready`` is
    :func:`logically_ready_occurrences` of this state when the caller already has it.
    """
    out: list[Candidate] = []
    rejected = 0
    t = state.t
    robots = state.robots
    item_holder = state.item_holder
    for product, op in logically_ready_occurrences(state, model) if ready is None else ready:
        # R-READY (material): :func:`inputs_present`, with the holders looked up once
        holding = [item_holder.get((product.pid, tok)) for tok in op.inputs]
        if None in holding:
            continue
        holder_of = dict(zip(op.inputs, holding))
        holders = tuple(sorted(set(holding)))
        cap = min(op.kmax, model.k_topo)
        if len(holders) > cap or any(not robots[h].free(t) for h in holders):
            continue
        if not all(model.adjacent(a, b) for a, b in combinations(holders, 2)):
            continue
        # helpers are adjacent to every holder, so they are among the first holder's neighbours; an
        # occurrence whose holders already fill its arity takes no helper (combinations(pool, 0) is
        # the one empty choice whatever the pool), so its pool is not looked for
        around = model.neighbours[holders[0]] if holders else model.cells
        pool = [
            c
            for c in around
            if c not in holders
            and robots[c].free(t)
            and robots[c].holding is None
            and all(model.adjacent(c, h) for h in holders)
        ] if len(holders) < cap else []
        for extra in range(max(0, op.kmin - len(holders)), cap - len(holders) + 1):
            for helpers in combinations(pool, extra):
                members = tuple(sorted(holders + helpers))
                if not (op.kmin <= len(members) <= cap):
                    continue
                if not all(model.adjacent(a, b) for a, b in combinations(helpers, 2)):
                    continue
                cand = realized(state, model, product, op, members, holders, holder_of)
                if cand is None:
                    rejected += 1
                elif cand is not False:
                    out.append(cand)
    out.sort(key=lambda c: (c.pid, c.op.id, c.members))
    return out, rejected


def surviving_candidates(state: State, candidates: list[Candidate]) -> list[Candidate]:
    """R-CANDIDATES after a transition that only committed robots to new activities: it completed,
    released and admitted nothing, so logical readiness, the holders of items, who holds anything
    and every pose are as before, and robots only stopped being free (a robot becomes free only when
    its activity completes, R-EXECUTION).  A realization then exists now iff it existed before and
    all its members are still free: a busy holder drops its occurrence, a busy helper leaves the
    pool, and nothing else that :func:`build_candidates` reads has changed.  The previous candidates
    must be all of the previous realizations (none was rejected as motion-infeasible: those are
    counted, not kept); the kept ones stay in their sorted order."""
    t, robots = state.t, state.robots
    return [c for c in candidates if all(robots[m].free(t) for m in c.members)]


REALIZED_LIMIT = 20_000  # the memo starts over past this many entries (bounded memory)


def realized(state: State, model: Model, product: Product, op: OperationSpec, members, holders, holder_of):
    """:func:`realize`, remembered in ``model.realized``: most candidates of an epoch are the previous
    epoch's, with the same members at the same poses.  The key holds everything ``realize`` reads
    (the Candidate is immutable, so one object serves every epoch that realizes it)."""
    key = (product.pid, product.recipe, product.mass, op.id, members, tuple(holder_of[tok] for tok in op.inputs),
           tuple(state.robots[m].pose for m in members))
    memo = model.realized
    if key in memo:
        return memo[key]
    if len(memo) >= REALIZED_LIMIT:
        memo.clear()
    cand = memo[key] = realize(state, model, product, op, members, holders, holder_of)
    return cand


def realize(state: State, model: Model, product: Product, op: OperationSpec, members, holders, holder_of):
    """Roles, site, role targets and motion plan of one candidate (G-SITE, G-ROLE-TARGET, G-MOTION).

    Returns None when the plan is motion-infeasible, False when roles cannot be filled.
    """
    roles = assign_roles(op, members, holder_of)
    if roles is None:
        return False
    payload = float(model.profile.get("payload", 10.0))
    n_bound = sum(1 for _, b in op.roles if b is not None)
    if n_bound and product.mass / n_bound > payload:  # Capability: payload never binds in v1
        return False
    spacing = float(model.profile["spacing"])
    site = geometry.operation_site(list(holders), list(members), spacing)
    targets = geometry.role_targets(site, list(roles), float(model.profile["role_target_offset"]), spacing)
    plan = model.plans.plan([(m, state.robots[m].pose, targets[m]) for m in members], op.duration, site)
    if plan is None:
        return None
    resources = {f"operation:{product.pid}:{op.id}"} | {f"token:{product.pid}:{tok}" for tok in op.inputs}
    resources |= set(op.resources)
    return Candidate(
        cid=candidate_id(product.pid, op.id, members),
        pid=product.pid,
        recipe=product.recipe,
        op=op,
        members=members,
        roles=roles,
        holders=holders,
        plan=plan,
        target=site,
        resources=frozenset(resources),
    )
