"""The paper's results layout with the user's rows (F-POLICY-TABLE): one model, three renderings.

:func:`layout` turns episodes into rows (references, published MARL rows, the user's policies) by
scenario columns; :func:`markdown` and :func:`latex` (booktabs, the paper's format) render it, as
does the CLI's rich table.  Cells are mean ± 1.96·s/√n over the instances (F-POLICY-COMPARISON);
every cell carries its coverage (F-POLICY-COVERAGE) and every rendering shows n per row, marks an
incomplete cell with ‡ and its "n of N", and says what the published rows' intervals are over.  A
trained policy's row (F-POLICY-BUDGET) is named by its method, marked † below the paper's training
budget, and footnoted with its budget and evaluation action.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any, Iterable, Mapping, Sequence

from agspec.controllers import CONTROLLERS
from agspec.policy import published, trained
from agspec.policy.coverage import Planned, coverage, planned_from_episodes
from agspec.policy.stats import summary_cell

# display names of the paper (tab:nonlearning, fig:familyoutcomes)
DISPLAY = {"random": "Random masked", "greedy": "Greedy", "parallel-aware": "Parallel-aware",
           "centralized": "Centralized"}
DECIMALS = {"delivered": 2, "completion_rate": 3, "throughput": 4}
FAMILIES = ("flow", "coalition", "concurrency")
DIFFICULTIES = ("easy", "medium", "hard")
INCOMPLETE = "‡"  # a cell over fewer ok episodes than planned (F-POLICY-COVERAGE)


@dataclass(frozen=True)
class Row:
    label: str
    kind: str  # reference | published | policy
    cells: tuple[dict[str, Any] | None, ...]
    training: Mapping[str, Any] | None = None  # F-POLICY-BUDGET: the run of a trained policy

    @property
    def complete(self) -> bool:
        return all(c is None or c.get("complete", True) for c in self.cells)


def display(label: str) -> str:
    return DISPLAY.get(label, label)


def published_cell(metric: str, name: str, scenario: str) -> dict[str, Any] | None:
    """A published MARL cell: its n is the number of training seeds its interval is over."""
    row = published.cell(metric, name, scenario)
    if row is None:
        return None
    seeds = re.search(r"over (\d+) training", row.get("interval", ""))
    return {"mean": row["mean"], "half_width": row["half_width"], "n": int(seeds.group(1)) if seeds else None,
            "unit": "training seeds", "complete": True}


def layout(episodes: Sequence[Mapping[str, Any]], labels: Sequence[str], scenarios: Sequence[str], metric: str,
           with_published: bool = True, planned: Planned | None = None,
           policies: Sequence[Mapping[str, Any]] | Mapping[str, Mapping[str, Any]] | None = None) -> list[Row]:
    """References first (paper order), then the paper's published MARL rows, then the user's policies.

    ``planned`` (F-POLICY-COVERAGE) says which episodes each cell should be over; without it, every
    policy is expected on every instance that any policy ran in the scenario.  ``policies`` (the
    bundle's identities) give a trained policy's row its run (F-POLICY-BUDGET).
    """
    runs = trained.trainings(policies)
    plan = planned if planned is not None else planned_from_episodes(episodes)

    def cell(label: str, scenario: str) -> dict[str, Any]:
        return {**summary_cell(episodes, label, scenario, metric), **coverage(episodes, plan, label, scenario).fields()}

    refs = [lab for lab in CONTROLLERS if lab in labels]
    mine = [lab for lab in labels if lab not in CONTROLLERS]
    out = [Row(lab, "reference", tuple(cell(lab, s) for s in scenarios)) for lab in refs]
    if with_published:
        for name in published.MARL:
            cells = tuple(published_cell(metric, name, s) for s in scenarios)
            if any(cells):
                out.append(Row(name, "published", cells))
    out += [Row(lab, "policy", tuple(cell(lab, s) for s in scenarios), runs.get(lab)) for lab in mine]
    return out


def fmt_cell(cell: Mapping[str, Any] | None, metric: str, pm: str = " ± ", mark: str = " " + INCOMPLETE) -> str:
    """mean ± half-width; the mean alone when n = 1; "—" when nothing counts; incomplete: ``mark (n of N)``."""
    if not cell:
        return "—"
    d = DECIMALS.get(metric, 3)
    if cell.get("mean") is None or cell.get("n", 1) == 0:
        text = "—"
    elif cell.get("half_width") is None:
        text = f"{cell['mean']:.{d}f}"
    else:
        text = f"{cell['mean']:.{d}f}{pm}{cell['half_width']:.{d}f}"
    if not cell.get("complete", True):
        text += f"{mark} ({cell.get('n', 0)} of {cell['planned']})"
    return text


def row_n(row: Row) -> str:
    """n of a row: instances with an ok episode (one number when every cell agrees), or training seeds."""
    cells = [c for c in row.cells if c and (row.kind == "published" or c.get("planned", c.get("n")))]
    if not cells:  # nothing planned in any column
        return "—"
    ns = sorted({c.get("n") or 0 for c in cells})
    text = str(ns[0]) if len(ns) == 1 else f"{ns[0]}–{ns[-1]}"
    if row.kind == "published":
        return f"{text} seeds"
    if not row.complete:
        return f"{text} of {max(c.get('planned', 0) for c in cells)} {INCOMPLETE}"
    return text


def row_name(row: Row) -> str:
    if row.training is not None:  # F-POLICY-BUDGET
        return trained.row_name(row.label, row.training)
    return display(row.label) + (" (published)" if row.kind == "published" else "")


def trained_rows(rows: Sequence[Row]) -> dict[str, Mapping[str, Any]]:
    return {r.label: r.training for r in rows if r.training is not None}


def notes(rows: Sequence[Row], instances: str) -> list[str]:
    """What every rendering says under its table: what n and the interval are over, the marks, and each
    trained row's budget and evaluation action (F-POLICY-BUDGET)."""
    out = [f"Cells: mean ± 95 % half-width (1.96·s/√n) over the n instances with an ok episode, of {instances}; "
           "a mean without ± is over n = 1 (no interval)."]
    if any(not r.complete for r in rows):
        out.append(f"{INCOMPLETE} incomplete: fewer ok episodes than planned (errors or missing episodes), shown as "
                   "(n of N); its mean leaves those episodes out.")
    if any(r.kind == "published" for r in rows):
        out.append("Published rows are copied from the paper (fig:familyoutcomes, tab:checkpoint-heldout), not re-run: "
                   "their n is training seeds and their interval a 95 % Student-t interval over those seeds, each "
                   "seed's value a mean over the 50 final-test instances, each trained for the paper's "
                   f"{trained.paper_steps():,} environment steps.")
    return out + trained.notes(trained_rows(rows))


def fmt_num(x: float | None, d: int = 3) -> str:
    return "—" if x is None else f"{x:.{d}f}"


def fmt_p(p: float | None) -> str:
    return "—" if p is None else (f"{p:.3g}" if p >= 1e-4 else "<1e-4")


def comparison_cells(c: Mapping[str, Any]) -> list[str]:
    d = DECIMALS.get(c["metric"], 3)
    ci = "—" if c["ci_low"] is None else f"[{c['ci_low']:.{d}f}, {c['ci_high']:.{d}f}]"
    return [c["scenario"], display(c["reference"]), str(c["n"]), fmt_num(c["mean_difference"], d), ci,
            fmt_num(c["t"], 2), fmt_p(c["p_value"]), fmt_p(c["wilcoxon_p"])]


COMPARISON_HEADER = ["scenario", "reference", "n", "Δ mean", "95 % CI", "t", "p (t-test)",
                     "p (Wilcoxon)"]


def markdown(rows: list[Row], scenarios: Sequence[str], metric: str, comparisons: Iterable[Mapping[str, Any]] = (),
             instances: str = "the instances") -> str:
    head = ["Method", "n", *scenarios]
    lines = [f"**{metric}** — {instances}", "",
             "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for row in rows:
        lines.append("| " + " | ".join([row_name(row), row_n(row), *(fmt_cell(c, metric) for c in row.cells)]) + " |")
    lines += [""] + notes(rows, instances)
    comps = [c for c in comparisons if c["metric"] == metric]
    for policy in dict.fromkeys(c["policy"] for c in comps):
        lines += ["", f"Paired comparison, {policy} − reference ({metric}, same instances):", "",
                  "| " + " | ".join(COMPARISON_HEADER) + " |", "|" + "---|" * len(COMPARISON_HEADER)]
        lines += ["| " + " | ".join(comparison_cells(c)) + " |" for c in comps if c["policy"] == policy]
    return "\n".join(lines) + "\n"


def tex(text: str) -> str:
    return (text.replace("_", r"\_").replace("&", r"\&").replace("%", r"\%").replace("#", r"\#")
            .replace("–", "--").replace("—", "---").replace("ε", r"$\varepsilon$"))


def latex(rows: list[Row], scenarios: Sequence[str], metric: str, caption: str | None = None,
          instances: str = "the instances") -> str:
    """A booktabs table as in the paper: families as column groups, difficulties as columns, and n."""
    grouped = all("-" in s and s.rsplit("-", 1)[1] in DIFFICULTIES for s in scenarios)
    out = [r"\begin{table}[t]", r"\centering", r"\small",
           rf"\caption{{{tex(caption or metric.replace('_', ' ').capitalize())} "
           rf"(mean $\pm$ 95\,\% half-width over the $n$ instances with an ok episode, of {tex(instances)}).}}",
           r"\begin{tabular}{lr" + "c" * len(scenarios) + "}", r"\toprule"]
    if grouped:
        families = list(dict.fromkeys(s.rsplit("-", 1)[0] for s in scenarios))
        spans, col = [], 3
        heads = []
        for fam in families:
            k = sum(1 for s in scenarios if s.rsplit("-", 1)[0] == fam)
            heads.append(rf"\multicolumn{{{k}}}{{c}}{{\textsc{{{fam.capitalize()}}}}}")
            spans.append(rf"\cmidrule(lr){{{col}-{col + k - 1}}}")
            col += k
        out.append(" & & " + " & ".join(heads) + r" \\")
        out.append(" ".join(spans))
        out.append("Method & $n$ & " + " & ".join(rf"\textsc{{{s.rsplit('-', 1)[1]}}}" for s in scenarios) + r" \\")
    else:
        out.append("Method & $n$ & " + " & ".join(tex(s) for s in scenarios) + r" \\")
    out.append(r"\midrule")
    previous = None
    for row in rows:
        if previous is not None and row.kind != previous:
            out.append(r"\addlinespace")
        previous = row.kind
        name = tex(row_name(row)).replace(trained.MARK, r"$^{\dagger}$")
        cells = [_latex_cell(c, metric) for c in row.cells]
        n = row_n(row).replace(INCOMPLETE, r"$^{\ddagger}$")
        out.append(name + " & " + _tex_n(n) + " & " + " & ".join(cells) + r" \\")
    out += [r"\bottomrule", r"\end{tabular}"]
    foot = []
    if any(not r.complete for r in rows):
        foot.append(r"$^{\ddagger}$Incomplete: fewer ok episodes than planned (errors or missing episodes), shown as "
                    r"($n$ of $N$); the mean leaves those episodes out.")
    if any(r.kind == "published" for r in rows):
        foot.append(r"Published rows: from the AssemblyGrid v1 paper (not re-run), trained for "
                    + tex(f"{trained.paper_steps():,}") + r" environment steps; $n$ is training seeds and the "
                    r"interval a 95\,\% Student-t interval over those seeds.")
    foot += [tex(line).replace(trained.MARK, r"$^{\dagger}$") for line in trained.notes(trained_rows(rows))]
    if foot:
        out.append(r"\par\footnotesize " + r" ".join(foot))
    out.append(r"\end{table}")
    return "\n".join(out) + "\n"


def _tex_n(text: str) -> str:
    return text.replace("–", "--")


def _latex_cell(cell: Mapping[str, Any] | None, metric: str) -> str:
    if not cell:
        return "--"
    value = fmt_cell({**cell, "complete": True}, metric, r" \pm ")
    body = "--" if value == "—" else f"${value}$"
    if not cell.get("complete", True):
        body += rf"$^{{\ddagger}}$ ({cell.get('n', 0)} of {cell['planned']})"
    return body
