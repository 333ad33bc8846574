"""The plumbing and presentation of the conformance commands (kept out of conform_cmds.py).

Building the item list (suite, catalogue episodes, replay), the expected-failures file, the rich
progress bar, the CommonMark-style failure blocks, the summary table, the JSON output, the
coverage table and ``agspec check``'s invariant table.
"""

from __future__ import annotations

import gc
import hashlib
import re
import shlex
import sys
import time
from pathlib import Path
from typing import Any, Mapping, Sequence

from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from agspec.campaign.executor import ExecutorError, ExecutorSpec
from agspec.cli.common import EXIT_INVALID, EXIT_OK, EXIT_USAGE, emit_json, fail, stderr, stdout
from agspec.conform.coverage.values import EVENT_RULES
from agspec.conform.run_item import LEVEL_PARTS
from agspec.conform.runner import EXIT_NONDETERMINISTIC, level_name

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
                episodes: int, ticks: int | None) -> tuple[list, str, set[str], bool]:
    """(items, impl spec, every id that exists, whether the suite was loaded)."""
    from agspec.conform.items import catalogue_episodes, default_run, from_reproducer

    if replay_path:
        from agspec.conform.repro import ReproError, load_reproducer

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
    items = catalogue_episodes(episodes, ticks) if no_suite else default_run(_load_suite(suite_dir), episodes, ticks)
    return items, impl_spec, {i.id for i in items}, not no_suite


def load_expect(path: str | None, universe: set[str], suite_loaded: bool):
    if not path:
        return {}, []
    from agspec.conform.expect import ExpectError, load_expectations, stale_entries
    from agspec.conform.items import EPISODE_SCENARIOS

    try:
        expectations = load_expectations(path)
    except ExpectError as exc:
        fail(str(exc), exc.exit_code)
    return expectations, stale_entries(expectations, universe, suite_loaded=suite_loaded, scenarios=EPISODE_SCENARIOS)


# --------------------------------------------------------------------------- running


def impl_slug(impl_spec: str) -> str:
    """The directory of one implementation's reproducers under --repro-dir (F-REPRO): its command, path
    words cut to their last part, as a readable slug, plus 8 hex digits of SHA-256 of the whole command,
    so two simulators never share (and overwrite) reproducers."""
    try:
        words = shlex.split(impl_spec)
    except ValueError:
        words = impl_spec.split()
    text = "-".join(w.rstrip("/").rsplit("/", 1)[-1] for w in words)
    slug = re.sub(r"[^A-Za-z0-9_.]+", "-", text).strip("-.")[:48].rstrip("-.") or "impl"
    return f"{slug}-{hashlib.sha256(impl_spec.encode('utf-8')).hexdigest()[:8]}"


def repro_dir_of(repro_dir: str | None, impl_spec: str) -> str | None:
    """Where this run saves reproducers: ``{--repro-dir}/{impl_slug}`` (F-REPRO)."""
    return str(Path(repro_dir) / impl_slug(impl_spec)) if repro_dir else None


def execute(items: Sequence[Any], impl_spec: str, *, impl_timeout: float, validate: bool, campaign: ExecutorSpec,
            expectations: Mapping[str, Any], stale: Sequence[str], max_fail: int | None, report_path: str | None,
            repro_dir: str | None, tolerance: float | None, options_record: Mapping[str, Any], fmt: str,
            require: Sequence[str] = (), golden_dir: str | None = None):
    from agspec.conform.impl import ImplSpecError, make_impl
    from agspec.conform.run_item import Options
    from agspec.conform.runner import run
    from agspec.transport.teardown import exit_on_signals

    try:
        impl = make_impl(impl_spec, timeout=impl_timeout, validate=validate)
    except ImplSpecError as exc:
        fail(str(exc))
    opts = Options(tolerance=tolerance, repro_dir=repro_dir, impl_spec=impl_spec, golden_dir=golden_dir)
    show = fmt == "table" and sys.stderr.isatty()
    with Progress(TextColumn("[bold]conform"), BarColumn(), MofNCompleteColumn(), TextColumn("{task.description}"),
                  TimeElapsedColumn(), console=stderr, disable=not show, transient=True) as progress:
        task = progress.add_task("", total=len(items))

        def on_result(result, outcome):
            progress.update(task, advance=1, description=f"{result.item.name} {outcome}")
            reproducer = (result.failure or {}).get("reproducer")
            # F-REPRO: every file written is announced (with --format json: in the footer's `reproducers`)
            if reproducer and result.item.kind != "replay" and fmt != "json":
                stderr.print(f"reproducer written: {reproducer}", markup=False)

        # What exists now (modules, schemas, the catalogue, the items and their instances) lives until the
        # command ends; every reply of every item is a few thousand short-lived containers, and the
        # collections they trigger would otherwise walk all of it again (about a tenth of a warm
        # F-GOLDEN run).  Frozen objects are only left out of collections; nothing is checked less.
        gc.freeze()
        # SIGTERM / SIGHUP / Ctrl-C / an exception: the finally blocks close every simulator (F-PROTOCOL-TEARDOWN)
        with exit_on_signals():
            try:
                inline = campaign.kind == "local" and (campaign.jobs or 1) <= 1
                return run(items, impl_spec, timeout=impl_timeout, validate=validate, opts=opts, executor=campaign,
                           expectations=expectations, stale=stale, max_fail=max_fail, report_path=report_path,
                           options_record=options_record, impl=impl if inline else None, on_result=on_result,
                           require=require)
            except ExecutorError as exc:
                fail(str(exc))
            finally:
                impl.close()  # also on Ctrl-C: never leave a simulator process behind


