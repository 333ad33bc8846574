"""Paper reproduction report: our numbers beside the AssemblyGrid v1 paper's (`agspec evaluate --paper`).

Runs exactly what the paper's tables report for the non-learning references and writes
``docs/reproduction.md`` and ``docs/reproduction.json``.  Nothing is tuned: the semantics are the
spec's.  Marks: *exact* (equal at the paper's printed precision), *inside* (within the paper's
95 % interval), *outside*.
"""

from __future__ import annotations

import json
import math
import statistics
from pathlib import Path
from typing import Any, Callable

from agspec.campaign.executor import ExecutorSpec
from agspec.evaluate import evaluate
from agspec.formats import output
from agspec.formats.schemas import self_check
from agspec.policy.stats import mean_ci

FINAL_TEST = range(1000, 1050)
MATCHED = range(0, 50)
COALITION = ("coalition-easy", "coalition-medium", "coalition-hard")
OFFICIAL = ("flow-easy", "flow-medium", "flow-hard", "coalition-easy", "coalition-medium", "coalition-hard",
            "concurrency-easy", "concurrency-medium", "concurrency-hard")
GEOMETRY = ("geometry-matched-low", "geometry-matched-medium", "geometry-matched-high")
RHO = {"geometry-matched-low": 0.12, "geometry-matched-medium": 0.25, "geometry-matched-high": 0.40}

# Paper table "Privileged Centralized method" (mean delivered, final test 1000-1049).
PAPER_CENTRALIZED = {"flow-easy": 21.28, "flow-medium": 27.68, "flow-hard": 38.20, "coalition-easy": 17.68,
                     "coalition-medium": 15.46, "coalition-hard": 3.86, "concurrency-easy": 10.06,
                     "concurrency-medium": 17.74, "concurrency-hard": 18.50}
# Paper table "Non-learning Coalition deliveries": mean ± 95 % half-width.
PAPER_COALITION = {
    "random": {"coalition-easy": (1.28, 0.26), "coalition-medium": (1.26, 0.24), "coalition-hard": (0.00, 0.00)},
    "greedy": {"coalition-easy": (17.34, 0.64), "coalition-medium": (14.76, 0.54), "coalition-hard": (3.88, 0.41)},
    "parallel-aware": {"coalition-easy": (17.68, 0.65), "coalition-medium": (14.86, 0.39),
                       "coalition-hard": (3.86, 0.40)},
}
# Paper table "Matched geometry sensitivity" (Greedy; suite indices 0-49): metric -> (values, decimals).
PAPER_GEOMETRY = {
    "delivered": ((15.20, 14.60, 13.94), 2),
    "completion_rate": ((0.792, 0.784, 0.776), 3),
    "throughput": ((0.038, 0.036, 0.035), 3),
    "geometry_blocked": ((267, 307, 336), 0),
    "blocked_activities": ((269, 309, 338), 0),
    "capacity_mean": ((0.828, 0.807, 0.774), 3),
    "realized_concurrency_mean": ((0.766, 0.740, 0.707), 3),
    "utilization": ((0.927, 0.923, 0.916), 3),
    "robot_occupancy": ((0.189, 0.183, 0.175), 3),
}
# Paragraph after that table: paired endpoint differences (rho 0.12 -> 0.40): mean and 95 % interval.
PAPER_PAIRED = {
    "greedy": {"delivered": (-1.26, (-1.80, -0.72), 2), "realized_concurrency_mean": (-0.060, (-0.086, -0.034), 3),
               "geometry_blocked": (69, (53, 85), 0)},
    "parallel-aware": {"delivered": (-1.18, (-1.73, -0.63), 2),
                       "realized_concurrency_mean": (-0.037, (-0.067, -0.007), 3),
                       "geometry_blocked": (70, (52, 87), 0)},
    "centralized": {"delivered": (-1.22, (-1.78, -0.67), 2),
                    "realized_concurrency_mean": (-0.068, (-0.097, -0.039), 3),
                    "geometry_blocked": (75, (60, 90), 0)},
}

RANDOM_NOTE = ("The original release's random-masked controller is not public; agspec's C-RANDOM draws "
               "uniformly among legal actions from one stream seeded by the execution seed (spec/11), so its "
               "numbers are compared with the paper's interval, not expected to be exact.")


