"""The plumbing and presentation of the conformance commands (kept out of conform_cmds.py).

Building the item list (suite, catalogue episodes, replay), the expected-failures file, the rich
progress bar, the CommonMark-style failure blocks, the summary table, the JSON output, the
coverage table and ``agspec check``'s invariant table.
"""

from __future__ import annotations

import sys
from typing import Any, Mapping, Sequence

from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from agspec.cli.common import EXIT_INVALID, EXIT_OK, EXIT_USAGE, emit_json, fail, stderr, stdout

MAX_SHOWN = 20  # failure blocks printed in table mode


# --------------------------------------------------------------------------- items


def _load_suite(suite_dir: str | None):
    from agspec.conform.cases import SuiteError, load_suite

    try:
        return load_suite(suite_dir)
    except SuiteError as exc:
        for problem in exc.problems[:20]:
            stderr.print(f"{problem}", markup=False)
        fail("the conformance suite cannot be loaded", EXIT_INVALID)  # RES-EXIT-CONTENT: its files are invalid
    except OSError as exc:
        fail(f"the conformance suite cannot be read: {exc}")


def build_items(impl_spec: str | None, replay_path: str | None, no_suite: bool, suite_dir: str | None,
                episodes: int, ticks: int) -> tuple[list, str, set[str], bool]:
    """(items, impl spec, every id that exists, whether the suite was loaded)."""
    from agspec.conform.items import catalogue_episodes, from_case, from_reproducer

    if replay_path:
        from agspec.conform.compare import ReproError, load_reproducer

        try:
            data = load_reproducer(replay_path)
        except ReproError as exc:
            fail(str(exc), exc.exit_code)
        spec = impl_spec or data.get("impl")
        if not spec:
            fail("--replay needs --impl (the reproducer names no implementation)")
        item = from_reproducer(data, replay_path)
        return [item], spec, {item.id}, False
    if not impl_spec:
        fail("missing --impl SPEC (reference, python:pkg.module:factory, or a command line)")
    items = []
    suite_loaded = False
    if not no_suite:
        items += [from_case(c) for c in _load_suite(suite_dir)]
        suite_loaded = True
    items += catalogue_episodes(episodes, ticks)
    return items, impl_spec, {i.id for i in items}, suite_loaded


def load_expect(path: str | None, universe: set[str], suite_loaded: bool):
    if not path:
        return {}, []
    from agspec.catalogue import OFFICIAL_SCENARIOS
    from agspec.conform.expect import ExpectError, load_expectations, stale_entries

    try:
        expectations = load_expectations(path)
    except ExpectError as exc:
        fail(str(exc), exc.exit_code)
    return expectations, stale_entries(expectations, universe, suite_loaded=suite_loaded, scenarios=OFFICIAL_SCENARIOS)


# --------------------------------------------------------------------------- running


def execute(items: Sequence[Any], impl_spec: str, *, impl_timeout: float, validate: bool, jobs: int,
            expectations: Mapping[str, Any], stale: Sequence[str], max_fail: int | None, report_path: str | None,
            repro_dir: str | None, tolerance: float | None, options_record: Mapping[str, Any], fmt: str):
    from agspec.conform.impl import ImplSpecError, make_impl
    from agspec.conform.lockstep import Options
    from agspec.conform.runner import run

    try:
        impl = make_impl(impl_spec, timeout=impl_timeout, validate=validate)
    except ImplSpecError as exc:
        fail(str(exc))
    if report_path:
        try:
            open(report_path, "a", encoding="utf-8").close()
        except OSError as exc:
            fail(f"cannot write the report {report_path}: {exc.strerror or exc}")
    opts = Options(tolerance=tolerance, repro_dir=repro_dir, impl_spec=impl_spec)
    show = fmt == "table" and sys.stderr.isatty()
    with Progress(TextColumn("[bold]conform"), BarColumn(), MofNCompleteColumn(), TextColumn("{task.description}"),
                  TimeElapsedColumn(), console=stderr, disable=not show, transient=True) as progress:
        task = progress.add_task("", total=len(items))

        def on_result(result, outcome):
            progress.update(task, advance=1, description=f"{result.item.id} {outcome}")

        try:
            return run(items, impl_spec, timeout=impl_timeout, validate=validate, jobs=jobs, opts=opts,
                       expectations=expectations, stale=stale, max_fail=max_fail, report_path=report_path,
                       options_record=options_record, impl=impl if jobs <= 1 else None, on_result=on_result)
        finally:
            impl.close()  # also on Ctrl-C: never leave a simulator process behind


# --------------------------------------------------------------------------- output

_STYLE = {"pass": "green", "fail": "bold red", "error": "bold magenta", "skip": "yellow", "xfail": "cyan",
          "xpass": "bold red"}