# --------------------------------------------------------------------------- output

_STYLE = {"pass": "green", "fail": "bold red", "error": "bold magenta", "skip": "yellow", "xfail": "cyan",
          "xpass": "bold red"}


def print_summary(summary, impl_spec: str, golden_dir: str | None = None) -> None:
    failing = [(r, o) for r, o in summary.results if o in ("fail", "error", "xpass")]
    for result, outcome in failing[:MAX_SHOWN]:
        label = outcome.upper()
        stdout.print(f"[{_STYLE[outcome]}]{label}[/] ", end="")
        if outcome == "xpass":
            stdout.print(f"{result.item.heading}: listed as an expected failure but passed; "
                         "remove it from the expected-failures file", markup=False)
        else:
            stdout.print(result.rendered or f"{result.item.heading}: {result.message}", markup=False)
        stdout.print()
    if len(failing) > MAX_SHOWN:
        stdout.print(f"… {len(failing) - MAX_SHOWN} more failures (see the -o report)")
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
            where = f"{first.item.name} " + (f.get("path") or f.get("code") or ",".join(f.get("ids") or []) or "")
        table.add_row(f"[{_STYLE[outcome]}]{outcome}[/]", str(summary.counts[outcome]), where)
    if summary.stale:
        table.add_row("[bold red]stale[/]", str(len(summary.stale)), summary.stale[0])
    stdout.print(table)
    c = summary.compared
    stdout.print(f"{len(summary.results)} run ({summary.not_run} not run), {summary.ticks} ticks; compared: "
                 f"{c['events']} events, {c['state']} states, {c['observations']} observations, {c['masks']} masks; "
                 f"{summary.invariant_checks} invariant checks, {summary.expectations} expectations, "
                 f"{summary.duration_s:.1f} s")
    a = summary.assertions
    if a["checked"] or a["skipped"]:
        stdout.print(f"suite assertions: {a['checked']} checked, {a['skipped']} skipped"
                     + (" (they read parts the implementation does not declare: "
                        + ", ".join(f"{p} {n}" for p, n in a["skipped_by_part"].items()) + ")" if a["skipped"] else ""),
                     markup=False)
    for ident, ids in summary.known_divergences.items():
        stdout.print(f"[cyan]known divergence[/] {ident} (spec/10-divergences.md): {', '.join(ids)}")
    if summary.golden:
        stdout.print(f"{summary.golden} of {len(summary.results)} items matched golden reference traces reply by "
                     "reply (F-GOLDEN)")
    stdout.print(golden_line(golden_dir), markup=False)
    for reason, n in summary.skips.items():
        stdout.print(f"[yellow]skipped[/] {n}: {reason}")
    for path in summary.reproducers:
        stdout.print(f"reproducer: {path}", markup=False)
    if summary.reproducers:  # F-REPRO: one directory per implementation
        stdout.print(f"reproducers of this implementation are in {Path(summary.reproducers[0]).parent}/ "
                     "(--repro-dir DIR or $AGSPEC_REPRO_DIR moves them)", markup=False)
    if summary.horizon:  # F-CONFORM: how much of each scenario's horizon the catalogue episodes checked
        stdout.print("horizon checked: " + ", ".join(f"{name} {row['ticks']}/{row['horizon']}"
                                                     for name, row in summary.horizon.items()), markup=False)
    witnessed = sorted({r for rules in EVENT_RULES.values() for r in rules})
    missing = [r for r in witnessed if r not in summary.rules_exercised]
    stdout.print(f"rules exercised: {len(summary.rules_exercised)} of {len(witnessed)} the events witness"
                 + (f" (never: {', '.join(missing)})" if missing else ""), markup=False)
    stdout.print(f"level proven: [bold]{level_name(summary.level)}[/]"
                 + (f" (not proven: {', '.join(p for p in LEVEL_PARTS if p not in summary.level)})"
                    if summary.level != LEVEL_PARTS else ""))
    code = summary.exit_code
    if summary.nondeterministic is not None:
        nd = summary.nondeterministic
        stdout.print(f"{nd['id']}: failed {nd['first']['message']!r}, but {len(nd['replays'])} replay(s) of its "
                     f"reproducer in a fresh process reproduced it {nd['reproduced']} time(s): " + "; ".join(
                         f"{r['outcome']} {r['message'] or ''}".strip() for r in nd["replays"]), markup=False)
    if summary.history_dependent is not None:
        hd = summary.history_dependent
        stdout.print(f"history-dependent: {hd['message']} (F-CONFORM-HISTORY)", markup=False)
        if hd.get("reproducer"):
            stdout.print(f"reproducer with that history: {hd['reproducer']}", markup=False)
    style = {0: "bold green", 1: "bold red", EXIT_NONDETERMINISTIC: "bold red"}.get(code, "bold magenta")
    head, sep, rest = summary.verdict.partition(":")
    verdict = (head.upper() + sep + rest) if code in (1, EXIT_NONDETERMINISTIC) else summary.verdict
    stdout.print(f"[{style}]{verdict}[/]" + (" (the implementation could not be judged)"
                                             if code == 3 and not summary.vacuous else ""))


