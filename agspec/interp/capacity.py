"""Exact productive-concurrency capacity K* (spec M-CAPACITY).

Paper, "Productive concurrency" and appendix "State-dependent feasibility": with E_run the running
recipe-operation activities and C_new the individually admissible candidates of state s_t,

    K*(s_t) = max |I| over I ⊆ E_run ∪ {e(c)}, I independent in the conflict graph G_op,
              E_run ⊆ I, and |{e ∈ I : ρ ∈ res(e)}| + n_ext(ρ) <= cap(ρ) for every resource ρ.

Two activities are incompatible when they share a robot or an exclusive resource, violate the
geometric rule (the caller's ``conflicts``), are alternative realizations of one operation
occurrence (same ``group`` = (product, op)), or belong to different operations of one product's
XOR group (same ``xor_key``).  Finite capacities above one are cardinality constraints on the
whole selection, not pairwise edges.

This module knows nothing about the interpreter: a :class:`CapacityProblem` is plain data.  The
running activities are fixed members of every I, so only their number (and total weight) is
needed; their resource use must be included in ``resource_external_use`` together with the
logistics reservations (both are committed users outside the candidate choice).

Exactness (resolution RES-CAPACITY-EXACT): the original release switches to a greedy lower bound
above 64 candidates / 6 groups / 100,000 combinations; agspec is exact on every state.  The
search is a branch and bound over groups (include one option, or skip), on bitsets:

1. the live candidate set is split into independent components (connected through conflicts,
   groups, XOR keys and *binding* finite resources) that are solved separately; every answer is
   memoised on (live set, binding residual capacities);
2. a component branches on its most constrained group (fewest live options), best option
   first, then "skip"; subproblems get the value they must beat (fail-hard), so the parent's
   incumbent prunes them;
3. the upper bound is min(greedy clique cover of the live exclusion graph, Σ best value per
   group minus a fractional matching of pairs of groups whose best options exclude each other);
   first fit and a min-degree greedy give lower bounds, and when a lower bound meets the upper
   bound the node is closed;
4. propagation: once every remaining group is needed to beat the incumbent, options that exclude
   all options of a needed group are removed and needed groups with one option are taken.

Reported selection (resolution RES-CAPACITY-TIEBREAK): the optimum value is unique, the set is
not.  We report the set the original's search reports whenever that search is exact: the greedy
seed if it is optimal, otherwise the first optimal set in its depth-first order (groups by
(size, product, op); options by (size, duration, id) for count or (-weight, id) for weight;
including before skipping).  Once the optimum is known, that set is found by a descent along the
canonical order (:meth:`_Search.first_optimum`).
"""

from __future__ import annotations

import math
from typing import Hashable

from agspec.interp.capacity_model import Cand, CapacityProblem, CapacityResult, _bits, _count_option_key, _first_fit
from agspec.interp.capacity_model import _greedy_count_key, _greedy_weight_key, _result, _weight_option_key
from agspec.interp.capacity_model import greedy_count, greedy_weighted

# the problem's data and greedy bounds are importable from here, beside the exact solvers
__all__ = ["Cand", "CapacityProblem", "CapacityResult", "DEFAULT_NODE_BUDGET", "greedy_count", "greedy_weighted",
           "solve_count", "solve_weighted"]

DEFAULT_NODE_BUDGET = 2_000_000
WEIGHT_TOLERANCE = 1e-9  # weighted values within this (relative) tolerance count as equal
HEURISTIC_MIN_CANDIDATES = 12  # component roots this large also run the floor heuristic


# --------------------------------------------------------------------------------------------
# Exact search
# --------------------------------------------------------------------------------------------


