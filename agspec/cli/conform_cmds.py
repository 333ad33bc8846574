"""Conformance commands: ``agspec conform``, ``agspec serve``, ``agspec check``, ``agspec trace validate``.

Exit codes follow F-EXIT-CODES: 0 conformant / valid / check passed, 1 nonconformant / invalid /
violations, 2 usage or I/O error, 3 harness or protocol error.
"""

from __future__ import annotations

import gc
import sys
from typing import Any

import click

from agspec.campaign.executor import ExecutorSpec
from agspec.cli.common import EXIT_INVALID, EXIT_OK, EXIT_USAGE, FORMAT_OPTION, emit_json, fail, stderr, stdout
from agspec.cli.executor_opts import JOBS_HELP, executor_options
from agspec.cli.grammar import exitfirst_option, horizon_option, output_option, timeout_option
from agspec.formats.output import make_dir

# =============================================================================================== conform


@click.command("conform")
@click.option("--impl", "impl_spec", default=None, metavar="SPEC",
              help='Implementation under test: "reference", "python:pkg.module:factory" or a command line ("./sim --agspec").')
@timeout_option("Seconds per protocol request before the simulator counts as hung (F-PROTOCOL-ERRORS).", 5.0)
@click.option("-k", "keyword", default=None, metavar="EXPR", help="Select cases/episodes by id, title, tag, rule or glob (and/or/not).")
@exitfirst_option(False)
@click.option("--max-fail", type=int, default=None, metavar="N", help="Stop after N failures or errors.")
@click.option("-j", "--jobs", type=click.IntRange(1, 256), default=None,
              help="Workers, each with its own implementation (default: 1 locally; with --executor ray every CPU).")
@output_option("Write the JSON Lines report (F-REPORT) here, line by line.")
@click.option("--expect", "expect_path", type=click.Path(dir_okay=False), default=None,
              help="Expected-failures file (YAML or JSON): {id: {outcome: fail|error, reason: ...}}.")
@click.option("--episodes", type=int, default=2, show_default=True,
              help="Catalogue episodes per scenario: greedy plus N-1 seeded random (0: none).")
@horizon_option("Stop each catalogue episode after this many ticks (default: its whole horizon, 400 for the "
                "official scenarios; the summary states how much of each scenario's horizon was checked).")
@FORMAT_OPTION
@click.option("--validate-protocol", is_flag=True, help="Validate every message in both directions against the schemas.")
@click.option("--coverage", is_flag=True,
              help="Print which rules, invariants, values and variant-space entries the suite and the default "
                   "episodes exercise (F-CONFORM-COVERAGE), and exit: 1 if anything is uncovered.")
@click.option("--replay", "replay_path", type=click.Path(dir_okay=False), default=None,
              help="Re-run a reproducer file (saved with a divergence).")
@click.option("--no-suite", is_flag=True, help="Skip the conformance suite (run only catalogue episodes).")
@click.option("--suite", "suite_dir", type=click.Path(file_okay=False), default=None, help="Suite root (default: the shipped conformance/).")
@click.option("--repro-dir", type=click.Path(file_okay=False), default=".agspec/repro", show_default=True,
              envvar="AGSPEC_REPRO_DIR", show_envvar=True,
              help="Where reproducers of failures are saved, one subdirectory per implementation "
                   "(every path written is printed and in the report).")
@click.option("--require", "require", default=None, metavar="LEVEL",
              help="Fail (exit 1) unless the run proves LEVEL: `full` or parts from events,state,observations,masks.")
@click.option("--float-tolerance", type=float, default=None, help="Compare floats with this absolute tolerance (default: exactly).")
@click.option("--golden-cache", "golden_cache", default=None, metavar="DIR|off", envvar="AGSPEC_GOLDEN_CACHE",
              show_envvar=True, help="Golden reference traces (F-GOLDEN): reuse the reference's recorded replies "
                                     "(default ~/.cache/agspec/golden; `off`: every item runs live).")