def golden_line(golden_dir: str | None) -> str:
    """Where the golden traces are kept and how to move or clear them (F-GOLDEN)."""
    if not golden_dir:
        return "golden cache: off (every item ran live; without --golden-cache off they are kept in ~/.cache/agspec/golden)"
    return (f"golden cache: {golden_dir} (move it: --golden-cache DIR or $AGSPEC_GOLDEN_CACHE; clear it: delete the "
            "directory; --golden-cache off runs every item live)")


def json_summary(summary, golden_dir: str | None = None) -> dict[str, Any]:
    """F-REPORT in one object; the level, skips, reproducers and verdict are in the footer; the golden
    cache's directory (null: off, F-GOLDEN)."""
    return {"header": summary.header,
            "results": list(summary.records),
            "stale": list(summary.stale),
            "footer": summary.footer(),
            "golden_cache": golden_dir}


# --------------------------------------------------------------------------- coverage


def show_coverage(suite_dir: str | None, fmt: str, episodes: int, ticks: int) -> int:
    from agspec.conform.cases import coverage
    from agspec.conform.coverage.values import value_coverage
    from agspec.conform.coverage.variants import entries, variant_coverage
    from agspec.conform.items import default_run, from_case

    cases = _load_suite(suite_dir)
    cov = coverage(cases)
    with stderr.status("running every case on the reference for value coverage …"):
        values = value_coverage([from_case(c) for c in cases])  # F-CONFORM-COVERAGE
    items = default_run(cases, episodes, ticks)
    with stderr.status(f"running the {len(items)} items of the default run against hard-coded values …"):
        variants = variant_coverage(items)  # F-CONFORM-COVERAGE: the variant space
    cov["values"] = values["values"]
    cov["variants"] = variants["variants"]
    cov["unreachable"] = variants["unreachable"]
    cov["uncovered"] = cov["uncovered"] + values["uncovered"] + variants["uncovered"]
    if fmt == "json":
        emit_json(cov, "coverage")
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
        from agspec.conform.coverage.values import VALUE_CLASSES

        for entry, ids in cov.get("values", {}).items():
            n = len(ids)
            table.add_row(entry, VALUE_CLASSES.get(entry.split(":", 1)[1], "") if entry.startswith("value:") else "",
                          str(n) if n else "[bold red]0[/]")
        stdout.print(table)
        stdout.print(_variant_table(entries(), variants, len(items)))
        for entry, why in variants["unreachable"].items():
            stdout.print(f"not an entry: {entry} — {why}", markup=False)
        if cov["uncovered"]:
            stdout.print(f"[bold red]uncovered[/]: {', '.join(cov['uncovered'])}")
        else:
            stdout.print("[green]every rule, invariant, field, action class, event type, value class and variant "
                         "entry is covered[/]")
    return EXIT_INVALID if cov["uncovered"] else EXIT_OK