class EpisodeFailures(Exception):
    """Episodes of the reproduction produced no metrics (CAMP-FAULTS); ``errors`` names each cause."""

    def __init__(self, errors: list[str]):
        super().__init__(f"{len(errors)} episode(s) failed; first: {errors[0]}")
        self.errors = errors


def t_quantile(p: float, df: int) -> float:
    """Quantile of Student's t distribution (bisection on a Simpson-integrated density; stdlib only)."""
    log_c = math.lgamma((df + 1) / 2) - math.lgamma(df / 2) - 0.5 * math.log(df * math.pi)

    def pdf(x: float) -> float:
        return math.exp(log_c - (df + 1) / 2 * math.log1p(x * x / df))

    def cdf(x: float, steps: int = 2000) -> float:  # P(T <= x) for x >= 0
        h = x / steps
        area = pdf(0) + pdf(x) + sum((4 if k % 2 else 2) * pdf(k * h) for k in range(1, steps))
        return 0.5 + area * h / 3

    lo, hi = 0.0, 50.0
    for _ in range(60):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if cdf(mid) < p else (lo, mid)
    return (lo + hi) / 2


def paired_ci(diffs: list[float]) -> tuple[float, float]:
    """Mean paired difference and its 95 % Student-t half-width (the paper's paired intervals)."""
    mean = statistics.fmean(diffs)
    return mean, t_quantile(0.975, len(diffs) - 1) * statistics.stdev(diffs) / math.sqrt(len(diffs))


def mark(ours: float, paper: float, decimals: int, interval: tuple[float, float] | None = None) -> str:
    """exact: equal at the paper's printed precision; inside: within the paper's interval; else outside."""
    if round(ours, decimals) == round(paper, decimals):
        return "exact"
    if interval is not None and interval[0] - 10 ** -decimals / 2 <= ours <= interval[1] + 10 ** -decimals / 2:
        return "inside"
    return "outside"


def _jobs(plan: list[tuple[str, str, range]]):
    from agspec.catalogue import load_scenario_bundle
    from agspec.ir.instance import make_instance

    bundles: dict[str, Any] = {}
    for scenario, controller, indices in plan:
        if scenario not in bundles:
            bundles[scenario] = load_scenario_bundle(scenario)
        sc, recipes, profile = bundles[scenario]
        for k in indices:
            yield (scenario, controller, k, make_instance(sc, recipes, profile, index=k))


def default_plan() -> list[tuple[str, str, range]]:
    plan = [(s, "centralized", FINAL_TEST) for s in OFFICIAL]
    plan += [(s, c, FINAL_TEST) for c in ("random", "greedy", "parallel-aware") for s in COALITION]
    plan += [(s, c, MATCHED) for c in ("greedy", "parallel-aware", "centralized") for s in GEOMETRY]
    return plan