@executor_options
def conform(impl_spec: str | None, timeout: float, keyword: str | None, exitfirst: bool, max_fail: int | None,
            jobs: int, output: str | None, expect_path: str | None, episodes: int, horizon: int | None, fmt: str,
            validate_protocol: bool, coverage: bool, replay_path: str | None, no_suite: bool, suite_dir: str | None,
            repro_dir: str, float_tolerance: float | None, require: str | None, golden_cache: str | None,
            campaign: ExecutorSpec) -> None:
    """Check an implementation against the AssemblyGrid v1 reference (F-CONFORM).

    Runs the conformance suite and lockstep episodes on the official catalogue; every state is
    compared with the reference interpreter and checked against the eleven invariants.
    """
    from agspec.cli import conform_view as view

    impl_timeout, report_path, ticks = timeout, output, horizon
    if coverage:
        raise SystemExit(view.show_coverage(suite_dir, fmt, episodes, ticks))
    if episodes < 0:
        fail(f"--episodes must be >= 0, got {episodes}")
    if max_fail is not None and max_fail < 1:
        fail(f"--max-fail must be >= 1, got {max_fail}")
    if exitfirst:
        max_fail = 1
    from agspec.conform.runner import parse_level

    try:
        required = parse_level(require) if require is not None else ()
    except ValueError as exc:
        fail(str(exc))
    items, impl_spec, universe, suite_loaded = view.build_items(impl_spec, replay_path, no_suite, suite_dir,
                                                                episodes, ticks)
    from agspec.conform.select import SelectError, select

    try:
        selected = select(items, keyword)
    except SelectError as exc:
        fail(str(exc))
    if not selected:
        fail("no case or episode selected" + (f" by -k {keyword!r}" if keyword else ""))
    expectations, stale = view.load_expect(expect_path, universe, suite_loaded)
    options_record = {"impl_timeout": impl_timeout, "k": keyword, "max_fail": max_fail, "jobs": jobs,
                      "executor": campaign.kind,
                      "episodes": episodes, "ticks": ticks, "validate_protocol": validate_protocol,
                      "suite": not no_suite and not replay_path, "replay": replay_path, "expect": expect_path,
                      "float_tolerance": float_tolerance, "require": require,
                      "repro_dir": view.repro_dir_of(repro_dir, impl_spec)}
    from agspec.conform.golden import cache_dir

    golden_dir = cache_dir(golden_cache)
    if golden_dir is not None:
        make_dir(golden_dir)  # F-OUTPUT-FAILURES: an unusable cache is found before the items run
    summary = view.execute(selected, impl_spec, impl_timeout=impl_timeout, validate=validate_protocol, campaign=campaign,
                           expectations=expectations, stale=stale, max_fail=max_fail, report_path=report_path,
                           repro_dir=view.repro_dir_of(repro_dir, impl_spec), tolerance=float_tolerance,
                           options_record=options_record, fmt=fmt,
                           require=required, golden_dir=str(golden_dir) if golden_dir else None)
    where = str(golden_dir) if golden_dir else None
    if fmt == "json":
        emit_json(view.json_summary(summary, where), "conform")
    else:
        view.print_summary(summary, impl_spec, where)
    raise SystemExit(summary.exit_code)


# =============================================================================================== serve


@click.command("serve")
@click.option("--observations/--no-observations", default=True, show_default=True,
              help="Send every robot's observation with each reply (capability `observations`).")
@click.option("--masks/--no-masks", default=True, show_default=True, help="Send every robot's mask (capability `masks`).")
def serve(observations: bool, masks: bool) -> None:
    """Run the reference interpreter as an F-PROTOCOL simulator on stdin/stdout (JSON Lines)."""
    import io

    from agspec.conform.impl.serve import Server, serve_stdio

    stdin = io.TextIOWrapper(sys.stdin.buffer, encoding="utf-8", errors="replace")
    gc.freeze()  # the modules live as long as the server: the collections each reply triggers leave them out
    raise SystemExit(serve_stdio(stdin, sys.stdout, Server(observations=observations, masks=masks)))


# =============================================================================================== check


@click.command("check")
@click.argument("targets", metavar="TRACE...", nargs=-1, required=True, type=click.Path())
@FORMAT_OPTION
@click.option("-j", "--jobs", type=click.IntRange(1, 256), default=None, help=JOBS_HELP)
@output_option("With several traces: write one JSON line per trace here, as each is checked.")
@executor_options
def check(targets: tuple[str, ...], fmt: str, jobs: int | None, output: str | None,
          campaign: ExecutorSpec) -> None:
    """Check traces (F-TRACE) against the eleven invariants (INV-*), with the vacuity guard.

    Also the trace as a whole (F-TRACE-CHECK): its record count, its footer metrics, and that every
    state change has its event and every event its change (F-TRACE-PAIRING, AG609).

    One file: its invariant table. A directory (every *.jsonl below it) or several files: a
    campaign (spec chapter 14), one row per trace, in file order whatever the executor.
    """
    from pathlib import Path

    from agspec.cli import conform_view as view

    report_path = output
    if len(targets) == 1 and not Path(targets[0]).is_dir() and report_path is None:
        if campaign.kind != "local":  # never a silently ignored option: say where the one trace is checked
            stderr.print(f"note: one trace is checked in this process; --executor {campaign.kind} distributes "
                         "several traces (a directory or several files)", markup=False)
        raise SystemExit(view.check_trace_command(targets[0], fmt))
    from agspec.cli.check_view import check_many_command

    raise SystemExit(check_many_command(targets, fmt, campaign, report_path))


# =============================================================================================== trace


@click.group("trace")
def trace() -> None:
    """Trace exchange files (F-TRACE)."""


@trace.command("validate")
@click.argument("trace_path", metavar="FILE", type=click.Path(dir_okay=False))
@FORMAT_OPTION
def trace_validate(trace_path: str, fmt: str) -> None:
    """Validate a trace against schemas/trace.schema.json and the F-TRACE structure (located errors)."""
    from agspec.trace.read import read_trace

    records, diags = read_trace(trace_path)
    io_error = any(d.code in ("AG001", "AG002") and d.line is None for d in diags)
    if fmt == "json":
        emit_json({"file": trace_path, "records": len(records), "valid": not diags,
                   "diagnostics": [_diag_json(d) for d in diags]}, "trace-validate")
    else:
        for d in diags[:50]:
            stderr.print(d.render(), markup=False)
        if len(diags) > 50:
            stderr.print(f"… {len(diags) - 50} more problems", markup=False)
        if not diags:
            ticks = sum(1 for r in records if r.get("type") == "tick")
            stdout.print(f"{trace_path}: valid trace ({ticks} tick records)")
    raise SystemExit(EXIT_USAGE if io_error else (EXIT_INVALID if diags else EXIT_OK))


def _diag_json(d: Any) -> dict[str, Any]:
    return {"code": d.code, "severity": d.severity, "message": d.message, "file": d.file, "line": d.line,
            "col": d.col, "pointer": d.pointer, "hint": d.hint}


__all__ = ["conform", "serve", "check", "trace"]