def _variant_table(universe, variants: Mapping[str, Any], n_items: int) -> Table:
    """F-CONFORM-COVERAGE: per entry of the variant space, the items that catch a simulator reading the
    official value instead, and the cases whose expectations catch it."""
    table = Table(title=f"Variant space: items of the default run ({n_items}) that fail a simulator reading "
                        "the official value instead")
    for name, justify in (("Entry", "left"), ("Spec", "left"), ("Items", "right"), ("Asserted", "right"),
                          ("First caught by", "left")):
        table.add_column(name, justify=justify, overflow="fold")
    for entry in universe:
        row = variants["variants"][entry.id]
        first = next(iter(row["findings"].items()), None)
        shown = ""
        if first is not None:
            where = first[1]["where"]
            shown = f"{first[0]}" + ("" if where == "witnessed" else f" at tick {first[1]['tick']}: {where}")
        bad = entry.id in variants["uncovered"]
        asserted = "n/a" if entry.kind == "witness" else str(len(row["asserted"]))  # nothing to assert against
        table.add_row(entry.id, entry.spec,
                      f"[bold red]{len(row['items'])}[/]" if bad and not row["items"] else str(len(row["items"])),
                      f"[bold red]{asserted}[/]" if bad and row["items"] else asserted, shown)
    return table


# --------------------------------------------------------------------------- agspec check


def check_trace_command(path: str, fmt: str) -> int:
    from agspec.cli.check_view import timing
    from agspec.invariants import INVARIANT_IDS, check_trace
    from agspec.trace.check import diag_record, paired_records, report_record, trace_diag, verify_whole
    from agspec.trace.read import read_trace

    records, diags = read_trace(path)
    if any(d.code in ("AG001", "AG002") and d.line is None for d in diags):
        for d in diags:
            stderr.print(d.render(), markup=False)
        return EXIT_USAGE
    fatal = [d for d in diags if not d.code.startswith("AG6")]  # unreadable records: invariants cannot run
    if fatal:
        if fmt == "json":
            emit_json({"file": path, "ok": False, "diagnostics": [diag_record(d) for d in diags]}, "check")
        else:
            for d in fatal[:30]:
                stderr.print(d.render(), markup=False)
            stderr.print(f"{path}: the trace is malformed; the invariants were not evaluated "
                         "(see `agspec trace validate`)")
        return EXIT_INVALID
    started = time.perf_counter()
    report = check_trace(records)
    speed = timing(report.ticks, time.perf_counter() - started)
    # F-TRACE-CHECK: the whole trace — record count against the horizon, footer metrics recomputed
    whole = verify_whole(records, path, trace_diag)
    ok = report.ok and not whole and not diags  # F-TRACE-VALIDATE: what `trace validate` reports fails here too
    if fmt == "json":
        emit_json({**report_record(path, report, diags, whole, paired_records(records)), "timing": speed}, "check")
        return EXIT_OK if ok else EXIT_INVALID
    table = Table(title=f"{path}: {report.ticks} ticks, {report.agents} agents, {report.states} states, "
                        f"{report.total_checks} checks evaluated, {speed['ticks_per_s'] or 0:.0f} ticks/s")
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
    for d in diags + whole:
        stdout.print(d.render(), markup=False)
    stdout.print("[green]all invariants hold[/]" if report.ok else f"[bold red]{len(report.violations)} violation(s)[/]")
    stdout.print(f"[bold red]the trace as a whole is wrong ({len(diags) + len(whole)} problem(s))[/]" if diags or whole
                 else "[green]the header's claims hold; record count and footer metrics agree with the records; "
                 "events agree with states[/]"
                 + f" ({paired_records(records)} of {report.states} records carry events)")
    return EXIT_OK if ok else EXIT_INVALID

