"""Training curves from run directories, as the paper draws them (spec/16-training.md, T-RECORD).

fig:traincurves and its siblings: milestone return, admissions and delivered per environment step,
the median and inter-quartile range over seeds, one colour per method; fig:trainopt: policy entropy
and critic explained variance for IPPO and MAPPO.  Admissions are left out for the Flow family, as
in the paper (its recipes are unary); the empty panel says so.  The curves are the training episodes
— sampled actions on the run's training realizations — which the figure states in its title and
axes, beside the masked-argmax validation points (T-VALIDATION, markers), so that neither is read
as the final-test evaluation.  Every method's legend entry is marked † when a run is below the paper's
training budget and the budgets are written under the figure (F-POLICY-BUDGET).  Needs matplotlib
(extra ``agspec[plot]``); no torch.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence

import numpy as np

from agspec.checkpoint.rundir import RECORD, RunDirError, read_summary
from agspec.extras import pyplot
from agspec.policy import trained
from agspec.train.record import read_record

# the paper's colours (AGQMIX, AGIPPO, AGMAPPO) and names
COLOURS = {"qmix": "#F9DEAC", "ippo": "#F99B1C", "mappo": "#7A5100"}
NAMES = {"ippo": "IPPO", "mappo": "MAPPO", "qmix": "QMIX"}
PANELS = (("milestone_return", "Milestone return"), ("admissions", "Admissions"), ("delivered", "Delivered"),
          ("entropy", "Policy entropy"), ("explained_variance", "Critic explained variance"))
EPISODE_PANELS = ("milestone_return", "admissions", "delivered")  # means over the training episodes of a row
# what the curves' numbers are (T-RECORD): the training episodes, not the evaluation (T-EVAL-ACTION)
SOURCE = ("lines: training episodes, sampled actions (IPPO/MAPPO: masked softmax; QMIX: ε-greedy) on the run's "
          "training realizations (suite indices 0–4 under run seeds), not the final-test evaluation")
VALIDATION = "◆: masked argmax (the evaluation action) on validation instances {indices}"
FLOW_ADMISSIONS = "not drawn for Flow:\nits recipes are unary\n(the paper omits this panel)"


def load_runs(dirs: Iterable[str | Path]) -> list[dict[str, Any]]:
    """(summary, progress rows) of each run directory; RunDirError for one that is not a run."""
    out = []
    for d in dirs:
        summary = read_summary(d)
        try:
            rows = list(read_record(Path(d) / RECORD))
        except Exception as exc:  # InputError from the bounded reader, OSError
            raise RunDirError(f"{d}: cannot read its training record: {exc}") from None
        out.append({"summary": summary, "rows": [r for r in rows if r.get("kind") == "progress"],
                    "validation": [r for r in rows if r.get("kind") == "validation" and r.get("action") == "greedy"],
                    "budget": summary.get("budget") or next((r.get("budget") for r in rows if r.get("kind") == "header"),
                                                            None),
                    "dir": str(d)})
    return out


def budget_note(algorithm: str, scenario: str, members: Sequence[Mapping[str, Any]]) -> str:
    """F-POLICY-BUDGET: a method's runs on a scenario against the paper's training budget."""
    budgets = [int(m["budget"]) for m in members if m.get("budget") is not None]
    name = method_name(algorithm, members)
    if not budgets:
        return f"{name} on {scenario} (n={len(members)}) — training budget not recorded"
    text = trained.budget(budgets[0]) if len(set(budgets)) == 1 else \
        f"{trained.steps_range(budgets)} training steps (the paper's: {trained.paper_steps():,})"
    return f"{name} on {scenario} (n={len(members)}) — {text}"


def method_name(algorithm: str, members: Sequence[Mapping[str, Any]]) -> str:
    """The method's name, marked † when one of its runs is below the paper's budget (F-POLICY-BUDGET)."""
    low = any(m.get("budget") is not None and int(m["budget"]) < trained.paper_steps() for m in members)
    return NAMES[algorithm] + (trained.MARK if low else "")


def validation_points(runs: Sequence[Mapping[str, Any]]) -> tuple[np.ndarray, np.ndarray, list[int]]:
    """(steps, median over runs of the greedy validation's mean delivered, indices) (T-VALIDATION)."""
    by_step: dict[int, list[float]] = {}
    indices: set[int] = set()
    for run in runs:
        for row in run.get("validation", ()):
            if row.get("delivered_mean") is not None:
                by_step.setdefault(int(row["steps"]), []).append(float(row["delivered_mean"]))
                indices.update(int(k) for k in row.get("indices", ()))
    steps = sorted(by_step)
    return np.array(steps, dtype=float), np.array([np.median(by_step[s]) for s in steps]), sorted(indices)


def band(runs: Sequence[Mapping[str, Any]], key: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(steps, median, 25th, 75th percentile) of ``key`` over the runs, at every step some run recorded it."""
    by_step: dict[int, list[float]] = {}
    for run in runs:
        for row in run["rows"]:
            value = row.get(key)
            if value is not None and math.isfinite(float(value)):
                by_step.setdefault(int(row["steps"]), []).append(float(value))
    steps = np.array(sorted(by_step), dtype=float)
    if not len(steps):
        return steps, steps, steps, steps
    vals = [np.array(by_step[int(s)]) for s in steps]
    return (steps, np.array([np.median(v) for v in vals]), np.array([np.percentile(v, 25) for v in vals]),
            np.array([np.percentile(v, 75) for v in vals]))


def draw(runs: Sequence[Mapping[str, Any]], path: Path, fmt: str | None = None) -> Path:
    """One row of panels per scenario; one line (median) and band (IQR) per method; the greedy validation
    as markers on the delivered panel; the budgets under the figure (F-POLICY-BUDGET)."""
    plt = pyplot()
    groups: dict[tuple[str, str], list[Mapping[str, Any]]] = {}
    for run in runs:
        s = run["summary"]
        groups.setdefault((s["scenario"], s["algorithm"]), []).append(run)
    scenarios = list(dict.fromkeys(s for s, _a in groups))
    has_ppo = any(a != "qmix" for _s, a in groups)
    panels = [p for p in PANELS if has_ppo or p[0] not in ("entropy", "explained_variance")]
    fig, axes = plt.subplots(len(scenarios), len(panels), figsize=(3.1 * len(panels), 2.5 * len(scenarios)),
                             squeeze=False, constrained_layout=True)
    shown_indices: set[int] = set()
    for i, scenario in enumerate(scenarios):
        for j, (key, title) in enumerate(panels):
            ax = axes[i][j]
            ax.set_title(f"{scenario}: {title}", fontsize=8)
            if key == "admissions" and scenario.startswith("flow"):
                ax.set_xticks([])
                ax.set_yticks([])
                ax.text(0.5, 0.5, FLOW_ADMISSIONS, ha="center", va="center", fontsize=7, transform=ax.transAxes)
                continue
            for algorithm in ("qmix", "ippo", "mappo"):
                members = groups.get((scenario, algorithm))
                if not members or (algorithm == "qmix" and key in ("entropy", "explained_variance")):
                    continue
                colour = COLOURS[algorithm]
                name = method_name(algorithm, members)
                x, med, lo, hi = band(members, key)
                if len(x):
                    ax.plot(x, med, color=colour, linewidth=1.2, label=f"{name} (n={len(members)})")
                    ax.fill_between(x, lo, hi, color=colour, alpha=0.3, linewidth=0)
                if key == "delivered":
                    vx, vy, indices = validation_points(members)
                    if len(vx):
                        shown_indices.update(indices)
                        ax.plot(vx, vy, linestyle="none", marker="D", markersize=4, color=colour,
                                markeredgecolor="black", markeredgewidth=0.5,
                                label=f"{name} validation, masked argmax (n={len(members)})")
            ax.tick_params(labelsize=7)
            ax.set_xlabel("environment steps", fontsize=7)
            if key in EPISODE_PANELS:
                ax.set_ylabel("per training episode (sampled)", fontsize=7)
    handles = {}
    for row in axes:
        for ax in row:
            for h, name in zip(*ax.get_legend_handles_labels()):
                handles.setdefault(name, h)
    footer = [budget_note(a, s, members) for (s, a), members in groups.items()]  # F-POLICY-BUDGET
    if any(trained.MARK in line for line in footer):
        footer.append(trained.mark_note())
    fig.legend(list(handles.values()), list(handles), loc="outside lower center", ncols=max(1, min(len(handles), 3)),
               frameon=False, fontsize=8, title="\n".join(footer), title_fontsize=7, alignment="left")
    title = [f"Training curves: median and inter-quartile range over seeds; {SOURCE}"]
    if shown_indices:
        title.append(VALIDATION.format(indices=_indices(sorted(shown_indices))))
    fig.suptitle("\n".join(title), fontsize=8)
    fig.savefig(path, format=fmt or path.suffix.lstrip(".").lower())
    plt.close(fig)
    return path


def _indices(indices: Sequence[int]) -> str:
    """200–204 for a run of consecutive indices, else the list."""
    if indices == list(range(indices[0], indices[-1] + 1)) and len(indices) > 1:
        return f"{indices[0]}–{indices[-1]}"
    return ", ".join(map(str, indices))
