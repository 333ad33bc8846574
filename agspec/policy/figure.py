"""The paper's family figure with the user's policies as more series (F-POLICY-FIGURE).

fig:familyoutcomes: admitted completion (top row) and delivered products (bottom row) for the
Coalition, Concurrency and Flow families, bars grouped by difficulty, 95 % error bars.  Needs
matplotlib (extra ``agspec[plot]``); drawn with the non-interactive Agg backend.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping, Sequence

from agspec.policy.stats import MissingExtra
from agspec.policy.tables import DIFFICULTIES, Row, display, layout

PANEL_FAMILIES = ("coalition", "concurrency", "flow")  # the paper's column order
PANEL_METRICS = (("completion_rate", "Admitted completion", 1.0), ("delivered", "Delivered products / horizon", None))
FORMATS = ("svg", "png", "pdf")


def _pyplot():
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise MissingExtra("figures need matplotlib: pip install 'agspec[plot]'") from None
    return plt


def series(episodes: Sequence[Mapping[str, Any]], labels: Sequence[str], with_published: bool
           ) -> dict[str, list[Row]]:
    """metric -> rows over the nine official scenarios (family-major, easy -> hard)."""
    scenarios = [f"{fam}-{d}" for fam in PANEL_FAMILIES for d in DIFFICULTIES]
    return {metric: layout(episodes, labels, scenarios, metric, with_published) for metric, _, _ in PANEL_METRICS}


def draw(episodes: Sequence[Mapping[str, Any]], labels: Sequence[str], path: Path, with_published: bool = True
         ) -> Path:
    """Render the figure to ``path`` (format from its suffix: .svg, .png or .pdf)."""
    plt = _pyplot()
    data = series(episodes, labels, with_published)
    fig, axes = plt.subplots(2, 3, figsize=(11, 5.6), sharey="row", constrained_layout=True)
    rows_any = data["delivered"]
    shown = [r for r in rows_any if any(c and c.get("mean") is not None for c in r.cells)
             or any(c and c.get("mean") is not None for c in next(x for x in data["completion_rate"]
                                                                  if x.label == r.label).cells)]
    width = 0.8 / max(len(shown), 1)
    for i, (metric, ylabel, ymax) in enumerate(PANEL_METRICS):
        for j, family in enumerate(PANEL_FAMILIES):
            ax = axes[i][j]
            for k, row in enumerate(r for r in data[metric] if r.label in {s.label for s in shown}):
                cells = row.cells[3 * j:3 * j + 3]
                xs = [d + (k - (len(shown) - 1) / 2) * width for d in range(3)]
                means = [c["mean"] if c and c.get("mean") is not None else float("nan") for c in cells]
                errs = [c["half_width"] if c and c.get("half_width") is not None else 0.0 for c in cells]
                name = display(row.label) + (" (published)" if row.kind == "published" else "")
                ax.bar(xs, means, width, yerr=errs, capsize=1.5, label=name,
                       hatch="//" if row.kind == "policy" else None, error_kw={"linewidth": 0.6})
            ax.set_xticks(range(3), DIFFICULTIES)
            if ymax:
                ax.set_ylim(0, ymax)
            if i == 0:
                ax.set_title(family.capitalize(), fontweight="bold")
            if j == 0:
                ax.set_ylabel(ylabel)
    handles, names = axes[1][0].get_legend_handles_labels()
    fig.legend(handles, names, loc="outside lower center", ncols=min(len(names), 5), frameon=False)
    fig.suptitle("Decentralized reference behavior across workload families (final-test, 95 % intervals)")
    fig.savefig(path, format=path.suffix.lstrip(".").lower())
    plt.close(fig)
    return path
