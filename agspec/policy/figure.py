"""The paper's family figure with the user's policies as more series (F-POLICY-FIGURE).

fig:familyoutcomes: admitted completion (top row) and delivered products (bottom row) for the
Coalition, Concurrency and Flow families, bars grouped by difficulty, 95 % error bars.  Each
series' legend entry states its n (instances, or training seeds for published rows) and marks an
incomplete series (F-POLICY-COVERAGE); the title states the instance set.  A trained policy's series
is named by its method, marked † below the paper's budget, and its budget and evaluation action are
written under the figure (F-POLICY-BUDGET).  Needs matplotlib (extra
``agspec[plot]``); drawn with the non-interactive Agg backend, SVG text kept as text.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping, Sequence

from agspec.extras import pyplot
from agspec.policy.coverage import Planned
from agspec.policy.tables import DIFFICULTIES, INCOMPLETE, Row, layout, row_n, row_name, trained_rows
from agspec.policy.trained import notes as trained_notes

PANEL_FAMILIES = ("coalition", "concurrency", "flow")  # the paper's column order
PANEL_METRICS = (("completion_rate", "Admitted completion", 1.0), ("delivered", "Delivered products / horizon", None))
FORMATS = ("svg", "png", "pdf")


SCENARIOS = tuple(f"{fam}-{d}" for fam in PANEL_FAMILIES for d in DIFFICULTIES)


def series(episodes: Sequence[Mapping[str, Any]], labels: Sequence[str], with_published: bool,
           planned: Planned | None = None, policies: Any = None) -> dict[str, list[Row]]:
    """metric -> rows over the nine official scenarios (family-major, easy -> hard)."""
    return {metric: layout(episodes, labels, SCENARIOS, metric, with_published, planned, policies)
            for metric, _, _ in PANEL_METRICS}


def legend_label(rows: Sequence[Row]) -> str:
    """A series' legend entry: name, n over both panels' cells, and the incomplete mark."""
    first = rows[0]
    cells = tuple(c for r in rows for c in r.cells)
    n = row_n(Row(first.label, first.kind, cells))
    name = row_name(first)  # F-POLICY-BUDGET: a trained series by its method, † below the paper's budget
    if first.kind == "published":
        return f"{name}, n = {n}"
    return f"{name}, n = {n}" + (" incomplete" if INCOMPLETE in n else "")


def key(row: Row) -> tuple[str, str]:
    """A series' identity: a user's policy may be labelled like a published row ("IPPO")."""
    return row.kind, row.label


def draw(episodes: Sequence[Mapping[str, Any]], labels: Sequence[str], path: Path, with_published: bool = True,
         planned: Planned | None = None, instances: str = "final-test instances", policies: Any = None,
         fmt: str | None = None) -> Path:
    """Render the figure to ``path`` (format ``fmt``, else from its suffix: .svg, .png or .pdf)."""
    plt = pyplot()
    data = series(episodes, labels, with_published, planned, policies)
    fig, axes = plt.subplots(2, 3, figsize=(11, 5.6), sharey="row", constrained_layout=True)
    # a series is shown when it has a value or a planned episode in a panel: a row whose every episode
    # failed still appears, in the legend as incomplete (F-POLICY-COVERAGE)
    shown = [r for r in data["delivered"]
             if any(c and (c.get("mean") is not None or c.get("planned"))
                    for m, _, _ in PANEL_METRICS for x in data[m] if key(x) == key(r) for c in x.cells)]
    width = 0.8 / max(len(shown), 1)
    for i, (metric, ylabel, ymax) in enumerate(PANEL_METRICS):
        for j, family in enumerate(PANEL_FAMILIES):
            ax = axes[i][j]
            for k, row in enumerate(r for r in data[metric] if key(r) in {key(s) for s in shown}):
                cells = row.cells[3 * j:3 * j + 3]
                xs = [d + (k - (len(shown) - 1) / 2) * width for d in range(3)]
                means = [c["mean"] if c and c.get("mean") is not None else float("nan") for c in cells]
                errs = [c["half_width"] if c and c.get("half_width") is not None else 0.0 for c in cells]
                name = legend_label([r for m, _, _ in PANEL_METRICS for r in data[m] if key(r) == key(row)])
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
    # F-POLICY-BUDGET: each trained series' budget and evaluation action, at the head of the legend
    footer = trained_notes({label: t for label, t in trained_rows(data["delivered"]).items()
                            if ("policy", label) in {key(r) for r in shown}})
    fig.legend(handles, names, loc="outside lower center", ncols=min(len(names), 3), frameon=False,
               fontsize="small", title="\n".join(footer) or None, title_fontsize="x-small", alignment="left")
    fig.suptitle(f"Decentralized reference behavior across workload families\n{instances}; 95 % intervals over "
                 "instances (published rows: over training seeds)", fontsize="medium")
    fig.savefig(path, format=fmt or path.suffix.lstrip(".").lower())
    plt.close(fig)
    return path