class _Search:
    """Branch and bound over one problem, on bitsets.

    Local index = position in the canonical depth-first order (groups in order, options in
    order), so the lowest set bit of a live set is the first option of its first group, and
    first fit in bit order is the lexicographically first feasible assignment.

    ``solve(live, residual, floor)`` answers "the best selection on ``live`` if its value beats
    ``floor``": it returns ``(value, mask, True)`` with the optimum and one optimal selection,
    or ``(bound, None, False)`` when the optimum is known to be at most ``floor`` (fail-hard).
    Both kinds of answers are memoised.  ``first_optimum`` then extracts the canonical
    selection.  Values are ints in count mode (every candidate worth 1), weights otherwise.
    """

    def __init__(self, problem: CapacityProblem, weighted: bool, node_budget: int):
        self.weighted = weighted
        self.node_budget = node_budget
        self.nodes = 0
        self.exhausted = False
        self.memo: dict[tuple, tuple[float, int | None, bool]] = {}

        option_key = _weight_option_key if weighted else _count_option_key
        live = [c for c in problem.candidates if all(problem.residual_capacity(r) > 0 for r in c.resources)]
        groups: dict[Hashable, list[Cand]] = {}
        for cand in live:
            groups.setdefault(cand.group, []).append(cand)
        ordered_groups = sorted(groups.values(), key=lambda g: (len(g), _sortable(g[0].group)))
        self.cands: list[Cand] = [c for g in ordered_groups for c in sorted(g, key=option_key)]
        n = len(self.cands)
        self.value = [c.weight if weighted else 1 for c in self.cands]

        position = {c.index: k for k, c in enumerate(self.cands)}
        self.group_mask = [0] * n
        for k, cand in enumerate(self.cands):
            self.group_mask[k] = sum(1 << position[o.index] for o in groups[cand.group])

        # Pairwise exclusions (M-CAPACITY): group, XOR key, listed conflicts, residual-1 resources.
        adj = [self.group_mask[k] & ~(1 << k) for k in range(n)]
        by_xor: dict[Hashable, int] = {}
        for k, cand in enumerate(self.cands):
            if cand.xor_key is not None:
                by_xor[cand.xor_key] = by_xor.get(cand.xor_key, 0) | (1 << k)
        for k, cand in enumerate(self.cands):
            if cand.xor_key is not None:
                adj[k] |= by_xor[cand.xor_key] & ~(1 << k)
        for pair in problem.conflicts:
            if len(pair) != 2:
                continue
            i, j = tuple(pair)
            if i in position and j in position:
                a, b = position[i], position[j]
                adj[a] |= 1 << b
                adj[b] |= 1 << a
        users: dict[str, int] = {}
        for k, cand in enumerate(self.cands):
            for r in set(cand.resources):
                users[r] = users.get(r, 0) | (1 << k)
        dynamic: list[tuple[int, int]] = []  # (users mask, residual >= 2): cardinality constraints
        for r, mask in sorted(users.items()):
            residual = problem.residual_capacity(r)
            if residual == 1:
                for k in _bits(mask):
                    adj[k] |= mask & ~(1 << k)
            elif mask.bit_count() > residual:  # otherwise it can never bind
                dynamic.append((mask, residual))
        self.adj = adj
        self.res_users = [mask for mask, _ in dynamic]
        self.initial_residual = tuple(res for _, res in dynamic)
        self.res_of = [[ri for ri, m in enumerate(self.res_users) if m >> k & 1] for k in range(n)]
        self.full = (1 << n) - 1
        # Group ids and, per candidate, the other groups it excludes options of (for _forced).
        self.group_id = [0] * n
        for gid, g in enumerate(ordered_groups):
            for cand in g:
                self.group_id[position[cand.index]] = gid
        self.heaviest_first = sorted(range(n), key=lambda k: (-self.value[k], k))
        self.touches = [
            sorted({self.group_id[u] for u in _bits(adj[k] & ~self.group_mask[k])}) for k in range(n)
        ]

    # ---- values

    def _better(self, value: float, than: float) -> bool:
        """Strict improvement (weighted values: by more than the relative tolerance)."""
        if self.weighted:
            return value > than + WEIGHT_TOLERANCE * max(1.0, abs(than))
        return value > than

    # ---- live-set operations

    def _binding(self, live: int, residual: tuple[int, ...]) -> tuple[int, ...]:
        """Finite resources (residual >= 2) with more live users than residual capacity."""
        return tuple(ri for ri, m in enumerate(self.res_users) if (live & m).bit_count() > residual[ri])

    def _choose(self, live: int, residual: tuple[int, ...], k: int) -> tuple[int, tuple[int, ...]]:
        """Live set and residuals after selecting candidate k."""
        live &= ~(self.adj[k] | self.group_mask[k])
        if self.res_of[k]:
            res = list(residual)
            for ri in self.res_of[k]:
                res[ri] -= 1
                if res[ri] <= 0:
                    live &= ~self.res_users[ri]
            residual = tuple(res)
        return live, residual

    def _first_fit(self, live: int, residual: tuple[int, ...]) -> tuple[float, int]:
        """First fit in depth-first order: the lexicographically first feasible assignment."""
        value, chosen = 0, 0
        while live:
            k = (live & -live).bit_length() - 1
            value += self.value[k]
            chosen |= 1 << k
            live, residual = self._choose(live, residual, k)
        return value, chosen

    def _heuristic(self, live: int, residual: tuple[int, ...]) -> float:
        """Value of a good feasible selection (a floor for the search, never reported): the
        better of two greedy rules that repeatedly take the live candidate with the fewest
        exclusions (minimum degree), resp. the best value per excluded value (GWMIN2)."""
        best = self._greedy_by(live, residual, by_weight=False)
        if self.weighted:
            best = max(best, self._greedy_by(live, residual, by_weight=True))
        return best

    def _greedy_by(self, live: int, residual: tuple[int, ...], by_weight: bool) -> float:
        adj, value, group_mask = self.adj, self.value, self.group_mask
        total = 0
        while live:
            best_k, best_score = -1, -1.0
            rest = live
            while rest:
                low = rest & -rest
                rest ^= low
                k = low.bit_length() - 1
                killed = (adj[k] | group_mask[k]) & live
                if by_weight:
                    score = value[k] / sum(value[u] for u in _bits(killed | low))
                else:
                    score = 1.0 / (killed | low).bit_count()
                if score > best_score:
                    best_k, best_score = k, score
            total += value[best_k]
            live, residual = self._choose(live, residual, best_k)
        return total

    def _just_below(self, value: float) -> float:
        """A floor that ``value`` beats (so a search above it returns an optimum >= value)."""
        if self.weighted:
            return value - 2 * WEIGHT_TOLERANCE * max(1.0, abs(value))
        return value - 1

    def _upper_bound(self, live: int, residual: tuple[int, ...], need: float | None = None) -> float:
        """Upper bound on the best value over ``live``; cheap bounds first, and once a bound
        no longer beats ``need`` (the value the caller must beat) it is returned at once.

        1. :meth:`_graph_bound` on the whole live set;
        2. a partition bound when finite resources bind: the live users of a binding resource
           with residual capacity k hold at most k selected activities of distinct groups
           (worth at most the k best group values); the rest is bounded by :meth:`_graph_bound`;
        3. weighted mode: :meth:`_heavy_clique_bound`.
        """
        bound = self._graph_bound(live)
        if self.res_users and (need is None or self._better(bound, need)):
            value, group_mask = self.value, self.group_mask
            partition, rest = 0, live
            for ri, users_mask in enumerate(self.res_users):
                users = rest & users_mask
                best: list[float] = []
                scan = users
                while scan:
                    low = scan & -scan
                    g = scan & group_mask[low.bit_length() - 1]
                    scan &= ~g
                    best.append(value[low.bit_length() - 1])  # options are ordered best first
                if len(best) > residual[ri]:
                    best.sort(reverse=True)
                    partition += sum(best[: residual[ri]])
                    rest &= ~users
            if rest != live:
                bound = min(bound, partition + self._graph_bound(rest))
        if self.weighted and (need is None or self._better(bound, need)):
            bound = min(bound, self._heavy_clique_bound(live))
        return bound

    def _heavy_clique_bound(self, live: int) -> float:
        """Weighted clique cover: candidates, heaviest first, join the first clique they fit
        (else open one, worth their value), so light candidates ride along in heavy cliques."""
        adj, value = self.adj, self.value
        cliques: list[int] = []
        cover = 0.0
        for k in self.heaviest_first:
            if live >> k & 1:
                for c, members in enumerate(cliques):
                    if not members & ~adj[k]:
                        cliques[c] = members | (1 << k)
                        break
                else:
                    cliques.append(1 << k)
                    cover += value[k]
        return cover

    def _graph_bound(self, live: int) -> float:
        """min(clique cover, group bound) on the live exclusion graph.

        * Clique cover: a selection holds at most one activity per clique, worth at most the
          clique's heaviest member; cliques grow from the lowest live bit (which absorbs that
          group).
        * Group bound: Σ over groups of the best live value t_g, minus a fractional matching on
          pairs of groups whose best options exclude each other: such a pair cannot collect
          t_g + t_h, one of the two settles for its second best s or nothing.  Each group g lends
          at most t_g − s_g in total (a weighted clique cover with split weights).
        """
        adj, value, group_mask = self.adj, self.value, self.group_mask
        cover, rest = 0, live
        while rest:
            low = rest & -rest
            rest ^= low
            k = low.bit_length() - 1
            best = value[k]
            pool = rest & adj[k]
            while pool:
                low = pool & -pool
                rest ^= low
                u = low.bit_length() - 1
                pool &= adj[u]
                if value[u] > best:
                    best = value[u]
            cover += best

        # Options are ordered best first within a group, so the lowest live bit is the top.
        slack: dict[int, float] = {}
        top_mask, bound, rest = 0, 0, live
        while rest:
            low = rest & -rest
            k = low.bit_length() - 1
            g = rest & group_mask[k]
            rest &= ~g
            others = g ^ low
            second = value[(others & -others).bit_length() - 1] if others else 0
            bound += value[k]
            if value[k] > second:
                slack[k] = value[k] - second
                top_mask |= low
        if bound <= cover:
            for u in list(slack):
                nb = adj[u] & top_mask & ~((1 << (u + 1)) - 1)
                while nb and slack[u] > 0:
                    low = nb & -nb
                    nb ^= low
                    v = low.bit_length() - 1
                    lend = min(slack[u], slack[v])
                    if lend > 0:
                        slack[u] -= lend
                        slack[v] -= lend
                        bound -= lend
        return min(cover, bound)

    # ---- search

    def solve(
        self, live: int, residual: tuple[int, ...], floor: float, root: bool = False
    ) -> tuple[float, int | None, bool]:
        """See the class docstring.  ``root`` marks a component root (runs the floor heuristic)."""
        if not live:
            return 0, 0, True
        key = (live, tuple((ri, residual[ri]) for ri in self._binding(live, residual)))
        hit = self.memo.get(key)
        if hit is not None and (hit[2] or not self._better(hit[0], floor)):
            return hit
        if self.exhausted or self.nodes >= self.node_budget:
            self.exhausted = True
            value, chosen = self._first_fit(live, residual)
            return value, chosen, True
        self.nodes += 1
        upper = self._upper_bound(live, residual, floor)
        if not self._better(upper, floor):
            result = (upper, None, False)
        else:
            components = self._components(live, key[1])
            if len(components) > 1:
                result = self._solve_components(components, residual, floor)
            else:
                result = self._branch(live, residual, floor, upper, root)
        if not self.exhausted:
            self.memo[key] = result
        return result

    def _components(self, live: int, binding: tuple[tuple[int, int], ...]) -> list[int]:
        """Connected components of ``live`` (exclusions and binding finite resources)."""
        bound_users = [self.res_users[ri] for ri, _ in binding]
        comps = []
        rest = live
        while rest:
            low = rest & -rest
            comp, frontier = low, low
            while frontier:
                k = (frontier & -frontier).bit_length() - 1
                frontier ^= 1 << k
                reach = self.adj[k]
                for m in bound_users:
                    if m >> k & 1:
                        reach |= m
                new = reach & live & ~comp
                comp |= new
                frontier |= new
            comps.append(comp)
            rest &= ~comp
        return comps

    def _solve_components(self, components: list[int], residual: tuple[int, ...], floor: float):
        """Independent components: optimum = Σ component optima, first optimum = union of theirs.
        Component i must beat floor − (values found so far) − (bounds of the others)."""
        bounds = [self._upper_bound(c, residual) for c in components]
        rest_bound = sum(bounds)
        total, chosen = 0, 0
        for comp, ub in zip(components, bounds):
            rest_bound -= ub
            value, mask, exact = self.solve(comp, residual, floor - total - rest_bound, root=True)
            if not exact:
                return floor, None, False
            total += value
            chosen |= mask
        return total, chosen, True

    def _branch(self, live: int, residual: tuple[int, ...], floor: float, upper: float, root: bool):
        """One connected component: branch on its most constrained group (fewest live options;
        options best first, then skip), after propagation (:meth:`_forced`)."""
        found, best = self._first_fit(live, residual)
        if root and live.bit_count() >= HEURISTIC_MIN_CANDIDATES:
            # A better heuristic value raises the floor; the optimum is at least the heuristic's.
            hint = self._heuristic(live, residual)
            if self._better(hint, found):
                floor = max(floor, self._just_below(hint))
        if not self._better(found, floor):
            found, best = None, None
        elif not self._better(upper, found):
            return found, best, True
        threshold = floor if found is None else found

        forced = self._forced(live, residual, threshold)
        if forced is None or forced[4]:
            if forced is not None:  # solve what is left after removals and forced choices
                sub_live, sub_res, gain, mask, _ = forced
                value, sub_mask, exact = self.solve(sub_live, sub_res, threshold - gain)
                if exact and self._better(value + gain, threshold):
                    return value + gain, sub_mask | mask, True
            return (found, best, True) if found is not None else (floor, None, False)

        group = self._most_constrained_group(live)
        branches = [(k, *self._choose(live, residual, k)) for k in _bits(group)]
        branches.append((None, live & ~group, residual))
        for k, sub_live, sub_res in branches:
            gain = 0 if k is None else self.value[k]
            if not self._better(gain + self._upper_bound(sub_live, sub_res, threshold - gain), threshold):
                continue
            value, mask, exact = self.solve(sub_live, sub_res, threshold - gain)
            if exact and self._better(value + gain, threshold):
                found = threshold = value + gain
                best = mask if k is None else mask | (1 << k)
                if not self._better(upper, found):
                    break
        if found is None:
            return floor, None, False
        return found, best, True

    def _most_constrained_group(self, live: int) -> int:
        """The live option mask of the group with the fewest live options (first on ties)."""
        best, best_size, rest = 0, 1 << 30, live
        while rest:
            low = rest & -rest
            g = rest & self.group_mask[low.bit_length() - 1]
            rest &= ~g
            size = g.bit_count()
            if size < best_size:
                best, best_size = g, size
                if size == 1:
                    break
        return best

    def _forced(self, live: int, residual: tuple[int, ...], threshold: float):
        """Propagation for selections that must beat ``threshold`` (sound for the first optimum:
        it only removes options that no such selection uses).

        A group is *mandatory* when the group bound without it does not beat the threshold.
        * An option that excludes every live option of some mandatory group is removed.
        * A mandatory group with a single live option forces that option.
        Returns None if no selection can beat the threshold, else
        (live, residual, gain, mask, changed) after removals and forced choices.
        """
        value, group_mask, group_id, adj = self.value, self.group_mask, self.group_id, self.adj
        gain, mask, changed = 0, 0, False
        while True:
            options: dict[int, int] = {}
            total, rest = 0, live
            while rest:
                low = rest & -rest
                k = low.bit_length() - 1
                g = rest & group_mask[k]
                rest &= ~g
                options[group_id[k]] = g
                total += value[k]  # options are ordered best first
            need = threshold - gain
            if not self._better(total, need):
                return None
            mandatory = {
                gid: g for gid, g in options.items()
                if not self._better(total - value[(g & -g).bit_length() - 1], need)
            }
            if not mandatory:
                return live, residual, gain, mask, changed
            removed = 0
            for k in _bits(live):
                for gid in self.touches[k]:
                    g = mandatory.get(gid)
                    if g is not None and not g & ~adj[k]:
                        removed |= 1 << k
                        break
            if removed:
                live &= ~removed
                changed = True
                continue
            single = [(g & -g).bit_length() - 1 for g in mandatory.values() if not g & (g - 1)]
            if not single:
                return live, residual, gain, mask, changed
            for k in single:
                if not live >> k & 1:  # excluded by another forced choice: re-evaluate
                    break
                gain += value[k]
                mask |= 1 << k
                changed = True
                live, residual = self._choose(live, residual, k)

    def _achieves(self, live: int, residual: tuple[int, ...], target: float) -> bool:
        """Does some selection on ``live`` reach ``target`` (within the weight tolerance)?"""
        if not self._better(target, 0):
            return True
        if self._better(target, self._upper_bound(live, residual)):
            return False
        if not self._better(target, self._heuristic(live, residual)):
            return True
        value, _, exact = self.solve(live, residual, self._just_below(target))
        return exact and not self._better(target, value)

    def first_optimum(self, live: int, residual: tuple[int, ...], target: float) -> int:
        """RES-CAPACITY-TIEBREAK: the first selection in depth-first order (groups in order,
        options in order, skip last) whose value reaches ``target`` = the optimum of ``live``.

        Descends the canonical order, keeping at each group the first option (or the skip)
        that still admits a completion reaching the target.  First fit is the first feasible
        assignment, so it ends the descent as soon as it reaches the target.
        """
        chosen = 0
        while live:
            value, mask = self._first_fit(live, residual)
            if not self._better(target, value):
                return chosen | mask
            first = (live & -live).bit_length() - 1
            group = live & self.group_mask[first]
            for k in _bits(group):
                sub_live, sub_res = self._choose(live, residual, k)
                if self._achieves(sub_live, sub_res, target - self.value[k]):
                    chosen |= 1 << k
                    live, residual, target = sub_live, sub_res, target - self.value[k]
                    break
            else:
                live &= ~group
        return chosen

    def run(self) -> tuple[float, list[Cand]]:
        """Optimum value, then the first optimal selection in the canonical order."""
        floor = -1.0 if self.weighted else -1
        value, chosen, exact = self.solve(self.full, self.initial_residual, floor, root=True)
        if not exact or chosen is None:  # only after an exhausted node budget
            value, chosen = self._first_fit(self.full, self.initial_residual)
        if not self.exhausted:
            first = self.first_optimum(self.full, self.initial_residual, value)
            if not self.exhausted:
                chosen = first
        return value, [self.cands[k] for k in _bits(chosen)]


