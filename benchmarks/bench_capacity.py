"""Solve-time benchmark of the exact capacity search (M-CAPACITY) on random structures.

Two families of random states, sized like (and beyond) the official AssemblyGrid v1 suite:

* ``grid``: robots on an M x N grid; every (product, op) group has its own anchor (holder)
  robot and its candidates are coalitions inside 2 x 2 blocks containing the anchor; two candidates conflict when
  they share a robot, or (geometry) with some probability when their anchors are close; a few
  finite resources with capacities 1-3 and external use; XOR keys shared by groups of a product.
* ``sparse``: structure-free candidates in groups with independent sparse conflicts.

Usage: python benchmarks/bench_capacity.py [--states 20] [--seed 0] [--json out.json]
Prints a table (median / p99 / max solve time and node counts per family and size) and JSON.
"""

from __future__ import annotations

import argparse
import itertools
import json
import random
import statistics
import sys
import time

from agspec.interp.capacity import CapacityProblem, Cand, greedy_count, solve_count, solve_weighted

RESOURCES = ("fixture", "press", "jig")


def grid_problem(rng: random.Random, rows: int, cols: int, groups: int, max_per_group: int) -> CapacityProblem:
    """Official-like state: coalitions of 1-4 robots in 2x2 blocks around an anchor robot."""
    cands: list[Cand] = []
    members: dict[int, frozenset] = {}
    anchors: dict[int, tuple[int, int]] = {}
    products = max(1, groups // 3)
    # A robot holds one item, so different groups have different holder (anchor) robots.
    holders = rng.sample([(i, j) for i in range(rows) for j in range(cols)], groups)
    for g, anchor in enumerate(holders):
        pid, op = g % products, f"op{g}"
        arity = rng.choice((1, 1, 2, 2, 2, 3, 4))
        blocks = []
        for di, dj in itertools.product((-1, 0), repeat=2):
            block = [(anchor[0] + di + a, anchor[1] + dj + b) for a in (0, 1) for b in (0, 1)]
            if all(0 <= i < rows and 0 <= j < cols for i, j in block):
                blocks.append(block)
        coalitions = set()
        for block in blocks:
            others = [c for c in block if c != anchor]
            for extra in itertools.combinations(others, arity - 1):
                coalitions.add(frozenset((anchor, *extra)))
        coalitions = sorted(coalitions, key=sorted)
        rng.shuffle(coalitions)
        xor_key = (pid, "route") if rng.random() < 0.15 else None
        resources = tuple(rng.sample(RESOURCES, rng.choice((0, 0, 0, 1, 1, 2))))
        weight = rng.choice((0.5, 1.0, 1.5, 2.0)) * (1 + rng.random())  # per (product, op)
        for coalition in coalitions[:max_per_group]:
            index = len(cands)
            cells = ";".join(f"{i},{j}" for i, j in sorted(coalition))
            cands.append(
                Cand(index=index, group=(pid, op), xor_key=xor_key, resources=resources,
                     weight=weight, size=len(coalition),
                     duration=rng.randint(2, 12), margin=rng.random(), id=f"op:{pid}:{op}:{cells}")
            )
            members[index] = coalition
            anchors[index] = anchor
    conflicts = set()
    for a, b in itertools.combinations(range(len(cands)), 2):
        if members[a] & members[b]:
            conflicts.add(frozenset((a, b)))
        else:
            (ai, aj), (bi, bj) = anchors[a], anchors[b]
            if max(abs(ai - bi), abs(aj - bj)) <= 1 and rng.random() < 0.3:
                conflicts.add(frozenset((a, b)))
    return CapacityProblem(
        running=rng.randint(0, 3), candidates=cands, conflicts=conflicts,
        resource_capacity={r: rng.randint(1, 3) for r in RESOURCES},
        resource_external_use={r: rng.randint(0, 1) for r in RESOURCES},
    )


def sparse_problem(rng: random.Random, n: int, groups: int, density: float, per_candidate_weights: bool = False) -> CapacityProblem:
    """Structure-free state: n candidates in ``groups`` groups, independent conflicts.  Weights
    are per group (as productive weights are per (product, op)) unless ``per_candidate_weights``."""
    group_weight = [rng.random() + 0.1 for _ in range(groups)]
    cands = [
        Cand(index=i, group=(i % groups, f"op{i % groups}"), xor_key=None,
             resources=tuple(rng.sample(RESOURCES, rng.choice((0, 0, 1)))),
             weight=rng.random() + 0.1 if per_candidate_weights else group_weight[i % groups], size=rng.randint(1, 4), duration=rng.randint(1, 12),
             margin=rng.random(), id=f"op:{i:04d}")
        for i in range(n)
    ]
    conflicts = {frozenset((a, b)) for a, b in itertools.combinations(range(n), 2) if rng.random() < density}
    return CapacityProblem(
        running=0, candidates=cands, conflicts=conflicts,
        resource_capacity={r: rng.randint(1, 3) for r in RESOURCES},
        resource_external_use={r: rng.randint(0, 1) for r in RESOURCES},
    )


CONFIGS = {
    # name: (family, factory(rng) -> problem)
    "grid 5x6, 6 groups": lambda rng: grid_problem(rng, 5, 6, 6, 12),
    "grid 6x8, 12 groups": lambda rng: grid_problem(rng, 6, 8, 12, 12),
    "grid 6x8, 24 groups": lambda rng: grid_problem(rng, 6, 8, 24, 12),
    "grid 6x8, 40 groups": lambda rng: grid_problem(rng, 6, 8, 40, 12),
    "sparse 200 cand / 40 groups, p=0.02": lambda rng: sparse_problem(rng, 200, 40, 0.02),
    "sparse 120 cand / 30 groups, p=0.08": lambda rng: sparse_problem(rng, 120, 30, 0.08),
    "sparse 100 cand / 20 groups, p=0.05, w/cand": lambda rng: sparse_problem(rng, 100, 20, 0.05, True),
}


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, max(0, round(q * (len(ordered) - 1))))]


