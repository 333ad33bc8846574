"""The paper's family figure with the user's policies as more series (F-POLICY-FIGURE).

fig:familyoutcomes: admitted completion (top row) and delivered products (bottom row) for the
Coalition, Concurrency and Flow families, bars grouped by difficulty, 95 % error bars.  Each
series' legend entry states its n (instances, or training seeds for published rows) and marks an
incomplete series (F-POLICY-COVERAGE); the title states the instance set.  Needs matplotlib (extra
``agspec[plot]``); drawn with the non-interactive Agg backend, SVG text kept as text.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping, Sequence

from agspec.policy.coverage import Planned
from agspec.policy.stats import MissingExtra
from agspec.policy.tables import DIFFICULTIES, INCOMPLETE, Row, display, layout, row_n

PANEL_FAMILIES = ("coalition", "concurrency", "flow")  # the paper's column order
PANEL_METRICS = (("completion_rate", "Admitted completion", 1.0), ("delivered", "Delivered products / horizon", None))
FORMATS = ("svg", "png", "pdf")


def _pyplot():
    try:
        import matplotlib

        matplotlib.use("Agg")
        matplotlib.rcParams["svg.fonttype"] = "none"  # text stays text: searchable, editable, checkable
        import matplotlib.pyplot as plt
    except ImportError:
        raise MissingExtra("figures need matplotlib: pip install 'agspec[plot]'") from None
    return plt


SCENARIOS = tuple(f"{fam}-{d}" for fam in PANEL_FAMILIES for d in DIFFICULTIES)


def series(episodes: Sequence[Mapping[str, Any]], labels: Sequence[str], with_published: bool,
           planned: Planned | None = None) -> dict[str, list[Row]]:
    """metric -> rows over the nine official scenarios (family-major, easy -> hard)."""
    return {metric: layout(episodes, labels, SCENARIOS, metric, with_published, planned)
            for metric, _, _ in PANEL_METRICS}


def legend_label(rows: Sequence[Row]) -> str:
    """A series' legend entry: name, n over both panels' cells, and the incomplete mark."""
    first = rows[0]
    cells = tuple(c for r in rows for c in r.cells)
    n = row_n(Row(first.label, first.kind, cells))
    name = display(first.label) + (" (published)" if first.kind == "published" else "")
    if first.kind == "published":
        return f"{name}, n = {n}"
    return f"{name}, n = {n}" + (" incomplete" if INCOMPLETE in n else "")


def draw(episodes: Sequence[Mapping[str, Any]], labels: Sequence[str], path: Path, with_published: bool = True,
         planned: Planned | None = None, instances: str = "final-test instances", fmt: str | None = None) -> Path:
    """Render the figure to ``path`` (format ``fmt``, else from its suffix: .svg, .png or .pdf)."""
    plt = _pyplot()
    data = series(episodes, labels, with_published, planned)
    fig, axes = plt.subplots(2, 3, figsize=(11, 5.6), sharey="row", constrained_layout=True)
    # a series is shown when it has a value or a planned episode in a panel: a row whose every episode
    # failed still appears, in the legend as incomplete (F-POLICY-COVERAGE)
    shown = [r for r in data["delivered"]
             if any(c and (c.get("mean") is not None or c.get("planned"))
                    for m, _, _ in PANEL_METRICS for x in data[m] if x.label == r.label for c in x.cells)]
    width = 0.8 / max(len(shown), 1)
    for i, (metric, ylabel, ymax) in enumerate(PANEL_METRICS):
        for j, family in enumerate(PANEL_FAMILIES):
            ax = axes[i][j]
            for k, row in enumerate(r for r in data[metric] if r.label in {s.label for s in shown}):
                cells = row.cells[3 * j:3 * j + 3]
                xs = [d + (k - (len(shown) - 1) / 2) * width for d in range(3)]
                means = [c["mean"] if c and c.get("mean") is not None else float("nan") for c in cells]
                errs = [c["half_width"] if c and c.get("half_width") is not None else 0.0 for c in cells]
                name = legend_label([r for m, _, _ in PANEL_METRICS for r in data[m] if r.label == row.label])
                ax.bar(xs, means, width, yerr=errs, capsize=1.5, label=name,
                       hatch="//" if row.kind == "policy" else None, error_kw={"linewidth": 0.6})
                for x, c in zip(xs, cells):  # F-POLICY-COVERAGE: an incomplete bar says so, with its n of N
                    if c and not c.get("complete", True):
                        ax.annotate(f"{INCOMPLETE}{c.get('n', 0)}/{c['planned']}", (x, c.get("mean") or 0.0),
                                    ha="center", va="bottom", fontsize="x-small", rotation=90)
            ax.set_xticks(range(3), DIFFICULTIES)
            if ymax:
                ax.set_ylim(0, ymax)
            if i == 0:
                ax.set_title(family.capitalize(), fontweight="bold")
            if j == 0:
                ax.set_ylabel(ylabel)
    handles, names = axes[1][0].get_legend_handles_labels()
    fig.legend(handles, names, loc="outside lower center", ncols=min(len(names), 3), frameon=False,
               fontsize="small")
    fig.suptitle(f"Decentralized reference behavior across workload families\n{instances}; 95 % intervals over "
                 "instances (published rows: over training seeds)", fontsize="medium")
    fig.savefig(path, format=fmt or path.suffix.lstrip(".").lower())
    plt.close(fig)
    return path