def _sortable(key: Hashable):
    """Group keys sort naturally when comparable (e.g. (pid, op)); otherwise by their repr."""
    if isinstance(key, tuple):
        return tuple((0, x) if isinstance(x, (int, float)) else (1, str(x)) for x in key)
    if isinstance(key, (int, float)):
        return ((0, key),)
    return ((1, str(key)),)


def _solve(problem: CapacityProblem, weighted: bool, node_budget: int) -> CapacityResult:
    if weighted and any(not c.weight > 0 for c in problem.candidates):
        raise ValueError("productive weights must be positive (M-CAPACITY weighted mode)")
    if not problem.candidates:  # most states: nothing to choose, K* = running (no search, no seed)
        return _result(problem, [], True, 0)
    search = _Search(problem, weighted, node_budget)
    value, chosen = search.run()
    greedy = _first_fit(problem, _greedy_weight_key if weighted else _greedy_count_key)
    greedy_value = math.fsum(c.weight for c in greedy) if weighted else len(greedy)
    exact = not search.exhausted
    # RES-CAPACITY-TIEBREAK: the original's search is seeded with the greedy set and only
    # replaces it by strictly better sets.
    if not search._better(value, greedy_value):
        chosen = greedy
    return _result(problem, chosen, exact, search.nodes)


def solve_count(problem: CapacityProblem, *, node_budget: int = DEFAULT_NODE_BUDGET) -> CapacityResult:
    """M-CAPACITY: exact K* = running + max number of mutually compatible candidates."""
    return _solve(problem, weighted=False, node_budget=node_budget)


def solve_weighted(problem: CapacityProblem, *, node_budget: int = DEFAULT_NODE_BUDGET) -> CapacityResult:
    """M-CAPACITY (weighted diagnostic P*): maximise Σ weight over compatible sets.  ``k_star``
    reports running + the size of the chosen set."""
    return _solve(problem, weighted=True, node_budget=node_budget)
