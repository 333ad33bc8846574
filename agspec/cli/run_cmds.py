"""`agspec run` and `agspec evaluate`: episodes of the reference interpreter with reference controllers."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import click
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from agspec.cli.common import EXIT_INVALID, EXIT_USAGE, SEED_RANGE, emit_json, fail, stderr, stdout
from agspec.controllers import CONTROLLERS

# Metrics shown by `agspec run` in its table: (key, label, format)
RUN_ROWS = [
    ("delivered", "Delivered products (M-DELIVERED)", "d"),
    ("throughput", "Throughput per tick (M-THROUGHPUT)", ".4f"),
    ("completion_rate", "Admitted-product completion (M-COMPLETION)", ".3f"),
    ("release_acceptance", "Release acceptance (M-RELEASE-ACCEPTANCE)", ".3f"),
    ("demand_fulfillment", "Demand fulfillment (M-DEMAND-FULFILLMENT)", ".3f"),
    ("lost_releases", "Lost releases (M-LOST-RELEASES)", "d"),
    ("mean_wip", "Mean WIP (M-MEAN-WIP)", ".3f"),
    ("restricted_mean_flow_time", "Restricted mean flow time (M-RMFT)", ".2f"),
    ("makespan", "Batch makespan C_max (M-MAKESPAN)", "d"),
    ("admissions", "Admissions (M-ADMISSIONS)", "d"),
    ("admission_failures", "Admission failures (M-ADMISSION-FAILURES)", "d"),
    ("admission_success", "Admission success, resolved (M-ADM-SUCCESS)", ".3f"),
    ("admission_latency", "Admission latency, ticks (M-ADMISSION-LATENCY)", ".2f"),
    ("coalition_success", "Coalition success |U|>=2 (M-COALITION)", ".3f"),
    ("candidate_switches", "Candidate switches (M-SWITCHES)", "d"),
    ("blocked_activities", "Blocked activities, all causes (M-BLOCKED)", "d"),
    ("geometry_blocked", "  geometry-only", "d"),
    ("resource_blocked", "  resource", "d"),
    ("robot_blocked", "  robot", "d"),
    ("robot_occupancy", "Robot occupancy (M-OCCUPANCY)", ".3f"),
    ("blocked_ready_rate", "Blocked-ready-operation rate (M-RF-BR)", ".3f"),
    ("no_progress_ticks", "Operational no-progress ticks (M-NO-PROGRESS)", "d"),
    ("geometry_delay_ticks", "Approach+retreat ticks (M-GEOMETRY-DELAY)", "d"),
    ("capacity_mean", "Mean capacity K* (M-CAPACITY)", ".3f"),
    ("realized_concurrency_mean", "Mean realized concurrency (M-REALIZED-CONCURRENCY)", ".3f"),
    ("utilization", "Concurrency utilization (M-UTILIZATION)", ".3f"),
    ("capacity_exact_fraction", "Exact K* share of states", ".3f"),
]


def _fmt(value: Any, spec: str) -> str:
    if value is None:
        return "—"
    if spec == "d":
        return str(int(value))
    return format(value, spec)


def load_instance(target: str, index: int | None, seed: int | None) -> dict[str, Any]:
    """agspec.catalogue.load_instance with its errors as CLI failures (F-EXIT-CODES)."""
    from agspec.catalogue import CatalogueError, InvalidDocumentError, InvalidInstanceError
    from agspec.catalogue import load_instance as load

    try:
        return load(target, index, seed)
    except (InvalidInstanceError, InvalidDocumentError) as exc:
        fail(str(exc), EXIT_INVALID)
    except CatalogueError as exc:
        fail(str(exc))


@click.command("run")
@click.argument("target", metavar="SCENARIO|INSTANCE")
@click.option("--index", type=SEED_RANGE, default=None, help="Suite index of the instance (default 0).")
@click.option("--seed", type=SEED_RANGE, default=None, help="Explicit generation seed instead of a suite index.")
@click.option("--controller", type=click.Choice(CONTROLLERS), default="greedy", show_default=True)
@click.option("--horizon", type=int, default=None, help="Stop earlier than the scenario horizon.")
@click.option("--format", "fmt", type=click.Choice(["table", "json", "result-v1"]), default="table", show_default=True)
@click.option("--trace", "trace_path", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Write the trace exchange format (JSON Lines) to this file.")
@click.option("--observations/--no-observations", default=False, help="Include every agent's observation in the trace.")
def run(target: str, index: int | None, seed: int | None, controller: str, horizon: int | None, fmt: str,
        trace_path: Path | None, observations: bool) -> None:
    """Run one episode of SCENARIO (official name or .ag file) or INSTANCE (.json) with a reference controller."""
    from agspec.evaluate import run_episode
    from agspec.interp.observe import SlotOverflow
    from agspec.formats.trace import TraceWriter

    if horizon is not None and horizon < 1:
        fail("--horizon must be at least 1")
    instance = load_instance(target, index, seed)
    writer = None
    if trace_path is not None:
        try:
            writer = TraceWriter(trace_path)
        except OSError as exc:
            fail(f"cannot write trace {trace_path}: {exc}")
    total = horizon or instance["scenario"]["evaluation"].get("horizon") or instance["scenario"]["evaluation"].get("timeout")
    show = fmt == "table" and sys.stderr.isatty()
    try:
        with Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                      console=stderr, disable=not show, transient=True) as progress:
            task = progress.add_task(f"{instance['id']} · {controller}", total=total)
            result = run_episode(instance, controller, horizon=horizon, trace=writer, observations_in_trace=observations,
                                 on_tick=lambda t, limit: progress.update(task, completed=t))
    except SlotOverflow as exc:
        fail(f"action-slot overflow (O-ACTION-ENCODING): {exc}", EXIT_INVALID)
    finally:
        if writer is not None:
            writer.close()
    metrics = result.metrics
    if fmt == "json":
        emit_json({"instance": instance["id"], "controller": controller, "metrics": metrics})
        return
    if fmt == "result-v1":
        from agspec.interop.original import result_record

        emit_json(result_record(instance, controller, metrics))
        return
    table = Table(title=f"{instance['id']} · controller {controller} · {metrics['ticks']} ticks")
    table.add_column("Measure")
    table.add_column("Value", justify="right")
    for key, label, spec in RUN_ROWS:
        if key == "makespan" and instance["scenario"]["evaluation"]["mode"] != "batch":
            continue
        table.add_row(label, _fmt(metrics.get(key), spec))
    stdout.print(table)
    if trace_path is not None:
        stdout.print(f"trace written to {trace_path}")


@click.command("evaluate")
@click.option("--controller", "controllers", multiple=True, type=click.Choice(CONTROLLERS),
              help="Controllers to evaluate (default: all four).")
@click.option("--scenario", "scenarios", multiple=True, help="Scenarios (default: the nine official ones).")
@click.option("--split", type=click.Choice(["final-test", "validation", "catalogue", "geometry-matched"]), default=None,
              help="Instance split (default final-test).")
@click.option("--indices", default=None, help="Explicit suite indices, e.g. 1000-1049 or 0,3,5-7.")
@click.option("-j", "--jobs", type=int, default=1, show_default=True, help="Worker processes.")
@click.option("--metric", "metric_keys", multiple=True, default=("delivered",), show_default=True,
              help="Metrics to summarize.")
@click.option("--format", "fmt", type=click.Choice(["table", "json"]), default="table", show_default=True)
@click.option("--paper", is_flag=True, help="Run what the paper's tables report and compare (writes the report).")
@click.option("--out-dir", type=click.Path(file_okay=False, path_type=Path), default=Path("docs"), show_default=True,
              help="With --paper: where reproduction.md and reproduction.json are written.")
def evaluate(controllers: tuple[str, ...], scenarios: tuple[str, ...], split: str | None, indices: str | None,
             jobs: int, metric_keys: tuple[str, ...], fmt: str, paper: bool, out_dir: Path) -> None:
    """Evaluate controllers over many instances: mean ± 95 % interval (1.96·s/√n) per scenario and controller."""
    if paper:
        _evaluate_paper(jobs, out_dir, fmt)
        return
    from agspec.catalogue import (
        OFFICIAL_SCENARIOS,
        SPLITS,
        CatalogueError,
        InvalidDocumentError,
        load_scenario_bundle,
        parse_indices,
    )
    from agspec.evaluate import evaluate as run_all
    from agspec.evaluate import summarize
    from agspec.ir.instance import make_instance

    if split and indices:
        fail("give either --split or --indices, not both")
    if jobs < 1:
        fail("-j must be at least 1")
    try:
        idx = list(parse_indices(indices)) if indices else list(SPLITS[split or "final-test"])
    except ValueError as exc:
        fail(str(exc))
    controllers = controllers or CONTROLLERS
    scenarios = scenarios or tuple(OFFICIAL_SCENARIOS)
    bundles = {}
    for name in scenarios:
        try:
            bundles[name] = load_scenario_bundle(name)
        except CatalogueError as exc:  # RES-EXIT-CONTENT: a document with errors is invalid input
            fail(str(exc), EXIT_INVALID if isinstance(exc, InvalidDocumentError) else EXIT_USAGE)
    job_list = []
    for name in scenarios:
        sc, recipes, profile = bundles[name]
        for k in idx:
            inst = make_instance(sc, recipes, profile, index=k)
            for ctl in controllers:
                job_list.append((name, ctl, k, inst))
    show = fmt == "table" and sys.stderr.isatty()
    with Progress(TextColumn("[bold]evaluate"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                  console=stderr, disable=not show) as progress:
        task = progress.add_task("episodes", total=len(job_list))
        runs = run_all(job_list, workers=jobs, on_done=lambda run: progress.advance(task))
    summary = summarize(runs, metric_keys)
    if fmt == "json":
        emit_json({"runs": runs, "summary": summary})
        return
    for key in metric_keys:
        table = Table(title=f"{key}: mean ± 95 % half-width over {len(idx)} instances")
        table.add_column("Scenario")
        for ctl in controllers:
            table.add_column(ctl, justify="right")
        for name in scenarios:
            row = [name]
            for ctl in controllers:
                entry = next((s for s in summary if s["scenario"] == name and s["controller"] == ctl), None)
                stat = entry[key] if entry else None
                row.append("—" if not stat or stat["n"] == 0 else f"{stat['mean']:.2f} ± {stat['half_width']:.2f}")
            table.add_row(*row)
        stdout.print(table)


def _evaluate_paper(jobs: int, out_dir: Path, fmt: str) -> None:
    """`agspec evaluate --paper`: the paper's non-learning tables, ours beside theirs."""
    from agspec.reproduce import default_plan, ours_text, paper_text, run_paper

    if jobs < 1:
        fail("-j must be at least 1")
    total = sum(len(indices) for _, _, indices in default_plan())
    show = fmt == "table" and sys.stderr.isatty()
    with Progress(TextColumn("[bold]paper reproduction"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                  console=stderr, disable=not show) as progress:
        task = progress.add_task("episodes", total=total)
        report = run_paper(workers=jobs, out_dir=out_dir, on_done=lambda run: progress.advance(task))
    if fmt == "json":
        emit_json(report)
        return
    table = Table(title=f"paper reproduction ({report['episodes']} episodes)")
    for col in ("table", "scenario", "controller", "metric", "ours", "paper", "mark"):
        table.add_column(col, justify="right" if col in ("ours", "paper") else "left")
    for r in report["rows"]:
        table.add_row(r["table"], r["scenario"], r["controller"], r["metric"], ours_text(r), paper_text(r), r["mark"])
    stdout.print(table)
    c = report["counts"]
    stdout.print(f"{c['exact']} exact, {c['inside']} inside, {c['outside']} outside; "
                 f"written to {out_dir / 'reproduction.md'} and {out_dir / 'reproduction.json'}")
