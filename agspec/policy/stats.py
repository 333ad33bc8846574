"""Summaries and the paired comparison of a policy against a reference (F-POLICY-COMPARISON).

Per-policy summaries are the paper's mean ± 1.96·s/√n (:func:`mean_ci`).  The paired
comparison pairs episodes by (scenario, suite index), both ``ok``; its interval and test are SciPy's
``ttest_rel`` (Student-t on the paired differences, the paper's paired intervals) with the Wilcoxon
signed-rank test beside it.  SciPy is the optional extra ``agspec[eval]``.
"""

from __future__ import annotations

import math
import statistics
from typing import Any, Iterable, Mapping

from agspec.extras import scipy_stats


def mean_ci(values: list[float]) -> tuple[float, float]:
    """Mean and 95 % normal-approximation half-width 1.96·s/√n (s: sample standard deviation)."""
    if not values:
        return (math.nan, math.nan)
    mean = statistics.fmean(values)
    if len(values) < 2:
        return (mean, 0.0)
    return (mean, 1.96 * statistics.stdev(values) / math.sqrt(len(values)))


def _scipy_stats():
    return scipy_stats("the paired comparison")


def _finite(x: float) -> float | None:
    return float(x) if x is not None and math.isfinite(float(x)) else None


def paired(policy: list[float], reference: list[float]) -> dict[str, Any]:
    """Mean difference policy − reference, its 95 % paired Student-t interval, and paired tests."""
    stats = _scipy_stats()
    n = len(policy)
    out: dict[str, Any] = {"n": n, "mean_difference": None, "ci_low": None, "ci_high": None, "t": None,
                           "p_value": None, "wilcoxon_p": None}
    if n == 0:
        return out
    diffs = [a - b for a, b in zip(policy, reference)]
    out["mean_difference"] = sum(diffs) / n
    if n < 2:
        return out
    if all(d == diffs[0] for d in diffs):  # zero variance: the interval is the point, no test is defined
        out["ci_low"] = out["ci_high"] = out["mean_difference"]
        return out
    res = stats.ttest_rel(policy, reference)
    ci = res.confidence_interval(0.95)
    out.update(ci_low=_finite(ci.low), ci_high=_finite(ci.high), t=_finite(res.statistic), p_value=_finite(res.pvalue))
    if any(d != 0 for d in diffs):
        out["wilcoxon_p"] = _finite(stats.wilcoxon(diffs).pvalue)
    return out


def values_by_episode(runs: Iterable[Mapping[str, Any]], label: str, scenario: str, metric: str) -> dict[int, float]:
    """index -> metric value of the ``ok`` first runs of one policy in one scenario."""
    out: dict[int, float] = {}
    for r in runs:
        if (r["controller"] == label and r["scenario"] == scenario and r.get("status", "ok") == "ok"
                and not r.get("repeat") and r["metrics"].get(metric) is not None):
            out[int(r["index"])] = float(r["metrics"][metric])
    return out


def compare(runs: list[Mapping[str, Any]], policy: str, references: Iterable[str], scenarios: Iterable[str],
            metric: str) -> list[dict[str, Any]]:
    """F-POLICY-COMPARISON of ``policy`` against each reference, per scenario, on common instances."""
    out = []
    for scenario in scenarios:
        mine = values_by_episode(runs, policy, scenario, metric)
        for ref in references:
            theirs = values_by_episode(runs, ref, scenario, metric)
            common = sorted(set(mine) & set(theirs))
            if not common:
                continue
            entry = paired([mine[k] for k in common], [theirs[k] for k in common])
            out.append({"scenario": scenario, "policy": policy, "reference": ref, "metric": metric, **entry})
    return out


def summary_cell(runs: Iterable[Mapping[str, Any]], label: str, scenario: str, metric: str) -> dict[str, Any]:
    """mean ± half-width (1.96·s/√n) of one policy's ok episodes in one scenario; no interval below n = 2
    (one value has no spread to report, and "± 0" would claim one)."""
    values = list(values_by_episode(runs, label, scenario, metric).values())
    mean, half = mean_ci(values)
    return {"mean": _finite(mean), "half_width": _finite(half) if len(values) >= 2 else None, "n": len(values)}