def build_report(runs: list[dict[str, Any]]) -> dict[str, Any]:
    """Compare runs (as returned by agspec.evaluate.evaluate) with the paper's numbers."""
    by: dict[tuple[str, str], dict[int, dict]] = {}
    for r in runs:
        if r["metrics"] is not None:  # failed episodes (CAMP-FAULTS) are reported by the caller
            by.setdefault((r["scenario"], r["controller"]), {})[r["index"]] = r["metrics"]

    def values(scenario: str, controller: str, key: str) -> list[float]:
        return [float(m[key]) for _, m in sorted(by.get((scenario, controller), {}).items()) if m.get(key) is not None]

    rows: list[dict[str, Any]] = []
    for scenario, paper in PAPER_CENTRALIZED.items():
        vals = values(scenario, "centralized", "delivered")
        if vals:
            mean, half = mean_ci(vals)
            rows.append({"table": "Privileged Centralized method", "scenario": scenario, "controller": "centralized",
                         "metric": "delivered", "ours": mean, "ours_half_width": half, "paper": paper,
                         "paper_interval": None, "decimals": 2, "n": len(vals), "mark": mark(mean, paper, 2)})
    for controller, cells in PAPER_COALITION.items():
        for scenario, (paper, half_paper) in cells.items():
            vals = values(scenario, controller, "delivered")
            if not vals:
                continue
            mean, half = mean_ci(vals)
            interval = (paper - half_paper, paper + half_paper)
            m = mark(mean, paper, 2, interval)
            if m == "exact" and round(half, 2) != round(half_paper, 2):
                m = "inside"
            rows.append({"table": "Non-learning Coalition deliveries", "scenario": scenario, "controller": controller,
                         "metric": "delivered", "ours": mean, "ours_half_width": half, "paper": paper,
                         "paper_half_width": half_paper, "paper_interval": [round(v, 2) for v in interval], "decimals": 2,
                         "n": len(vals), "mark": m})
    for metric, (papers, decimals) in PAPER_GEOMETRY.items():
        for scenario, paper in zip(GEOMETRY, papers):
            vals = values(scenario, "greedy", metric)
            if vals:
                mean, half = mean_ci(vals)
                rows.append({"table": "Matched geometry sensitivity (Greedy)", "scenario": scenario,
                             "rho_conf": RHO[scenario], "controller": "greedy", "metric": metric, "ours": mean,
                             "ours_half_width": half, "paper": paper, "paper_interval": None, "decimals": decimals,
                             "n": len(vals), "mark": mark(mean, paper, decimals)})
    for controller, metrics in PAPER_PAIRED.items():
        low = by.get((GEOMETRY[0], controller), {})
        high = by.get((GEOMETRY[2], controller), {})
        common = sorted(set(low) & set(high))
        for metric, (paper, interval, decimals) in metrics.items():
            diffs = [float(high[k][metric]) - float(low[k][metric]) for k in common
                     if high[k].get(metric) is not None and low[k].get(metric) is not None]
            if len(diffs) < 2:
                continue
            mean, half = paired_ci(diffs)
            rows.append({"table": "Paired endpoint differences rho 0.12 -> 0.40 (Student-t 95 %)", "scenario": "geometry-matched",
                         "controller": controller, "metric": metric, "ours": mean, "ours_half_width": half,
                         "ours_interval": [mean - half, mean + half], "paper": paper, "paper_interval": list(interval),
                         "decimals": decimals, "n": len(diffs), "mark": mark(mean, paper, decimals, interval),
                         "interval_mark": "exact" if [round(mean - half, decimals), round(mean + half, decimals)]
                         == [round(interval[0], decimals), round(interval[1], decimals)] else "differs"})
    for r in rows:
        r["explanation"] = explanation(r)
    counts = {m: sum(1 for r in rows if r["mark"] == m) for m in ("exact", "inside", "outside")}
    return {"title": "AssemblyGrid v1 paper reproduction", "generated_by": "agspec evaluate --paper",
            "rows": rows, "counts": counts, "episodes": len(runs)}


def _fmt(value: float, decimals: int = 3) -> str:
    return "—" if value is None or (isinstance(value, float) and math.isnan(value)) else f"{value:.{decimals}f}"


def paper_text(row: dict[str, Any]) -> str:
    """The paper's value (and interval, if it publishes one) at the paper's printed precision."""
    d = row.get("decimals", 2)
    text = _fmt(float(row["paper"]), d)
    if row.get("paper_half_width") is not None:
        text += f" ± {_fmt(row['paper_half_width'], d)}"
    if row.get("paper_interval"):
        lo, hi = row["paper_interval"]
        text += f" [{_fmt(float(lo), d)}, {_fmt(float(hi), d)}]"
    return text


def ours_text(row: dict[str, Any]) -> str:
    """Our mean (one digit beyond the paper's precision) ± half-width, and our interval for paired rows."""
    d = row.get("decimals", 2) + 1
    text = f"{_fmt(row['ours'], d)} ± {_fmt(row['ours_half_width'], d)}"
    if row.get("ours_interval"):
        lo, hi = row["ours_interval"]
        text += f" [{_fmt(lo, d - 1)}, {_fmt(hi, d - 1)}]"
    return text


def explanation(row: dict[str, Any]) -> str | None:
    """Why a number is not exact: the spec resolution behind the difference (None for exact rows)."""
    if row["mark"] == "exact" and row.get("interval_mark", "exact") == "exact":
        return None
    if row["controller"] == "random":
        return RANDOM_NOTE
    if row["mark"] == "exact":  # mean exact, interval endpoints differ
        return ("Mean exact; the interval endpoints differ at the paper's precision (the paper does not state "
                "its paired-interval method; agspec uses Student-t with n-1 degrees of freedom).")
    return ("Not explained by a documented spec resolution: a semantic difference from the original release "
            "(the interpreter is deterministic; report it as a bug).")


