"""The paper's results layout with the user's rows (F-POLICY-TABLE): one model, three renderings.

:func:`layout` turns episodes into rows (references, published MARL rows, the user's policies) by
scenario columns; :func:`markdown` and :func:`latex` (booktabs, the paper's format) render it, as
does the CLI's rich table.  Cells are mean ± 1.96·s/√n over the instances (F-POLICY-COMPARISON).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Iterable, Mapping, Sequence

from agspec.controllers import CONTROLLERS
from agspec.policy import published
from agspec.policy.stats import summary_cell

# display names of the paper (tab:nonlearning, fig:familyoutcomes)
DISPLAY = {"random": "Random masked", "greedy": "Greedy", "parallel-aware": "Parallel-aware",
           "centralized": "Centralized"}
DECIMALS = {"delivered": 2, "completion_rate": 3, "throughput": 4}
FAMILIES = ("flow", "coalition", "concurrency")
DIFFICULTIES = ("easy", "medium", "hard")


@dataclass(frozen=True)
class Row:
    label: str
    kind: str  # reference | published | policy
    cells: tuple[dict[str, Any] | None, ...]


def display(label: str) -> str:
    return DISPLAY.get(label, label)


def layout(episodes: Sequence[Mapping[str, Any]], labels: Sequence[str], scenarios: Sequence[str], metric: str,
           with_published: bool = True) -> list[Row]:
    """References first (paper order), then the paper's published MARL rows, then the user's policies."""
    refs = [lab for lab in CONTROLLERS if lab in labels]
    mine = [lab for lab in labels if lab not in CONTROLLERS]
    out = [Row(lab, "reference", tuple(summary_cell(episodes, lab, s, metric) for s in scenarios)) for lab in refs]
    if with_published:
        for name in published.MARL:
            cells = tuple(published.cell(metric, name, s) for s in scenarios)
            if any(cells):
                out.append(Row(name, "published", cells))
    out += [Row(lab, "policy", tuple(summary_cell(episodes, lab, s, metric) for s in scenarios)) for lab in mine]
    return out


def fmt_cell(cell: Mapping[str, Any] | None, metric: str, pm: str = " ± ") -> str:
    if not cell or cell.get("mean") is None or cell.get("n", 1) == 0:
        return "—"
    d = DECIMALS.get(metric, 3)
    if cell.get("half_width") is None:
        return f"{cell['mean']:.{d}f}"
    return f"{cell['mean']:.{d}f}{pm}{cell['half_width']:.{d}f}"


def row_name(row: Row) -> str:
    return display(row.label) + (" (published)" if row.kind == "published" else "")


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


def markdown(rows: list[Row], scenarios: Sequence[str], metric: str, comparisons: Iterable[Mapping[str, Any]] = ()
             ) -> str:
    head = ["Method", *scenarios]
    lines = [f"**{metric}** — mean ± 95 % half-width (1.96·s/√n over instances)", "",
             "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for row in rows:
        lines.append("| " + " | ".join([row_name(row), *(fmt_cell(c, metric) for c in row.cells)]) + " |")
    comps = [c for c in comparisons if c["metric"] == metric]
    for policy in dict.fromkeys(c["policy"] for c in comps):
        lines += ["", f"Paired comparison, {policy} − reference ({metric}, same instances):", "",
                  "| " + " | ".join(COMPARISON_HEADER) + " |", "|" + "---|" * len(COMPARISON_HEADER)]
        lines += ["| " + " | ".join(comparison_cells(c)) + " |" for c in comps if c["policy"] == policy]
    if any(r.kind == "published" for r in rows):
        lines += ["", "Published rows are copied from the paper (fig:familyoutcomes, tab:checkpoint-heldout), not "
                      "re-run; their intervals are across ten training replicates."]
    return "\n".join(lines) + "\n"


def _tex(text: str) -> str:
    return text.replace("_", r"\_").replace("&", r"\&").replace("%", r"\%").replace("#", r"\#")


def latex(rows: list[Row], scenarios: Sequence[str], metric: str, caption: str | None = None) -> str:
    """A booktabs table as in the paper: families as column groups, difficulties as columns."""
    grouped = all("-" in s and s.rsplit("-", 1)[1] in DIFFICULTIES for s in scenarios)
    out = [r"\begin{table}[t]", r"\centering", r"\small",
           rf"\caption{{{_tex(caption or metric.replace('_', ' ').capitalize())} "
           r"(mean $\pm$ 95\,\% half-width over instances).}",
           r"\begin{tabular}{l" + "c" * len(scenarios) + "}", r"\toprule"]
    if grouped:
        families = list(dict.fromkeys(s.rsplit("-", 1)[0] for s in scenarios))
        spans, col = [], 2
        heads = []
        for fam in families:
            k = sum(1 for s in scenarios if s.rsplit("-", 1)[0] == fam)
            heads.append(rf"\multicolumn{{{k}}}{{c}}{{\textsc{{{fam.capitalize()}}}}}")
            spans.append(rf"\cmidrule(lr){{{col}-{col + k - 1}}}")
            col += k
        out.append(" & " + " & ".join(heads) + r" \\")
        out.append(" ".join(spans))
        out.append("Method & " + " & ".join(rf"\textsc{{{s.rsplit('-', 1)[1]}}}" for s in scenarios) + r" \\")
    else:
        out.append("Method & " + " & ".join(_tex(s) for s in scenarios) + r" \\")
    out.append(r"\midrule")
    previous = None
    for row in rows:
        if previous is not None and row.kind != previous:
            out.append(r"\addlinespace")
        previous = row.kind
        name = _tex(display(row.label)) + ("$^{\\dagger}$" if row.kind == "published" else "")
        cells = ["--" if fmt_cell(c, metric) == "—" else "$" + fmt_cell(c, metric, r"\pm") + "$" for c in row.cells]
        out.append(name + " & " + " & ".join(cells) + r" \\")
    out += [r"\bottomrule", r"\end{tabular}"]
    if any(r.kind == "published" for r in rows):
        out.append(r"\par\footnotesize $^{\dagger}$Published in the AssemblyGrid v1 paper (not re-run); interval "
                   r"across ten training replicates.")
    out.append(r"\end{table}")
    return "\n".join(out) + "\n"
