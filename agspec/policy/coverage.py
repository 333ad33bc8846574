"""What a summary is over: planned episodes, the ones that count, and the ones that do not (F-POLICY-COVERAGE).

A mean over the ``ok`` episodes of a policy hides every episode that errored or never ran.  Each
summary cell therefore carries its coverage — episodes planned, ``ok`` (n), ``error``, missing —
and a cell is *complete* only when every planned episode is ``ok``.  The planned episodes of a
bundle are its header's ``planned`` list (F-POLICY-BUNDLE) or, in bundles written before it, every
recorded policy on every recorded instance.  The instance set is described by its split:
"10 of 50 final-test instances", never a bare split name.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Iterable, Mapping, Sequence

from agspec.catalogue import SPLITS

Planned = dict[tuple[str, str], frozenset[int]]  # (policy label, scenario) -> planned suite indices
DESCRIBED_SPLITS = ("final-test", "validation", "catalogue", "geometry-matched")


@dataclass(frozen=True)
class Coverage:
    """Episodes of one policy in one scenario: planned, ok, errored, missing (never run or not recorded)."""

    label: str
    scenario: str
    planned: int
    ok: int
    errors: int
    missing: int

    @property
    def complete(self) -> bool:
        """Every planned episode is ok (a cell with nothing planned leaves nothing out: it shows "—")."""
        return self.ok == self.planned

    def fields(self) -> dict[str, Any]:
        return {"planned": self.planned, "errors": self.errors, "missing": self.missing, "complete": self.complete}

    def problem(self) -> str:
        """One line naming what the summary of this row leaves out."""
        parts = [f"{self.errors} error{'s' if self.errors != 1 else ''}"] if self.errors else []
        if self.missing:
            parts.append(f"{self.missing} missing")
        return (f"{self.label} on {self.scenario}: {self.ok} of {self.planned} planned episodes ok"
                + (f" ({', '.join(parts)})" if parts else ""))


def planned_entries(planned: Planned) -> list[dict[str, Any]]:
    """The bundle's ``planned`` list (schema results, F-POLICY-BUNDLE), in a stable order."""
    return [{"policy": label, "scenario": scenario, "indices": sorted(indices)}
            for (label, scenario), indices in sorted(planned.items())]


def planned_of_bundle(doc: Mapping[str, Any]) -> Planned:
    """The episodes a bundle's campaign planned: its ``planned`` list, else every policy on every instance."""
    if doc.get("planned") is not None:
        return {(p["policy"], p["scenario"]): frozenset(p["indices"]) for p in doc["planned"]}
    labels = [p["label"] for p in doc.get("policies", [])]
    out: dict[tuple[str, str], set[int]] = {}
    for inst in doc.get("instances", []):
        for label in labels:
            out.setdefault((label, inst["scenario"]), set()).add(int(inst["index"]))
    return {key: frozenset(v) for key, v in out.items()}


def merge(*plans: Planned) -> Planned:
    out: dict[tuple[str, str], frozenset[int]] = {}
    for plan in plans:
        for key, indices in plan.items():
            out[key] = out.get(key, frozenset()) | indices
    return out


def planned_from_episodes(episodes: Iterable[Mapping[str, Any]]) -> Planned:
    """Without a plan: every policy is expected on every instance any policy ran in that scenario."""
    eps = [ep for ep in episodes if not ep.get("repeat")]
    by_scenario: dict[str, set[int]] = {}
    for ep in eps:
        by_scenario.setdefault(ep["scenario"], set()).add(int(ep["index"]))
    return {(ep["controller"], ep["scenario"]): frozenset(by_scenario[ep["scenario"]]) for ep in eps}


def coverage(episodes: Iterable[Mapping[str, Any]], planned: Planned, label: str, scenario: str) -> Coverage:
    """F-POLICY-COVERAGE of one (policy, scenario); recorded episodes outside the plan count as planned."""
    status: dict[int, str] = {}
    for ep in episodes:
        if ep["controller"] == label and ep["scenario"] == scenario and not ep.get("repeat"):
            status.setdefault(int(ep["index"]), ep.get("status", "ok"))
    indices = set(planned.get((label, scenario), frozenset())) | set(status)
    ok = sum(1 for k in indices if status.get(k) == "ok")
    errors = sum(1 for k in indices if status.get(k) == "error")
    return Coverage(label, scenario, len(indices), ok, errors, len(indices) - ok - errors)


def incomplete(episodes: Sequence[Mapping[str, Any]], planned: Planned, labels: Iterable[str],
               scenarios: Iterable[str]) -> list[Coverage]:
    """The (policy, scenario) rows whose summaries would leave planned episodes out."""
    scenarios = list(scenarios)
    out = []
    for label in labels:
        for scenario in scenarios:
            cov = coverage(episodes, planned, label, scenario)
            if cov.planned and not cov.complete:
                out.append(cov)
    return out


def final_test_only(planned: Planned) -> bool:
    """Whether every planned instance is a final-test instance: only then do the published rows, final-test
    results, stand beside the table's (F-POLICY-PUBLISHED)."""
    return all(k in SPLITS["final-test"] for indices in planned.values() for k in indices)


def _ranges(indices: Sequence[int]) -> str:
    parts, start = [], None
    for k, x in enumerate(indices):
        if start is None:
            start = x
        if k + 1 == len(indices) or indices[k + 1] != x + 1:
            parts.append(f"{start}" if start == x else f"{start}–{x}")
            start = None
    return ", ".join(parts)


def describe_indices(indices: Iterable[int], split: str | None = None) -> str:
    """The instance set in words: "all 50 final-test instances (1000–1049)", "10 of 50 final-test instances"."""
    idx = sorted(set(int(k) for k in indices))
    if not idx:
        return "no instances"
    names = ([split] if split in SPLITS else []) + [s for s in DESCRIBED_SPLITS if s != split]
    for name in names:
        r = SPLITS[name]
        if all(k in r for k in idx):
            if len(idx) == len(r):
                return f"all {len(r)} {name} instances ({r.start}–{r.stop - 1})"
            return f"{len(idx)} of {len(r)} {name} instances ({_ranges(idx)})"
    return f"{len(idx)} instance{'s' if len(idx) != 1 else ''} ({_ranges(idx)})"


def describe_sets(planned: Planned, scenarios: Sequence[str], split: str | None = None) -> str:
    """The instance set of a table: one description when every scenario shares it, else one per scenario."""
    per = {s: sorted(set().union(*[v for (_, sc), v in planned.items() if sc == s] or [set()])) for s in scenarios}
    distinct = {tuple(v) for v in per.values()}
    if len(distinct) == 1:
        return describe_indices(next(iter(distinct)), split)
    return "; ".join(f"{s}: {describe_indices(v, split)}" for s, v in per.items())


__all__ = ["Coverage", "Planned", "coverage", "describe_indices", "describe_sets", "final_test_only", "incomplete",
           "merge",
           "planned_entries", "planned_from_episodes", "planned_of_bundle"]
