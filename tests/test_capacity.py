"""Exact productive-concurrency capacity (spec M-CAPACITY): brute force agreement, finite
resources as cardinality constraints, the reported selection (RES-CAPACITY-TIEBREAK), and
exactness on large states (RES-CAPACITY-EXACT)."""

from __future__ import annotations

import itertools
import random

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from agspec.interp.capacity import (
    CapacityProblem,
    Cand,
    greedy_count,
    greedy_weighted,
    solve_count,
    solve_weighted,
)

# ---------------------------------------------------------------- reference implementations


def compatible(problem: CapacityProblem, chosen: list[Cand]) -> bool:
    """M-CAPACITY feasibility of a selection, straight from the paper's definition of I_t."""
    for a, b in itertools.combinations(chosen, 2):
        if a.group == b.group:
            return False
        if a.xor_key is not None and a.xor_key == b.xor_key:
            return False
        if frozenset((a.index, b.index)) in problem.conflicts:
            return False
    use: dict[str, int] = {}
    for c in chosen:
        for r in set(c.resources):
            use[r] = use.get(r, 0) + 1
    return all(
        n + problem.resource_external_use.get(r, 0) <= problem.resource_capacity.get(r, 1)
        for r, n in use.items()
    )


def brute_force(problem: CapacityProblem, weighted: bool) -> float:
    best = 0.0
    cands = problem.candidates
    for size in range(len(cands) + 1):
        for subset in itertools.combinations(cands, size):
            if compatible(problem, list(subset)):
                best = max(best, sum(c.weight for c in subset) if weighted else size)
    return best


def original_search(problem: CapacityProblem, weighted: bool) -> tuple[str, ...]:
    """The original's exact search as documented (seeded with its greedy set, depth-first over
    groups sorted by (size, product, op), options by (size, duration) or -weight, include before
    skip, strict improvement only): the selection RES-CAPACITY-TIEBREAK promises to report.
    Its candidate list holds only candidates compatible with the active reservations, so a
    candidate whose resource is used up externally takes no place in its group."""
    greedy = list(
        (greedy_weighted if weighted else greedy_count)(problem).selected
    )
    by_id = {c.id: c for c in problem.candidates}
    value = (lambda sel: sum(c.weight for c in sel)) if weighted else len
    best = [value([by_id[i] for i in greedy]), [by_id[i] for i in greedy]]
    groups: dict = {}
    for c in problem.candidates:
        if all(problem.residual_capacity(r) > 0 for r in c.resources):  # admissible at all
            groups.setdefault(c.group, []).append(c)
    option_key = (lambda c: (-c.weight, c.id)) if weighted else (lambda c: (c.size, c.duration, c.id))
    ordered = [sorted(g, key=option_key) for g in sorted(groups.values(), key=lambda g: (len(g), g[0].group))]

    def dfs(i: int, sel: list[Cand]) -> None:
        if i == len(ordered):
            if value(sel) > best[0]:
                best[0], best[1] = value(sel), list(sel)
            return
        for c in ordered[i]:
            if compatible(problem, sel + [c]):
                dfs(i + 1, sel + [c])
        dfs(i + 1, sel)

    dfs(0, [])
    return tuple(sorted(c.id for c in best[1]))


# ---------------------------------------------------------------- random small structures

RESOURCES = ("fixture", "press", "jig")


@st.composite
def small_problems(draw, max_candidates: int = 12):
    n = draw(st.integers(0, max_candidates))
    n_groups = draw(st.integers(1, max(1, n)))
    cands = []
    for i in range(n):
        g = draw(st.integers(0, n_groups - 1))
        product = g % 3
        cands.append(
            Cand(
                index=10 * i + 7,  # indices need not be 0..n-1
                group=(product, f"op{g}"),
                xor_key=draw(st.sampled_from([None, None, (product, "route")])),
                resources=tuple(draw(st.lists(st.sampled_from(RESOURCES), max_size=2, unique=True))),
                weight=draw(st.sampled_from([0.25, 0.5, 1.0, 1.5, 2.75])),  # dyadic: exact sums
                size=draw(st.integers(1, 4)),
                duration=draw(st.integers(1, 9)),
                margin=draw(st.floats(0.0, 1.5)),
                id=f"op:{product}:op{g}:{i:02d}",
            )
        )
    pairs = list(itertools.combinations([c.index for c in cands], 2))
    conflicts = {frozenset(p) for p in pairs if draw(st.integers(0, 99)) < 25}
    return CapacityProblem(
        running=draw(st.integers(0, 3)),
        candidates=cands,
        conflicts=conflicts,
        resource_capacity={r: draw(st.integers(1, 3)) for r in RESOURCES},
        resource_external_use={r: draw(st.integers(0, 2)) for r in RESOURCES},
    )