def run(states: int, seed: int) -> dict:
    report = {}
    for name, factory in CONFIGS.items():
        rng = random.Random(f"{seed}:{name}")
        times, nodes, sizes, gaps, exact = [], [], [], [], 0
        for _ in range(states):
            problem = factory(rng)
            for solve in (solve_count, solve_weighted):
                start = time.perf_counter()
                result = solve(problem)
                times.append(time.perf_counter() - start)
                nodes.append(result.nodes_explored)
                exact += result.exact
            count = solve_count(problem)
            gaps.append(count.k_star - greedy_count(problem).k_star)
            sizes.append(len(problem.candidates))
        report[name] = {
            "solves": len(times),
            "exact_fraction": exact / len(times),
            "candidates_median": statistics.median(sizes),
            "candidates_max": max(sizes),
            "time_median_ms": 1e3 * statistics.median(times),
            "time_p99_ms": 1e3 * percentile(times, 0.99),
            "time_max_ms": 1e3 * max(times),
            "nodes_median": statistics.median(nodes),
            "nodes_p99": percentile(nodes, 0.99),
            "nodes_max": max(nodes),
            "greedy_gap_mean": statistics.mean(gaps),
            "greedy_gap_max": max(gaps),
        }
    return report


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--states", type=int, default=20, help="random states per configuration")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", help="also write the JSON report to this file")
    args = parser.parse_args(argv)
    report = run(args.states, args.seed)
    header = f"{'configuration':40} {'cands':>9} {'exact':>6} {'med ms':>8} {'p99 ms':>8} {'max ms':>8} {'nodes med/p99/max':>20} {'greedy gap':>10}"
    print(header)
    print("-" * len(header))
    for name, r in report.items():
        nodes = f"{r['nodes_median']:.0f}/{r['nodes_p99']}/{r['nodes_max']}"
        print(f"{name:40} {r['candidates_median']:>5.0f}/{r['candidates_max']:<3} {r['exact_fraction']:>6.2f} "
              f"{r['time_median_ms']:>8.2f} {r['time_p99_ms']:>8.2f} {r['time_max_ms']:>8.2f} {nodes:>20} "
              f"{r['greedy_gap_mean']:>5.2f}/{r['greedy_gap_max']}")
    text = json.dumps({"states_per_configuration": args.states, "seed": args.seed, "results": report}, indent=2)
    print(text)
    if args.json:
        with open(args.json, "w", encoding="utf-8") as fh:
            fh.write(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
