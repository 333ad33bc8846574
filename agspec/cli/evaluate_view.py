"""`agspec evaluate` campaigns: plan (options checked), run through the one episode map, render.

Options are checked before anything runs (F-POLICY-INDICES): unknown metrics and controllers are
click choices; index lists are parsed with a bound and must lie inside the split.  Episodes already
in ``--from`` bundles are reused, the rest run through :func:`agspec.evaluate.map_episodes`; each
record reaches the ``--out`` bundle when its episode ends (F-POLICY-BUNDLE).
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence

from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn
from rich.table import Table
from rich.text import Text

from agspec.campaign.executor import ExecutorSpec
from agspec.cli.common import EXIT_INVALID, EXIT_USAGE, emit_json, fail, print_table, stderr, stdout
from agspec.controllers import CONTROLLERS

# the mechanism diagnostics the paper reports beside the outcomes (tab:coalcoord-full and siblings)
DIAGNOSTICS = ("throughput", "admissions", "admission_failures", "admission_success", "admission_latency",
               "coalition_success", "blocked_activities", "blocked_ready_rate", "no_progress_ticks", "robot_occupancy")
MAX_INDICES = 10_000


def check_indices(indices: str | None, split: str | None) -> tuple[str | None, list[int]]:
    """F-POLICY-INDICES: the indices of the split, or an explicit list inside it (any split without --split)."""
    from agspec.catalogue import SPLITS, CatalogueError, parse_indices

    if indices is None:
        return split or "final-test", list(SPLITS[split or "final-test"])
    if not indices.strip():
        fail("--indices is empty; give indices such as 1000-1049 or 1000,1003")
    try:
        idx = parse_indices(indices, limit=MAX_INDICES)
    except CatalogueError as exc:
        fail(f"--indices: {exc}")
    names = [split] if split else [s for s in SPLITS if s != "training"]  # RES-POLICY-INDICES-IN-SPLIT
    home = next((s for s in names if all(k in SPLITS[s] for k in idx)), None)
    if home is None:
        outside = next((k for k in idx if not any(k in SPLITS[s] for s in names)), None)
        ranges = ", ".join(f"{s} {SPLITS[s].start}-{SPLITS[s].stop - 1}" for s in names)
        fail(f"--indices: index {outside} is outside the split{'s' if len(names) > 1 else ''} ({ranges})"
             if outside is not None else f"--indices: {indices} mixes splits ({ranges})")
    return home, idx


def where(ep: dict[str, Any]) -> str:
    err = ep["error"]
    parts = [f"{ep['scenario']} #{ep['index']}"]
    if err.get("tick") is not None:
        parts.append(f"tick {err['tick']}")
    if err.get("agent"):
        parts.append(f"agent {err['agent']}")
    return ", ".join(parts)


def nondeterminism(episodes: Iterable[dict[str, Any]]) -> list[dict[str, Any]]:
    """F-POLICY-DETERMINISM: an episode run twice with different actions or metrics."""
    first: dict[tuple[str, str, int], dict[str, Any]] = {}
    repeats = []
    for ep in episodes:
        key = (ep["controller"], ep["scenario"], ep["index"])
        (repeats.append(ep) if ep.get("repeat") else first.setdefault(key, ep))
    out = []
    for ep in repeats:
        base = first.get((ep["controller"], ep["scenario"], ep["index"]))
        if base is None or base["status"] != "ok" or ep["status"] != "ok":
            continue
        if base["actions_sha256"] != ep["actions_sha256"] or base["metrics"] != ep["metrics"]:
            what = "actions" if base["actions_sha256"] != ep["actions_sha256"] else "metrics"
            out.append({"controller": ep["controller"], "scenario": ep["scenario"], "index": ep["index"],
                        "message": f"the same episode run twice gave different {what} (nondeterministic policy)"})
    return out


def refuse_incomplete(problems: Sequence[Any], allow: bool, what: str) -> None:
    """F-POLICY-COVERAGE, RES-INCOMPLETE-REFUSED: name every incomplete row; without ``allow`` refuse to
    render (exit 1)."""
    if not problems:
        return
    stderr.print(Text.assemble(("incomplete", "bold red"),
                               f": {len(problems)} row(s) of the {what} have fewer ok episodes than planned:"))
    for p in problems:
        stderr.print(Text("  " + p.problem()))
    if not allow:
        fail(f"the {what} is not rendered: a mean over the ok episodes would hide the others; re-run the missing "
             "episodes (agspec evaluate --from BUNDLE --policy ...), or give --allow-incomplete to render them "
             "marked ‡ with their n of N", EXIT_INVALID)


class Campaign:
    """What one `agspec evaluate` invocation runs and shows."""

    def __init__(self, specs: list, scenarios: list[str], split: str | None, indices: list[int],
                 reused: dict[str, Any] | None, strict: bool, timeout: float, repeats: int,
                 load_timeout: float | None = None):
        self.specs, self.scenarios, self.split, self.indices = specs, scenarios, split, indices
        self.reused, self.strict, self.timeout, self.repeats = reused, strict, timeout, repeats
        self.load_timeout = load_timeout
        self.episodes: list[dict[str, Any]] = list(reused["episodes"]) if reused else []
        self.reused_planned = reused["planned"] if reused else {}
        self.findings: list[dict[str, Any]] = list(reused["nondeterminism"]) if reused else []
        self.failed = False

    @property
    def labels(self) -> list[str]:
        seen = [s.label for s in self.specs]
        seen += [ep["controller"] for ep in self.episodes]
        seen += [label for label, _ in self.reused_planned]  # a policy whose every episode is missing
        return list(dict.fromkeys(seen))

    def planned(self):
        """F-POLICY-COVERAGE: the episodes the bundles read planned, and those this invocation plans."""
        from agspec.policy.coverage import merge

        own = {(s.label, name): frozenset(self.indices) for s in self.specs for name in self.scenarios}
        return merge(self.reused_planned, own)

    def identities(self) -> list[dict[str, Any]]:
        """The policies' bundle identities, those run now and those of the bundles read (F-POLICY-BUDGET)."""
        return [s.identity() for s in self.specs] + list((self.reused or {}).get("policies", []))

    @property
    def user_labels(self) -> list[str]:
        return [lab for lab in self.labels if lab not in CONTROLLERS]

    @classmethod
    def plan(cls, *, bundles: Sequence[Path], policies: Sequence[str], names: Sequence[str],
             versions: Sequence[str], controllers: Sequence[str], scenarios: Sequence[str], split: str | None,
             indices: str | None, strict: bool, timeout: float, repeats: int,
             load_timeout: float | None = None) -> "Campaign":
        from agspec.catalogue import OFFICIAL_SCENARIOS
        from agspec.policy.bundle import BundleError, combine, read_bundle
        from agspec.policy.contract import PolicySpecError, parse_policy

        reused = None
        if bundles:
            try:
                reused = combine([(str(p), read_bundle(p)) for p in bundles])
            except BundleError as exc:
                fail(str(exc))
        split, idx = check_indices(indices, split)
        try:
            specs = [parse_policy(p, names[k] if k < len(names) else None,
                                  versions[k] if k < len(versions) else None) for k, p in enumerate(policies)]
        except PolicySpecError as exc:
            fail(str(exc))
        labels = [s.label for s in specs]
        clash = next((lab for lab in labels if labels.count(lab) > 1 or lab in CONTROLLERS), None)
        if clash is not None:
            fail(f"policy label {clash!r} is used twice or names a reference controller; give --name")
        run_refs = controllers or (CONTROLLERS if (policies or not reused) else ())
        specs = [parse_policy(c) for c in run_refs] + specs
        if scenarios:
            chosen = list(scenarios)
        elif reused and not policies and not controllers:
            # the bundles' planned episodes too: a scenario whose every episode is missing is still shown
            chosen = list(dict.fromkeys([ep["scenario"] for ep in reused["episodes"]]
                                        + [s for _, s in reused["planned"]]))
            idx = sorted({ep["index"] for ep in reused["episodes"]}
                         | {k for indices in reused["planned"].values() for k in indices})
        else:
            chosen = list(OFFICIAL_SCENARIOS)
        return cls(specs, chosen, split, idx, reused, strict, timeout, repeats, load_timeout)

    # ------------------------------------------------------------------ running

    def jobs(self) -> tuple[list, list[dict[str, Any]]]:
        """Jobs still to run (episodes in --from bundles are reused) and the instances' identities."""
        from agspec.catalogue import CatalogueError, InvalidDocumentError, load_scenario_bundle
        from agspec.evaluate import Job
        from agspec.ir.fingerprint import fingerprint
        from agspec.ir.instance import make_instance

        have = {(ep["controller"], ep["scenario"], ep["index"], bool(ep.get("repeat"))) for ep in self.episodes}
        todo, instances = [], []
        for name in self.scenarios:
            try:
                sc, recipes, profile = load_scenario_bundle(name)
            except CatalogueError as exc:  # RES-EXIT-CONTENT: a document with errors is invalid input
                fail(str(exc), EXIT_INVALID if isinstance(exc, InvalidDocumentError) else EXIT_USAGE)
            for n, k in enumerate(self.indices):
                inst = make_instance(sc, recipes, profile, index=k)
                instances.append({"scenario": name, "index": k, "id": inst["id"], "fingerprint": fingerprint(inst),
                                  "execution_seed": inst.get("seeds", {}).get("execution")})
                for spec in self.specs:
                    if (spec.label, name, k, False) not in have:
                        todo.append(Job(name, k, spec, inst, self.strict, self.timeout, load_timeout=self.load_timeout))
                    if spec.kind != "controller" and n < self.repeats and (spec.label, name, k, True) not in have:
                        todo.append(Job(name, k, spec, inst, self.strict, self.timeout, repeat=True,
                                        load_timeout=self.load_timeout))
        return todo, instances

    def run(self, executor: ExecutorSpec, out: Path | None, show: bool,
            threads: Mapping[str, Any] | None = None) -> None:
        from agspec.evaluate import map_episodes
        from agspec.policy.bundle import BundleError, BundleWriter, header

        todo, instances = self.jobs() if self.specs else ([], [])
        writer = None
        if out is not None:
            policies = {s.label: s.identity() for s in self.specs}
            for p in (self.reused or {}).get("policies", []):
                policies.setdefault(p["label"], p)
            known = {(i["scenario"], i["index"]): i for i in (self.reused or {}).get("instances", [])}
            known.update({(i["scenario"], i["index"]): i for i in instances})
            head = header(policies.values(), known.values(), split=self.split, workers=executor.jobs or 1,
                          options={"strict": self.strict, "timeout": self.timeout,
                                   "load_timeout": self.load_timeout, "repeat": self.repeats},
                          planned=self.planned(), threads=threads)
            try:
                writer = BundleWriter(out, head)
            except BundleError as exc:
                fail(str(exc))
            for ep in self.episodes:
                writer.add(ep)
        started = time.perf_counter()
        done = False
        try:
            with Progress(TextColumn("[bold]evaluate"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                          TimeRemainingColumn(), console=stderr, disable=not show) as progress:
                task = progress.add_task("episodes", total=len(todo))
                for ep in map_episodes(todo, executor=executor):
                    self.episodes.append(ep)
                    if writer is not None:
                        writer.add(ep)
                    if ep["status"] == "error":
                        err = ep["error"]
                        progress.console.print(f"[bold red]policy error[/] {ep['controller']} ({where(ep)}): "
                                               f"{err['message']} [{err['code']}]", markup=True, highlight=False)
                    progress.advance(task)
            done = True
        finally:
            if writer is not None and not done:
                writer.abandon()
        self.findings += nondeterminism(self.episodes)
        if writer is not None:
            writer.close(wall_time=round(time.perf_counter() - started, 3), nondeterminism=self.findings)
        errors = [ep for ep in self.episodes if ep["status"] == "error"]
        self.failed = bool(errors or self.findings)

    # ------------------------------------------------------------------ output

    def render(self, metrics: Sequence[str], fmt: str, with_published: bool = True,
               allow_incomplete: bool = False) -> bool:
        """Tables (or JSON) of the campaign; refuses incomplete rows without ``allow_incomplete``
        (F-POLICY-COVERAGE).  Returns whether any shown row is incomplete."""
        from agspec.evaluate import summarize
        from agspec.extras import MissingExtra
        from agspec.policy import published
        from agspec.policy.coverage import coverage, describe_sets, final_test_only, incomplete
        from agspec.policy.stats import compare
        from agspec.policy.tables import COMPARISON_HEADER, comparison_cells, fmt_cell, layout, notes, row_n, row_name

        labels = self.labels
        refs = [lab for lab in CONTROLLERS if lab in labels]
        planned = self.planned()
        shown = {(lab, s): v for (lab, s), v in planned.items() if s in self.scenarios}
        instances = describe_sets(shown, self.scenarios, self.split)
        with_published = with_published and final_test_only(shown)  # F-POLICY-PUBLISHED: final-test numbers
        problems = incomplete(self.episodes, planned, labels, self.scenarios)
        if problems and not allow_incomplete:  # refused: the costs and errors go to stderr, stdout stays empty
            self._render_costs(show=fmt != "json", console=stderr)
        refuse_incomplete(problems, allow_incomplete, "evaluation")
        try:
            comparisons = [c for policy in self.user_labels for m in metrics
                           for c in compare(self.episodes, policy, refs, self.scenarios, m)]
        except MissingExtra as exc:
            fail(str(exc))
        if fmt == "json":
            runs = [ep for ep in self.episodes if ep["scenario"] in self.scenarios]
            summary = summarize([r for r in runs if not r.get("repeat")], metrics)
            for entry in summary:
                entry.update(coverage(runs, planned, entry["controller"], entry["scenario"]).fields())
            self._render_costs(show=False)
            emit_json({"runs": runs, "summary": summary, "instances": instances, "complete": not problems,
                       "incomplete": [p.problem() for p in problems],
                       "comparisons": comparisons, "nondeterminism": self.findings,
                       "published": [r for m in metrics for r in published.rows(m)] if with_published else []},
                      "evaluation")
            return bool(problems)
        for metric in metrics:
            rows = layout(self.episodes, labels, self.scenarios, metric, with_published, planned, self.identities())
            table = Table(title=f"{metric}: {instances}")
            table.add_column("Method")
            table.add_column("n", justify="right")
            for name in self.scenarios:
                table.add_column(name, justify="right")
            for row in rows:
                table.add_row(row_name(row), row_n(row), *(fmt_cell(c, metric) for c in row.cells),
                              style="dim" if row.kind == "published" else ("bold" if row.kind == "policy" else None))
            print_table(table)
            for line in notes(rows, instances):
                stdout.print(Text(line))
        for policy in self.user_labels:
            for metric in metrics:
                comps = [c for c in comparisons if c["policy"] == policy and c["metric"] == metric]
                if not comps:
                    continue
                table = Table(title=f"paired comparison: {policy} − reference, {metric} (same instances)")
                for col in COMPARISON_HEADER:
                    table.add_column(col, justify="left" if col in ("scenario", "reference") else "right")
                for c in comps:
                    table.add_row(*comparison_cells(c))
                print_table(table)
        self._render_costs()
        return bool(problems)

    def _render_costs(self, show: bool = True, console: Any = None) -> None:
        if show:
            table = Table(title="episodes: wall time, errors, masked actions run as idle")
            for col in ("policy", "episodes", "s / episode", "errors", "masked actions"):
                table.add_column(col, justify="left" if col == "policy" else "right")
            for label in self.labels:
                eps = [ep for ep in self.episodes if ep["controller"] == label and ep["scenario"] in self.scenarios]
                if not eps:
                    continue
                ok = [ep for ep in eps if ep["status"] == "ok"]
                mean = sum(ep["wall_time"] for ep in eps) / len(eps)
                table.add_row(label, str(len(eps)), f"{mean:.3f}", str(len(eps) - len(ok)),
                              str(sum(ep["illegal_actions"] or 0 for ep in ok)))
            print_table(table, console)
        for ep in self.episodes:
            if ep["status"] == "error":
                stderr.print(f"[bold red]error[/]: policy {ep['controller']} ({where(ep)}): {ep['error']['message']} "
                             f"[{ep['error']['code']}]", markup=True, highlight=False)
        for f in self.findings:
            stderr.print(f"[bold red]nondeterminism[/]: policy {f['controller']} ({f['scenario']} #{f['index']}): "
                         f"{f['message']}", markup=True, highlight=False)