@settings(max_examples=250, deadline=None)
@given(small_problems())
def test_count_equals_brute_force(problem):  # M-CAPACITY
    result = solve_count(problem)
    assert result.exact
    assert result.k_star == problem.running + brute_force(problem, weighted=False)
    chosen = [c for c in problem.candidates if c.id in result.selected]
    assert len(chosen) == result.k_star - problem.running
    assert compatible(problem, chosen)
    assert greedy_count(problem).k_star <= result.k_star


@settings(max_examples=250, deadline=None)
@given(small_problems())
def test_weighted_equals_brute_force(problem):  # M-CAPACITY, M-WEIGHTED (weighted diagnostic)
    result = solve_weighted(problem)
    assert result.exact
    assert result.weighted_value == pytest.approx(brute_force(problem, weighted=True), abs=1e-9)
    chosen = [c for c in problem.candidates if c.id in result.selected]
    assert compatible(problem, chosen)
    assert result.k_star == problem.running + len(chosen)
    assert greedy_weighted(problem).weighted_value <= result.weighted_value + 1e-9


@settings(max_examples=150, deadline=None)
@given(small_problems(max_candidates=10))
def test_reported_selection_is_the_originals(problem):  # RES-CAPACITY-TIEBREAK
    assert solve_count(problem).selected == original_search(problem, weighted=False)
    assert solve_weighted(problem).selected == original_search(problem, weighted=True)


# ---------------------------------------------------------------- hand-built cases


def cand(index, group, **kw):
    kw.setdefault("id", f"op:{index}")
    return Cand(index=index, group=group, **kw)


def test_greedy_is_suboptimal_exact_is_not():  # M-CAPACITY, RES-CAPACITY-EXACT
    # The cheapest candidate (size 1) blocks two others; its size-2 alternative blocks nothing.
    a1 = cand(1, (0, "join"), size=1, duration=3)
    a2 = cand(2, (0, "join"), size=2, duration=3)
    b = cand(3, (1, "join"), size=2, duration=3)
    c = cand(4, (2, "join"), size=2, duration=3)
    problem = CapacityProblem(running=0, candidates=[a1, a2, b, c], conflicts={frozenset((1, 3)), frozenset((1, 4))})
    greedy, exact = greedy_count(problem), solve_count(problem)
    assert greedy.k_star == 1 and greedy.selected == ("op:1",)
    assert exact.k_star == 3 and exact.selected == ("op:2", "op:3", "op:4")
    assert greedy.k_star < exact.k_star


def test_capacity_two_resource_three_pairwise_compatible_activities():  # M-CAPACITY (paper)
    # "three activities sharing a resource of capacity two are pairwise compatible yet cannot
    # all execute"
    trio = [cand(i, (i, "op"), resources=("fixture",)) for i in range(3)]
    problem = CapacityProblem(running=0, candidates=trio, resource_capacity={"fixture": 2})
    for a, b in itertools.combinations(trio, 2):
        assert compatible(problem, [a, b])
    assert not compatible(problem, trio)
    assert solve_count(problem).k_star == 2
    # A committed external user (e.g. a logistics reservation) leaves room for one more.
    busy = CapacityProblem(0, trio, set(), {"fixture": 2}, {"fixture": 1})
    assert solve_count(busy).k_star == 1
    # Resources default to capacity 1; capacity fully used externally blocks every user.
    assert solve_count(CapacityProblem(0, trio)).k_star == 1
    assert solve_count(CapacityProblem(0, trio, set(), {"fixture": 2}, {"fixture": 2})).k_star == 0


def test_running_activities_count_and_alternatives_exclude_each_other():  # M-CAPACITY
    alternatives = [cand(i, (0, "glue"), size=2) for i in range(4)]  # one occurrence, 4 coalitions
    problem = CapacityProblem(running=2, candidates=alternatives, running_weight=3.0)
    result = solve_count(problem)
    assert result.k_star == 3
    assert result.weighted_value == 4.0


