"""Plain data of the capacity problem (spec M-CAPACITY) and its greedy lower bounds.

A :class:`CapacityProblem` knows nothing about the interpreter.  The canonical orders below are
shared by the greedy bounds and the exact search of :mod:`agspec.interp.capacity`, whose reported
selection follows them (RES-CAPACITY-TIEBREAK); so is ``_bits``, the search's walk over a set of
candidates held as a bitset.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Hashable, Iterable, Mapping


@dataclass(frozen=True)
class Cand:
    """One prospective activity e(c) of an individually admissible candidate (M-CAPACITY).

    ``group`` identifies the operation occurrence, normally (product id, op id): alternative
    realizations of one occurrence exclude each other.  Candidates of *different* groups with
    the same non-None ``xor_key`` (normally (product id, xor group id)) exclude each other.
    ``size``, ``duration`` and ``margin`` (coalition size, total planned duration, minimum reach
    margin) only order the search and the greedy bound; ``weight`` is the productive weight.
    """

    index: int
    group: Hashable
    xor_key: Hashable | None = None
    resources: tuple[str, ...] = ()
    weight: float = 1.0
    size: int = 1
    duration: int = 1
    margin: float = 0.0
    id: str = ""


@dataclass(frozen=True)
class CapacityProblem:
    """The capacity question of one state (M-CAPACITY).

    ``conflicts`` holds pairwise incompatibilities as ``frozenset({i, j})`` of :attr:`Cand.index`
    values (shared robot, geometry, or anything else the caller knows about).  Resources missing
    from ``resource_capacity`` have capacity 1.  ``resource_external_use`` counts committed users
    outside the choice: logistics reservations and running operation teams.  Candidates
    should already be compatible with the active reservations; one whose resource has no
    residual capacity left is dropped before anything else (it never counts in a group's size).
    """

    running: int
    candidates: list[Cand]
    conflicts: set[frozenset[int]] = field(default_factory=set)
    resource_capacity: Mapping[str, int] = field(default_factory=dict)
    resource_external_use: Mapping[str, int] = field(default_factory=dict)
    running_weight: float = 0.0

    def residual_capacity(self, resource: str) -> int:
        """cap(ρ) − n_ext(ρ): how many more users ρ admits."""
        return self.resource_capacity.get(resource, 1) - self.resource_external_use.get(resource, 0)


@dataclass(frozen=True)
class CapacityResult:
    """K* = running + |selected| (count mode), with the selected candidate ids (ascending).

    ``weighted_value`` = running weight + Σ weights of the selection.  ``exact`` is False only
    for greedy bounds and for searches that exhausted their node budget.
    """

    k_star: int
    selected: tuple[str, ...]
    exact: bool
    weighted_value: float
    nodes_explored: int


# --------------------------------------------------------------------------------------------
# Canonical orders (shared by the search and the greedy bounds)
# --------------------------------------------------------------------------------------------


def _count_option_key(c: Cand):
    return (c.size, c.duration, c.id)


def _weight_option_key(c: Cand):
    return (-c.weight, c.id)


def _greedy_count_key(c: Cand):
    return (c.size, c.duration, -c.margin, c.id)


def _greedy_weight_key(c: Cand):
    return (-c.weight, c.size, -c.margin, c.id)


def _exclusive(a: Cand, b: Cand, conflicts: set[frozenset[int]]) -> bool:
    """Pairwise incompatibility: same group, XOR siblings, or a listed conflict (M-CAPACITY)."""
    if a.group == b.group:
        return True
    if a.xor_key is not None and a.xor_key == b.xor_key:
        return True
    return frozenset((a.index, b.index)) in conflicts


def _result(problem: CapacityProblem, chosen: list[Cand], exact: bool, nodes: int) -> CapacityResult:
    return CapacityResult(
        k_star=problem.running + len(chosen),
        selected=tuple(sorted(c.id for c in chosen)),
        exact=exact,
        weighted_value=problem.running_weight + math.fsum(c.weight for c in chosen),
        nodes_explored=nodes,
    )


# --------------------------------------------------------------------------------------------
# Greedy lower bounds (the original release's fallback, kept for diagnostics)
# --------------------------------------------------------------------------------------------


def _first_fit(problem: CapacityProblem, key: Callable[[Cand], object]) -> list[Cand]:
    residual: dict[str, int] = {}
    chosen: list[Cand] = []
    for cand in sorted(problem.candidates, key=key):
        resources = set(cand.resources)
        if any(residual.setdefault(r, problem.residual_capacity(r)) <= 0 for r in resources):
            continue
        if any(_exclusive(cand, other, problem.conflicts) for other in chosen):
            continue
        chosen.append(cand)
        for r in resources:
            residual[r] -= 1
    return chosen


def greedy_count(problem: CapacityProblem) -> CapacityResult:
    """The original's deterministic greedy lower bound for K* (M-CAPACITY, diagnostics only):
    candidates sorted by (size, total duration, −min margin, id), first fit.  ``exact`` = False."""
    return _result(problem, _first_fit(problem, _greedy_count_key), False, 0)


def greedy_weighted(problem: CapacityProblem) -> CapacityResult:
    """The original's greedy lower bound for the weighted capacity P*: candidates sorted by
    (−weight, size, −min margin, id), first fit.  ``exact`` = False."""
    return _result(problem, _first_fit(problem, _greedy_weight_key), False, 0)


# --------------------------------------------------------------------------------------------
# Candidate sets as bitsets
# --------------------------------------------------------------------------------------------


def _bits(mask: int) -> Iterable[int]:
    while mask:
        low = mask & -mask
        yield low.bit_length() - 1
        mask ^= low
