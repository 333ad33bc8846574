"""The paper's held-out row from several trained checkpoints (spec/16-training.md, T-CHECKPOINT-ROW).

tab:checkpoint-heldout summarizes ten independently trained final checkpoints of one method on one
scenario: each policy's mean over its final-test episodes, then the mean of those per-policy means
with the 95 % Student-t half-width t₀.₉₇₅,ₙ₋₁·s/√n across the n policies.  The uncertainty is over
training seeds, not instances.  Every row states its runs' training steps against the paper's and their
evaluation action; a row with a run below the paper's budget is marked † and footnoted
(F-POLICY-BUDGET).  The t quantile is SciPy's (the extra ``agspec[eval]``).
"""

from __future__ import annotations

import math
import statistics
from typing import Any, Iterable, Mapping

from agspec.extras import scipy_stats
from agspec.policy import published, trained
from agspec.policy.tables import tex as tex_escape

PAPER_NAMES = {"ippo": "IPPO", "mappo": "MAPPO", "qmix": "QMIX"}


def t_half_width(values: list[float]) -> float | None:
    """t₀.₉₇₅,ₙ₋₁ · s / √n over per-policy means; None for fewer than two."""
    if len(values) < 2:
        return None
    stats = scipy_stats("the Student-t interval over training seeds")
    return float(stats.t.ppf(0.975, len(values) - 1) * statistics.stdev(values) / math.sqrt(len(values)))


def rows(policies: Iterable[Mapping[str, Any]], episodes: Iterable[Mapping[str, Any]],
         metric: str = "delivered") -> list[dict[str, Any]]:
    """One row per (algorithm, scenario) of the checkpoint policies (F-POLICY-CHECKPOINT) in a bundle.

    A policy counts only with every one of its (first-run) episodes of that scenario ``ok``; the others
    are listed under ``incomplete``.  Each row carries the number of policies and of instances per policy.
    """
    eps = [e for e in episodes if not e.get("repeat")]
    groups: dict[tuple[str, str], list[tuple[str, Mapping[str, Any]]]] = {}
    for p in policies:
        training = p.get("training")
        if p.get("kind") == "checkpoint" and training:
            training = trained.with_action(p)["training"]  # F-POLICY-BUDGET: the action of older bundles
            groups.setdefault((training["algorithm"], training["scenario"]), []).append((p["label"], training))
    out = []
    for (algorithm, scenario), members in sorted(groups.items()):
        means, seeds, incomplete, instances = [], [], [], set()
        steps = sorted({int(t["steps"]) for _label, t in members})
        actions = sorted({trained.action(t) for _label, t in members})
        for label, training in sorted(members, key=lambda m: m[1]["seed"]):
            mine = [e for e in eps if e["controller"] == label and e["scenario"] == scenario]
            if not mine or any(e.get("status") != "ok" for e in mine):
                incomplete.append(label)
                continue
            instances.add(len(mine))
            means.append(statistics.fmean(float(e["metrics"][metric]) for e in mine))
            seeds.append(training["seed"])
        paper = published.cell(metric, PAPER_NAMES[algorithm], scenario)
        out.append({"algorithm": algorithm, "scenario": scenario, "metric": metric, "n": len(means),
                    "seeds": seeds, "instances_per_policy": sorted(instances),
                    "mean": statistics.fmean(means) if means else None, "half_width": t_half_width(means),
                    "per_policy": means, "incomplete": incomplete, "steps": steps, "actions": actions,
                    "below_budget": steps[0] < trained.paper_steps(),
                    "published": {"mean": paper["mean"], "half_width": paper["half_width"]} if paper else None})
    return out


def _cell(mean: float | None, half: float | None) -> str:
    if mean is None:
        return "—"
    return f"{mean:.2f}" if half is None else f"{mean:.2f} ± {half:.2f}"


def method(r: Mapping[str, Any]) -> str:
    """The method's name, marked † when a run of the row is below the paper's budget (F-POLICY-BUDGET)."""
    return PAPER_NAMES[r["algorithm"]] + (trained.MARK if r["below_budget"] else "")


def notes(table: list[dict[str, Any]]) -> list[str]:
    """Under the table: each row's budget against the paper's and its evaluation action (F-POLICY-BUDGET)."""
    out = []
    for r in table:
        steps = trained.steps_range(r["steps"])
        budget = trained.budget(r["steps"][0]) if len(r["steps"]) == 1 else \
            f"{steps} training steps (the paper's: {trained.paper_steps():,})"
        out.append(f"{method(r)} on {r['scenario']} — {budget}; evaluated with "
                   f"{' and '.join(trained.ACTION_TEXT[a] for a in r['actions'])}.")
    if any(r["below_budget"] for r in table):
        out.append(trained.mark_note())
    return out


def markdown(table: list[dict[str, Any]]) -> str:
    """T-CHECKPOINT-ROW as Markdown: n runs, instances per run and training steps in every row."""
    if not table:
        return ""
    paper = f"{trained.paper_steps():,}"
    lines = [f"Trained checkpoints, {table[0]['metric']}: mean of per-policy means, 95 % Student-t over training "
             "seeds (tab:checkpoint-heldout's rule)", "",
             f"| method | scenario | training steps (paper: {paper}) | action | n runs | instances per run | "
             f"this evaluation | published (10 runs × 50, {paper} steps) | left out |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in table:
        pub = r["published"]
        lines.append(f"| {method(r)} | {r['scenario']} | {trained.steps_range(r['steps'])} | {', '.join(r['actions'])} | "
                     f"{r['n']} | {', '.join(map(str, r['instances_per_policy'])) or '—'} | "
                     f"{_cell(r['mean'], r['half_width'])} | {_cell(pub['mean'], pub['half_width']) if pub else '—'} | "
                     f"{', '.join(r['incomplete']) or '—'} |")
    return "\n".join(lines + [""] + notes(table)) + "\n"


def latex(table: list[dict[str, Any]]) -> str:
    """T-CHECKPOINT-ROW as a booktabs table."""
    if not table:
        return ""
    pm = "$\\pm$"
    body = []
    for r in table:
        pub = r["published"]
        ours = _cell(r["mean"], r["half_width"]).replace(" ± ", pm)
        theirs = _cell(pub["mean"], pub["half_width"]).replace(" ± ", pm) if pub else "--"
        name = method(r).replace(trained.MARK, "$^{\\dagger}$")
        body.append(f"{name} & {r['scenario']} & {trained.steps_range(r['steps']).replace('–', '--')} & "
                    f"{', '.join(r['actions'])} & {r['n']} & {ours} & {theirs} \\\\")
    foot = [_tex(line) for line in notes(table)]
    return "\n".join(["\\begin{tabular}{llrlrrr}", "\\toprule",
                      f"Method & Scenario & Steps (paper: {trained.paper_steps():,}) & Action & $n$ & This evaluation "
                      "& Published \\\\", "\\midrule", *body, "\\bottomrule", "\\end{tabular}",
                      "\\par\\footnotesize " + " ".join(foot), ""])


def _tex(text: str) -> str:
    return tex_escape(text).replace(trained.MARK, "$^{\\dagger}$")