def render_markdown(report: dict[str, Any]) -> str:
    out = ["<!-- GENERATED by `agspec evaluate --paper`; do not edit by hand. -->", "",
           "# AssemblyGrid v1 paper reproduction", "",
           "This file is generated by `agspec evaluate --paper -j 2` (with `docs/reproduction.json`); "
           "regenerate it, never edit it. The paper's values are quoted in `agspec/reproduce.py`; no parameter "
           "is tuned to match them, the semantics are the spec's.", "",
           f"{report['episodes']} episodes. Marks: **exact** = equal at the paper's printed precision; "
           "**inside** = within the paper's 95 % interval; **outside** = neither. "
           f"Totals over {len(report['rows'])} published numbers: {report['counts']['exact']} exact, "
           f"{report['counts']['inside']} inside, {report['counts']['outside']} outside.", ""]
    tables: dict[str, list[dict]] = {}
    for row in report["rows"]:
        tables.setdefault(row["table"], []).append(row)
    for title, rows in tables.items():
        paired = any(r.get("ours_interval") for r in rows)
        head = "| scenario | controller | metric | ours (± 95 %) | paper | mark |"
        if paired:
            head += " interval endpoints |"
        out += [f"## {title}", "", head, "|---" * head.count(" | ") + "|---|"]
        for r in rows:
            line = f"| {r['scenario']} | {r['controller']} | {r['metric']} | {ours_text(r)} | {paper_text(r)} | {r['mark']} |"
            if paired:
                line += f" {r.get('interval_mark', '—')} |"
            out.append(line)
        out.append("")
    differing = [r for r in report["rows"] if explanation(r)]
    out += ["## Differences and their causes", ""]
    if not differing:
        out += ["Every number is exact.", ""]
    for r in differing:
        out.append(f"* {r['table']} · {r['scenario']} · {r['controller']} · {r['metric']}: ours "
                   f"{ours_text(r)}, paper {paper_text(r)} ({r['mark']}). {explanation(r)}")
    out += ["", "## Notes", "",
            "* Intervals: tables use the paper's 95 % normal approximation 1.96·s/√n over the 50 instances; "
            "the paired endpoint differences (same suite index at ρ_conf 0.12 and 0.40) use the Student-t "
            "quantile t(0.975, 49) ≈ 2.01, which reproduces the paper's printed endpoints (1.96 does not).",
            "* A *Non-learning Coalition* row is exact only if both the mean and the half-width are equal at "
            "the paper's precision; otherwise it is compared with the paper's interval.",
            "* Centralized: the productive weight follows RES-CENTRALIZED-WEIGHT (spec/07-metrics.md).",
            "* Matched geometry control: suite indices 0-49 with generation seed 10000+k (RES-MATCHED-SEEDS); "
            "the paper's table reports Greedy, the paired differences all three structured controllers.",
            "* Not reproduced here: the Random masked matched-geometry figures quoted in the text after the "
            "matched table (no table, no interval) and all learning (MARL) results.", ""]
    return "\n".join(out)


def run_paper(workers: int = 1, out_dir: Path | None = None, plan: list | None = None,
              on_done: Callable[[dict], None] | None = None, executor: ExecutorSpec | None = None) -> dict[str, Any]:
    """Run the plan and write the report; an episode that failed (CAMP-FAULTS) raises
    :class:`EpisodeFailures` and nothing is written (the report would compare partial numbers)."""
    jobs = list(_jobs(plan if plan is not None else default_plan()))
    runs = evaluate(jobs, workers=workers, on_done=on_done, executor=executor)
    errors = [f"{r['scenario']}/{r['controller']}/{r['index']}: {r['error']['message']}"
              for r in runs if r["metrics"] is None]
    if errors:
        raise EpisodeFailures(errors)
    report = build_report(runs)
    if out_dir is not None:
        output.make_dir(out_dir)  # F-OUTPUT-FAILURES
        self_check("reproduction", report)  # F-SCHEMAS-SELF
        output.write_text(out_dir / "reproduction.json", json.dumps(report, indent=2) + "\n")
        output.write_text(out_dir / "reproduction.md", render_markdown(report))
    return report


__all__ = ["run_paper", "EpisodeFailures", "build_report", "render_markdown", "mark", "default_plan", "paper_text", "ours_text",
           "explanation", "paired_ci", "t_quantile"]