def test_xor_siblings_exclude_each_other():  # M-CAPACITY (XOR exclusivity)
    glue = cand(1, (0, "glue"), xor_key=(0, "route"), weight=1.0)
    weld = cand(2, (0, "weld"), xor_key=(0, "route"), weight=2.0)
    other = cand(3, (1, "weld"), xor_key=(1, "route"), weight=1.0)
    problem = CapacityProblem(running=0, candidates=[glue, weld, other])
    assert solve_count(problem).k_star == 2
    weighted = solve_weighted(problem)
    assert weighted.selected == ("op:2", "op:3") and weighted.weighted_value == 3.0


def test_reports_greedy_seed_when_it_is_optimal():  # RES-CAPACITY-TIEBREAK
    # Two optimal sets of size 1; greedy (size first) picks op:9, DFS order would pick op:1.
    big = cand(1, (0, "a"), size=3, id="op:1")
    small = cand(9, (1, "b"), size=1, id="op:9")
    problem = CapacityProblem(running=0, candidates=[big, small], conflicts={frozenset((1, 9))})
    assert greedy_count(problem).selected == ("op:9",)
    assert solve_count(problem).selected == ("op:9",)


def test_independent_components_add_up():  # M-CAPACITY (decomposition)
    def block(offset):
        cs = [cand(offset + i, (offset, f"op{i % 3}"), size=1 + i % 2) for i in range(6)]
        conf = {frozenset((offset + i, offset + j)) for i, j in [(0, 1), (1, 2), (2, 4), (3, 5)]}
        return cs, conf

    c1, f1 = block(0)
    c2, f2 = block(100)
    one = solve_count(CapacityProblem(0, c1, f1)).k_star
    both = solve_count(CapacityProblem(0, c1 + c2, f1 | f2))
    assert both.exact and both.k_star == 2 * one


def test_node_budget_exhaustion_is_flagged():  # RES-CAPACITY-EXACT (safety net)
    problem = sparse_problem(random.Random(5), 120, 30, 0.08)
    result = solve_count(problem, node_budget=2)
    assert not result.exact
    chosen = [c for c in problem.candidates if c.id in result.selected]
    assert compatible(problem, chosen)
    assert result.k_star >= greedy_count(problem).k_star


# ---------------------------------------------------------------- large states


def sparse_problem(rng: random.Random, n: int, groups: int, density: float) -> CapacityProblem:
    """n candidates in ``groups`` (product, op) groups, independent sparse conflicts, a few
    finite resources; productive weights are per group (as in the interpreter)."""
    weight = [round(rng.uniform(0.1, 3.0), 3) for _ in range(groups)]
    cands = [
        Cand(index=i, group=(i % groups, f"op{i % groups}"), xor_key=None,
             resources=tuple(rng.sample(RESOURCES, rng.choice((0, 0, 0, 1)))),
             weight=weight[i % groups], size=rng.randint(1, 4), duration=rng.randint(1, 12),
             margin=rng.random(), id=f"op:{i % groups}:{i:04d}")
        for i in range(n)
    ]
    conflicts = {frozenset(p) for p in itertools.combinations(range(n), 2) if rng.random() < density}
    return CapacityProblem(
        running=rng.randint(0, 3), candidates=cands, conflicts=conflicts,
        resource_capacity={r: rng.randint(1, 3) for r in RESOURCES},
        resource_external_use={r: rng.randint(0, 1) for r in RESOURCES},
    )


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_large_random_state_is_solved_exactly(seed):  # RES-CAPACITY-EXACT
    problem = sparse_problem(random.Random(seed), 200, 40, 0.02)
    count = solve_count(problem)
    weighted = solve_weighted(problem)
    assert count.exact and weighted.exact
    chosen = [c for c in problem.candidates if c.id in count.selected]
    assert compatible(problem, chosen) and len(chosen) == count.k_star - problem.running
    assert greedy_count(problem).k_star <= count.k_star
    assert greedy_weighted(problem).weighted_value <= weighted.weighted_value + 1e-9
    # The original's limits (64 candidates / 6 groups) are far exceeded here.
    assert len(problem.candidates) > 64


def test_weighted_mode_requires_positive_weights():  # M-CAPACITY
    with pytest.raises(ValueError):
        solve_weighted(CapacityProblem(0, [cand(1, (0, "a"), weight=0.0)]))