def print_summary(summary, impl_spec: str) -> None:
    failing = [(r, o) for r, o in summary.results if o in ("fail", "error", "xpass")]
    for result, outcome in failing[:MAX_SHOWN]:
        label = outcome.upper()
        stdout.print(f"[{_STYLE[outcome]}]{label}[/] ", end="")
        if outcome == "xpass":
            stdout.print(f"{result.item.id} {result.item.title}: listed as an expected failure but passed; "
                         "remove it from the expected-failures file", markup=False)
        else:
            stdout.print(result.rendered or f"{result.item.id} {result.item.title}: {result.message}", markup=False)
        stdout.print()
    if len(failing) > MAX_SHOWN:
        stdout.print(f"… {len(failing) - MAX_SHOWN} more failures (see --report)")
    for ident in summary.stale:
        stdout.print(f"[bold red]STALE[/] {ident}: the expected-failures file lists an id that names no case or episode")
    table = Table(title=f"agspec conform · {impl_spec}")
    table.add_column("Outcome")
    table.add_column("Count", justify="right")
    table.add_column("First", overflow="fold")
    for outcome in ("pass", "fail", "error", "skip", "xfail", "xpass"):
        first = next((r for r, o in summary.results if o == outcome), None)
        where = ""
        if first is not None and outcome in ("fail", "error", "xfail"):
            f = first.failure or {}
            where = f"{first.item.id} " + (f.get("path") or f.get("code") or ",".join(f.get("ids") or []) or "")
        table.add_row(f"[{_STYLE[outcome]}]{outcome}[/]", str(summary.counts[outcome]), where)
    if summary.stale:
        table.add_row("[bold red]stale[/]", str(len(summary.stale)), summary.stale[0])
    stdout.print(table)
    stdout.print(f"{len(summary.results)} run ({summary.not_run} not run), {summary.ticks} ticks, "
                 f"{summary.states} states compared, {summary.invariant_checks} invariant checks, "
                 f"{summary.expectations} expectations, {summary.duration_s:.1f} s")
    code = summary.exit_code
    if code == 0:
        stdout.print("[bold green]conformant[/]")
    elif code == 1:
        stdout.print("[bold red]NONCONFORMANT[/]")
    elif summary.vacuous:
        stdout.print("[bold magenta]vacuous run: nothing was compared with the reference[/]")
    else:
        stdout.print("[bold magenta]harness or protocol errors[/] (the implementation could not be judged)")


def json_summary(summary) -> dict[str, Any]:
    return {"header": summary.header,
            "results": list(summary.records),
            "stale": list(summary.stale),
            "footer": summary.footer()}


# --------------------------------------------------------------------------- coverage


def show_coverage(suite_dir: str | None, fmt: str) -> int:
    from agspec.conform.cases import coverage

    cases = _load_suite(suite_dir)
    cov = coverage(cases)
    if fmt == "json":
        emit_json(cov)
    else:
        from agspec.spec_index import spec_titles

        titles = spec_titles()
        table = Table(title=f"Coverage of the conformance suite ({len(cases)} cases)")
        table.add_column("ID")
        table.add_column("Title")
        table.add_column("Cases", justify="right")
        for group in ("rules", "invariants"):
            for ident, ids in cov[group].items():
                n = len(ids)
                table.add_row(ident, titles.get(ident, ""), str(n) if n else "[bold red]0[/]")
        stdout.print(table)
        if cov["uncovered"]:
            stdout.print(f"[bold red]uncovered[/]: {', '.join(cov['uncovered'])}")
        else:
            stdout.print("[green]every rule and invariant is covered[/]")
    return EXIT_INVALID if cov["uncovered"] else EXIT_OK


# --------------------------------------------------------------------------- agspec check


def check_trace_command(path: str, fmt: str) -> int:
    from agspec.conform.invariants import INVARIANT_IDS, check_trace
    from agspec.trace.read import read_trace

    records, diags = read_trace(path)
    if any(d.code in ("AG001", "AG002") and d.line is None for d in diags):
        for d in diags:
            stderr.print(d.render(), markup=False)
        return EXIT_USAGE
    fatal = [d for d in diags if not d.code.startswith("AG6")]  # unreadable records: invariants cannot run
    if fatal:
        if fmt == "json":
            emit_json({"file": path, "ok": False, "diagnostics": [_d(d) for d in diags]})
        else:
            for d in fatal[:30]:
                stderr.print(d.render(), markup=False)
            stderr.print(f"{path}: the trace is malformed; the invariants were not evaluated "
                         "(see `agspec trace validate`)")
        return EXIT_INVALID
    report = check_trace(records)
    if fmt == "json":
        emit_json({
            "file": path, "ok": report.ok, "ticks": report.ticks, "agents": report.agents, "states": report.states,
            "checks": report.checks, "records": report.records, "skipped": report.skipped,
            "total_checks": report.total_checks,
            "violations": [{"invariant": v.invariant, "tick": v.tick, "entity": v.entity, "message": v.message}
                           for v in report.violations],
            "diagnostics": [_d(d) for d in diags],
        })
        return EXIT_OK if report.ok else EXIT_INVALID
    table = Table(title=f"{path}: {report.ticks} ticks, {report.agents} agents, {report.states} states, "
                        f"{report.total_checks} checks evaluated")
    table.add_column("Invariant")
    table.add_column("Records", justify="right")
    table.add_column("Checks evaluated", justify="right")
    table.add_column("Violations", justify="right")
    table.add_column("Note")
    for inv in INVARIANT_IDS:
        n = len(report.by_invariant(inv))
        table.add_row(inv, str(report.records.get(inv, 0)), str(report.checks.get(inv, 0)),
                      f"[bold red]{n}[/]" if n else "0", report.skipped.get(inv, ""))
    for guard in sorted({v.invariant for v in report.violations if not v.invariant.startswith("INV-")}):
        table.add_row(f"[bold red]{guard}[/]", "", "", str(len(report.by_invariant(guard))), "vacuity guard")
    stdout.print(table)
    for v in report.violations[:30]:
        stdout.print(f"  [bold red]{v.invariant}[/] ", end="")
        stdout.print(str(v)[len(v.invariant) + 1:], markup=False)
    if len(report.violations) > 30:
        stdout.print(f"  … {len(report.violations) - 30} more violations")
    stdout.print("[green]all invariants hold[/]" if report.ok else f"[bold red]{len(report.violations)} violation(s)[/]")
    return EXIT_OK if report.ok else EXIT_INVALID


def _d(d) -> dict[str, Any]:
    return {"code": d.code, "message": d.message, "line": d.line, "pointer": d.pointer}
