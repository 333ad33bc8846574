"""`agspec run` and `agspec evaluate`: episodes of the reference interpreter with reference controllers."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import click
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from agspec import threads as thread_budget
from agspec.campaign.executor import ExecutorError, ExecutorSpec
from agspec.cli.common import EXIT_HARNESS, EXIT_INVALID, FORMAT_OPTION, SEED_RANGE, Choice, emit_json, fail, stderr
from agspec.cli.common import stdout
from agspec.cli.executor_opts import JOBS_HELP, executor_options
from agspec.cli.grammar import horizon_option, timeout_option
from agspec.controllers import CONTROLLERS
from agspec.formats.output import make_dir
from agspec.policy.episode import DEFAULT_LOAD_TIMEOUT

PAPER_DIR = "paper-reproduction"  # `evaluate --paper`'s default output directory

# Metrics shown by `agspec run` in its table: (key, label, format, spec ID). The ID column is what
# `agspec explain ID` takes, so every label can be looked up without the paper.
RUN_ROWS = [
    ("delivered", "Delivered products", "d", "M-DELIVERED"),
    ("throughput", "Throughput per tick", ".4f", "M-THROUGHPUT"),
    ("completion_rate", "Admitted-product completion", ".3f", "M-COMPLETION"),
    ("release_acceptance", "Release acceptance", ".3f", "M-RELEASE-ACCEPTANCE"),
    ("demand_fulfillment", "Demand fulfillment", ".3f", "M-DEMAND-FULFILLMENT"),
    ("lost_releases", "Lost releases", "d", "M-LOST-RELEASES"),
    ("mean_wip", "Mean work in progress (WIP)", ".3f", "M-MEAN-WIP"),
    ("restricted_mean_flow_time", "Restricted mean flow time (RMFT)", ".2f", "M-RMFT"),
    ("makespan", "Batch makespan C_max", "d", "M-MAKESPAN"),
    ("admissions", "Admissions", "d", "M-ADMISSIONS"),
    ("admission_failures", "Admission failures", "d", "M-ADMISSION-FAILURES"),
    ("admission_success", "Admission success, resolved", ".3f", "M-ADM-SUCCESS"),
    ("admission_latency", "Admission latency, ticks", ".2f", "M-ADMISSION-LATENCY"),
    ("coalition_success", "Coalition success |U|>=2", ".3f", "M-COALITION"),
    ("candidate_switches", "Candidate switches", "d", "M-SWITCHES"),
    ("blocked_activities", "Blocked activities, all causes", "d", "M-BLOCKED"),
    ("geometry_blocked", "  of which geometry only", "d", "M-BLOCKED"),
    ("resource_blocked", "  of which resource", "d", "M-BLOCKED"),
    ("robot_blocked", "  of which robot", "d", "M-BLOCKED"),
    ("robot_occupancy", "Robot occupancy", ".3f", "M-OCCUPANCY"),
    ("blocked_ready_rate", "Blocked-ready-operation rate", ".3f", "M-RF-BR"),
    ("no_progress_ticks", "Operational no-progress ticks", "d", "M-NO-PROGRESS"),
    ("geometry_delay_ticks", "Approach+retreat ticks", "d", "M-GEOMETRY-DELAY"),
    ("capacity_mean", "Mean capacity K* (most activities startable at once)", ".3f", "M-CAPACITY"),
    ("realized_concurrency_mean", "Mean realized concurrency", ".3f", "M-REALIZED-CONCURRENCY"),
    ("utilization", "Concurrency utilization", ".3f", "M-UTILIZATION"),
    ("capacity_exact_fraction", "Share of states with K* solved exactly", ".3f", "M-CAPACITY"),
]


def _fmt(value: Any, spec: str) -> str:
    if value is None:
        return "—"
    if spec == "d":
        return str(int(value))
    return format(value, spec)


def which_instance(instance: dict[str, Any]) -> str:
    """One line naming the instance that ran: suite index and split (S-OFFICIAL, S-SPLITS), or its seeds."""
    from agspec.catalogue import GEOMETRY_MATCHED, OFFICIAL_SCENARIOS, SPLITS

    seeds = instance.get("seeds") or {}
    index = seeds.get("index")
    if index is None:
        seeds = ", ".join(f"{k} {v}" for k, v in sorted(seeds.items()) if v is not None)
        return f"instance {instance['id']}" + (f" (seeds: {seeds})" if seeds else "")
    if instance["scenario"].get("id") not in (*OFFICIAL_SCENARIOS, *GEOMETRY_MATCHED):
        return (f"instance {instance['id']}: suite index {index} (generation seed {seeds.get('generation')}, "
                f"execution seed {seeds.get('execution')})")
    split = next((name for name, r in SPLITS.items() if index in r), None)
    where = f"{split} split {SPLITS[split].start}-{SPLITS[split].stop - 1}" if split else "outside the named splits"
    hint = "" if split == "final-test" else "; the paper's tables use the final-test split (--index 1000 to 1049)"
    return f"instance {instance['id']}: suite index {index} ({where}){hint}"


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
@click.option("--generation-seed", "seed", type=SEED_RANGE, default=None,
              help="An instance from this explicit generation seed instead of a suite index (S-SEEDS).")
@click.option("--controller", type=Choice(CONTROLLERS), default="greedy", show_default=True)
@horizon_option()
@click.option("--format", "fmt", type=Choice(["table", "json", "result-v1"]), default="table", show_default=True)
@click.option("--trace", "trace_path", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Write the trace exchange format (JSON Lines) to this file.")
@click.option("--observations/--no-observations", default=False, help="Include every agent's observation in the trace.")
@click.option("--policy", default=None, metavar="PATH.py:NAME|module:NAME|\"CMD ARGS\"",
              help="Run a policy instead of a reference controller (spec/13-policy.md).")
@click.option("--strict", is_flag=True, help="A masked action is an error instead of idle (F-POLICY-ILLEGAL).")
@timeout_option("Seconds a policy may take per decision, loading excluded (F-POLICY-ERRORS).", 10.0)
@click.option("--load-timeout", type=click.FloatRange(0.001, 86400), default=DEFAULT_LOAD_TIMEOUT, show_default=True,
              help="Seconds a Python policy may take to load: module import and factory(env) (F-POLICY-HOST).")
def run(target: str, index: int | None, seed: int | None, controller: str, horizon: int | None, fmt: str,
        trace_path: Path | None, observations: bool, policy: str | None, strict: bool, timeout: float,
        load_timeout: float) -> None:
    """Run one episode of SCENARIO (official name or .ag file) or INSTANCE (.json) with a reference controller
    or a policy."""
    from agspec.evaluate import run_episode
    from agspec.formats.trace import TraceWriter
    from agspec.interp.observe import SlotOverflow
    from agspec.policy.contract import PolicyError, PolicySpecError, parse_policy

    try:
        spec = parse_policy(policy) if policy is not None else None
    except PolicySpecError as exc:
        fail(str(exc))
    if spec is not None:
        controller = spec.label

    if horizon is not None and horizon < 1:
        fail("--horizon must be at least 1")
    instance = load_instance(target, index, seed)
    writer = None
    if trace_path is not None:
        writer = TraceWriter(trace_path)  # F-OUTPUT-FAILURES
    total = horizon or instance["scenario"]["evaluation"].get("horizon") or instance["scenario"]["evaluation"].get("timeout")
    show = fmt == "table" and sys.stderr.isatty()
    try:
        with Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                      console=stderr, disable=not show, transient=True) as progress:
            task = progress.add_task(f"{instance['id']} · {controller}", total=total)
            result = run_episode(instance, spec or controller, horizon=horizon, trace=writer,
                                 observations_in_trace=observations, strict=strict, timeout=timeout,
                                 load_timeout=load_timeout,
                                 on_tick=lambda t, limit: progress.update(task, completed=t))
    except SlotOverflow as exc:
        fail(f"action-slot overflow (O-ACTION-ENCODING): {exc}", EXIT_INVALID)
    except PolicySpecError as exc:
        fail(str(exc))
    except PolicyError as exc:
        where = ", ".join(x for x in (f"tick {exc.tick}" if exc.tick is not None else "",
                                      f"agent {exc.agent}" if exc.agent else "") if x)
        fail(f"policy {spec.label if spec else controller} on {instance['id']}{' (' + where + ')' if where else ''}: "
             f"{exc.message} [{exc.code}]", EXIT_INVALID)
    finally:
        if writer is not None:
            writer.close()
    metrics = result.metrics
    if fmt == "json":
        emit_json({"instance": instance["id"], "controller": controller, "metrics": metrics}, "run-result")
        return
    if fmt == "result-v1":
        from agspec.interop.original import result_record

        emit_json(result_record(instance, controller, metrics), "original-result-v1")
        return
    table = Table(title=f"{instance['id']} · {'policy' if spec else 'controller'} {controller} · {metrics['ticks']} ticks"
                  + (f" · {result.illegal_actions} masked actions run as idle" if result.illegal_actions else ""),
                  caption="`agspec explain ID` prints the definition of each measure")
    table.add_column("Measure")
    table.add_column("Value", justify="right")
    table.add_column("spec ID", style="dim")
    for key, label, number, ident in RUN_ROWS:
        if key == "makespan" and instance["scenario"]["evaluation"]["mode"] != "batch":
            continue
        table.add_row(label, _fmt(metrics.get(key), number), ident)
    stdout.print(which_instance(instance))
    stdout.print(table, soft_wrap=False)
    if trace_path is not None:
        stdout.print(f"trace written to {trace_path}")


METRICS = tuple(row[0] for row in RUN_ROWS)


@click.command("evaluate")
@click.argument("bundles", nargs=-1, type=click.Path(dir_okay=False, path_type=Path))
@click.option("--from", "from_bundles", is_flag=True,
              help="Read results bundles (the arguments) instead of or before running (F-POLICY-BUNDLE).")
@click.option("--policy", "policies", multiple=True, metavar="PATH.py:NAME|module:NAME|\"CMD ARGS\"",
              help="A policy to evaluate beside the references (F-POLICY-SPEC); repeatable.")
@click.option("--name", "names", multiple=True, help="Label of the --policy of the same position.")
@click.option("--policy-version", "versions", multiple=True, help="Version recorded for the --policy of the same position.")
@click.option("--controller", "controllers", multiple=True, type=Choice(CONTROLLERS),
              help="Reference controllers (default: all four).")
@click.option("--scenario", "scenarios", multiple=True, help="Scenarios (default: the nine official ones).")
@click.option("--split", type=Choice(["final-test", "validation", "catalogue", "geometry-matched"]), default=None,
              help="Instance split (default final-test).")
@click.option("--indices", default=None, help="Suite indices inside the split, e.g. 1000-1049 or 1000,1003,1005-1007.")
@click.option("-j", "--jobs", type=click.IntRange(1, 256), default=None, help=JOBS_HELP)
@click.option("--threads", type=click.IntRange(1), default=None,
              help="Torch intra-op threads of each policy process (default: the budget, CAMP-THREADS).")
@click.option("--metric", "metric_keys", multiple=True, type=Choice(METRICS), default=None,
              help="Metrics to show (default delivered; with --policy also admitted completion).")
@click.option("--diagnostics", is_flag=True, help="Also show the mechanism diagnostics the paper reports.")
@click.option("--strict", is_flag=True, help="A masked action is an error instead of idle (F-POLICY-ILLEGAL).")
@timeout_option("Seconds a policy may take per decision, loading excluded (F-POLICY-ERRORS).", 10.0)
@click.option("--load-timeout", type=click.FloatRange(0.001, 86400), default=DEFAULT_LOAD_TIMEOUT, show_default=True,
              help="Seconds a Python policy may take to load: module import (once per worker) and factory(env) "
                   "(F-POLICY-HOST).")
@click.option("--repeat", "repeats", type=click.IntRange(0, 50), default=1, show_default=True,
              help="Episodes per scenario each user policy runs twice to detect nondeterminism.")
@click.option("--no-published", is_flag=True, help="Leave out the paper's published MARL rows.")
@click.option("--allow-incomplete", is_flag=True,
              help="Render rows with errors or missing episodes, marked ‡ with their n of N (F-POLICY-COVERAGE); "
                   "without it they are refused. Either way such rows make the exit status 1.")
@click.option("-o", "--output", "output", type=click.Path(), default=None, metavar="FILE|DIRECTORY",
              help="Write a results bundle to FILE (written as episodes end); with --paper, the DIRECTORY where "
                   f"reproduction.md and reproduction.json are written (default ./{PAPER_DIR}).")
@FORMAT_OPTION
@click.option("--paper", is_flag=True, help="Run what the paper's tables report and compare (writes the report).")
@executor_options
def evaluate(bundles: tuple[Path, ...], from_bundles: bool, policies: tuple[str, ...], names: tuple[str, ...],
             versions: tuple[str, ...], controllers: tuple[str, ...], scenarios: tuple[str, ...], split: str | None,
             indices: str | None, jobs: int, threads: int | None, metric_keys: tuple[str, ...], diagnostics: bool, strict: bool,
             timeout: float, load_timeout: float, repeats: int, no_published: bool, allow_incomplete: bool,
             output: str | None, fmt: str, paper: bool, campaign: ExecutorSpec) -> None:
    """Evaluate policies and reference controllers on many instances: the paper's table, mean ± 95 % interval
    (1.96·s/√n), and a paired comparison of each --policy against each reference (spec/13-policy.md)."""
    budget = thread_budget.facts(campaign.jobs or 1, threads,
                                 thread_budget.apply(thread_budget.budget(campaign.jobs or 1, threads)))
    if paper:  # never into the project's own docs/ by default: a directory of its own in the working directory
        _evaluate_paper(campaign, Path(output or PAPER_DIR), fmt)
        return
    out_path = Path(output) if output is not None else None
    from agspec.cli.evaluate_view import Campaign

    if bundles and not from_bundles:
        fail(f"unexpected argument {bundles[0]}; results bundles are read with --from")
    if from_bundles and not bundles:
        fail("--from needs at least one results bundle")
    if len(names) > len(policies) or len(versions) > len(policies):
        fail("give at most one --name and one --policy-version per --policy")
    plan = Campaign.plan(bundles=bundles, policies=policies, names=names, versions=versions,
                             controllers=controllers, scenarios=scenarios, split=split, indices=indices,
                             strict=strict, timeout=timeout, load_timeout=load_timeout, repeats=repeats)
    try:
        plan.run(campaign, out_path, show=fmt == "table" and sys.stderr.isatty(), threads=budget)
    except ExecutorError as exc:
        fail(str(exc))
    metrics = metric_keys or (("delivered", "completion_rate") if plan.user_labels else ("delivered",))
    if diagnostics:
        from agspec.cli.evaluate_view import DIAGNOSTICS

        metrics = tuple(dict.fromkeys((*metrics, *DIAGNOSTICS)))
    incomplete = plan.render(metrics, fmt, with_published=not no_published, allow_incomplete=allow_incomplete)
    if plan.failed or incomplete:  # F-EXIT-CODES: errors, missing episodes or nondeterminism
        raise SystemExit(EXIT_INVALID)


def _evaluate_paper(campaign: ExecutorSpec, out_dir: Path, fmt: str) -> None:
    """`agspec evaluate --paper`: the paper's non-learning tables, ours beside theirs."""
    from agspec.reproduce import EpisodeFailures, default_plan, ours_text, paper_text, run_paper

    make_dir(out_dir)  # F-OUTPUT-FAILURES: an unusable directory is found before the episodes run
    total = sum(len(indices) for _, _, indices in default_plan())
    show = fmt == "table" and sys.stderr.isatty()
    with Progress(TextColumn("[bold]paper reproduction"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                  console=stderr, disable=not show) as progress:
        task = progress.add_task("episodes", total=total)
        try:
            report = run_paper(out_dir=out_dir, executor=campaign, on_done=lambda run: progress.advance(task))
        except ExecutorError as exc:
            fail(str(exc))
        except EpisodeFailures as exc:
            fail(f"{exc}; nothing was written", EXIT_HARNESS)
    if fmt == "json":
        emit_json(report, "reproduction")
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
