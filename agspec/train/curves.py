"""Training curves from run directories, as the paper draws them (spec/16-training.md, T-RECORD).

fig:traincurves and its siblings: milestone return, admissions and delivered per environment step,
the median and inter-quartile range over seeds, one colour per method; fig:trainopt: policy entropy
and critic explained variance for IPPO and MAPPO.  Admissions are left out for the Flow family, as
in the paper (its recipes are unary).  Needs matplotlib (extra ``agspec[plot]``); no torch.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence

import numpy as np

from agspec.policy.figure import _pyplot
from agspec.train.record import read_record
from agspec.train.rundir import RECORD, RunDirError, read_summary

# the paper's colours (AGQMIX, AGIPPO, AGMAPPO) and names
COLOURS = {"qmix": "#F9DEAC", "ippo": "#F99B1C", "mappo": "#7A5100"}
NAMES = {"ippo": "IPPO", "mappo": "MAPPO", "qmix": "QMIX"}
PANELS = (("milestone_return", "Milestone return"), ("admissions", "Admissions"), ("delivered", "Delivered"),
          ("entropy", "Policy entropy"), ("explained_variance", "Critic explained variance"))


def load_runs(dirs: Iterable[str | Path]) -> list[dict[str, Any]]:
    """(summary, progress rows) of each run directory; RunDirError for one that is not a run."""
    out = []
    for d in dirs:
        summary = read_summary(d)
        try:
            rows = [r for r in read_record(Path(d) / RECORD) if r.get("kind") == "progress"]
        except Exception as exc:  # InputError from the bounded reader, OSError
            raise RunDirError(f"{d}: cannot read its training record: {exc}") from None
        out.append({"summary": summary, "rows": rows, "dir": str(d)})
    return out


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
    """One row of panels per scenario; one line (median) and band (IQR) per method."""
    plt = _pyplot()
    groups: dict[tuple[str, str], list[Mapping[str, Any]]] = {}
    for run in runs:
        s = run["summary"]
        groups.setdefault((s["scenario"], s["algorithm"]), []).append(run)
    scenarios = list(dict.fromkeys(s for s, _a in groups))
    has_ppo = any(a != "qmix" for _s, a in groups)
    panels = [p for p in PANELS if has_ppo or p[0] not in ("entropy", "explained_variance")]
    fig, axes = plt.subplots(len(scenarios), len(panels), figsize=(3.1 * len(panels), 2.5 * len(scenarios)),
                             squeeze=False, constrained_layout=True)
    for i, scenario in enumerate(scenarios):
        for j, (key, title) in enumerate(panels):
            ax = axes[i][j]
            if key == "admissions" and scenario.startswith("flow"):
                ax.set_axis_off()  # the paper omits admissions for the unary Flow recipes
                continue
            for algorithm in ("qmix", "ippo", "mappo"):
                members = groups.get((scenario, algorithm))
                if not members or (algorithm == "qmix" and key in ("entropy", "explained_variance")):
                    continue
                x, med, lo, hi = band(members, key)
                if not len(x):
                    continue
                colour = COLOURS[algorithm]
                ax.plot(x, med, color=colour, linewidth=1.2, label=f"{NAMES[algorithm]} (n={len(members)})")
                ax.fill_between(x, lo, hi, color=colour, alpha=0.3, linewidth=0)
            ax.set_title(f"{scenario}: {title}", fontsize=8)
            ax.tick_params(labelsize=7)
            ax.set_xlabel("environment steps", fontsize=7)
    handles = {}
    for row in axes:
        for ax in row:
            for h, name in zip(*ax.get_legend_handles_labels()):
                handles.setdefault(name, h)
    if handles:
        fig.legend(list(handles.values()), list(handles), loc="outside lower center", ncols=min(len(handles), 3),
                   frameon=False, fontsize=8)
    fig.suptitle("Training curves: median and inter-quartile range over seeds", fontsize=9)
    fig.savefig(path, format=fmt or path.suffix.lstrip(".").lower())
    plt.close(fig)
    return path
