"""`agspec render`: a self-contained HTML replay of a trace, or of a conformance divergence."""

from __future__ import annotations

from pathlib import Path

import click
from rich.markup import escape

from agspec.cli.common import EXIT_HARNESS, EXIT_INVALID, EXIT_USAGE, SEED_RANGE, Choice, fail, stderr, stdout
from agspec.cli.grammar import horizon_option, output_option, timeout_option
from agspec.controllers import CONTROLLERS
from agspec.formats.output import write_text


@click.command("render")
@click.argument("trace_path", metavar="[TRACE]", required=False, type=click.Path(dir_okay=False, path_type=Path))
@output_option("The HTML file to write (default replay.html, or diff.html with --diff).")
@click.option("--diff", "report", type=click.Path(dir_okay=False, path_type=Path), default=None, metavar="REPORT",
              help="A conformance report (agspec conform -o FILE): show its first divergence, the expected "
                   "(reference) states beside the observed ones (what the implementation sent).")
@click.option("--case", "case_id", default=None, help="With --diff: the failing case to show (default: the first divergence).")
@click.option("--rerun", "replay", is_flag=True,
              help="With --diff: re-run the reproducer's implementation for its states after the divergence too "
                   "(default: the states the implementation sent, as the report recorded them).")
@click.option("--impl", "impl", default=None, metavar="SPEC",
              help="With --diff: the implementation to re-run (implies --rerun). Without a TRACE: record a trace "
                   "of this implementation (a command line, python:pkg.mod:factory or reference) and render it.")
@click.option("--scenario", default=None, metavar="SCENARIO|INSTANCE",
              help="With --impl: the scenario (official name or .ag file) or instance .json to record.")
@click.option("--index", type=SEED_RANGE, default=0, show_default=True, help="With --scenario: the suite index.")
@horizon_option("With --impl: ticks to record.", default=120)
@click.option("--controller", type=Choice(CONTROLLERS), default="greedy", show_default=True,
              help="With --impl: the reference controller choosing the actions.")
@click.option("--observations/--no-observations", default=True, show_default=True,
              help="With --impl: record every robot's observation and mask in the trace.")
@click.option("--trace", "save_trace", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="With --impl: also keep the recorded trace (F-TRACE JSON Lines) in this file.")
@timeout_option("Seconds per protocol request before an implementation counts as hung.", 5.0)
@click.option("--keyframe", type=click.IntRange(1), default=25, show_default=True,
              help="A full state every K ticks; per-tick diffs in between.")
@click.option("--title", default=None, help="Page title (default: instance and controller).")
def render(trace_path, output, report, case_id, replay, impl, scenario, index, horizon, controller, observations,
           save_trace, timeout, keyframe, title) -> None:
    """Write one self-contained HTML file (no network) replaying TRACE, a divergence, or a recorded run.

    \b
      agspec render TRACE -o replay.html
      agspec render --diff REPORT [--rerun | --impl SPEC] -o diff.html
      agspec render --impl "CMD ARGS" --scenario coalition-medium --horizon 120 -o replay.html

    Exit 0: written; 1: the trace or report cannot be replayed (located message); 2: usage or I/O;
    3: the implementation failed while being recorded.
    """
    from agspec.viewer.page import build_page

    out = Path(output) if output is not None else None
    ticks, impl_timeout = horizon, timeout
    modes = sum([trace_path is not None, report is not None, impl is not None and report is None])
    if modes != 1:
        fail("give exactly one of: a TRACE file, --diff REPORT, or --impl SPEC --scenario S", EXIT_USAGE)
    if report is not None:
        data = _diff(report, case_id, replay, impl, impl_timeout, keyframe)
        page = build_page(data, title=title or data["title"], mode="diff")
        out = out or Path("diff.html")
        summary = f"divergence of {data['case_id']} at state {data['focus']}"
    else:
        if impl is not None:
            trace_path, failed = _record(impl, scenario, index, ticks, controller, observations, save_trace,
                                         impl_timeout)
        doc = _encode(trace_path, keyframe, title)
        if impl is not None and save_trace is None and not failed:
            import shutil

            shutil.rmtree(trace_path.parent, ignore_errors=True)  # our temporary directory
        page = build_page({"mode": "trace", "replay": doc}, title=doc["title"], mode="trace")
        out = out or Path("replay.html")
        summary = f"{doc['T']} ticks, {len(doc['states']['keys'][0]['robots'])} robots" + (
            ", observations" if doc["observations"] else "")
    write_text(out, page)  # F-OUTPUT-FAILURES
    stdout.print(f"wrote {out} ({len(page.encode('utf-8')) / 1e6:.2f} MB; {summary})")
    if impl is not None and report is None and failed:
        raise SystemExit(EXIT_HARNESS)  # the page shows the run up to the failure


SCHEMA_SAMPLE = 5  # tick records schema-checked besides the header and footer (speed: a 48-robot trace
#                    with observations is 35 MB; `agspec trace validate` checks every record)


def _encode(path: Path, keyframe: int, title: str | None) -> dict:
    """Read and encode a trace; schema problems are warnings (a viewer must show broken traces too)."""
    from agspec.formats.schemas import validate
    from agspec.trace.read import read_trace
    from agspec.viewer.encode import EncodeError, encode, trace_data

    records, diags = read_trace(path, schema=False)
    fatal = [d for d in diags if d.code in ("AG001", "AG002") and d.line is None]
    if fatal:
        fail(fatal[0].message, EXIT_USAGE)
    # unusable: nothing parsed, or no header first; anything else (a truncated or schema-invalid trace
    # of a crashed simulator) is still worth looking at, with warnings
    if not records or records[0].get("type") != "header":
        order = {"AG003": 0, "AG006": 0, "AG007": 0, "AG206": 0, "AG002": 1, "AG601": 2, "AG606": 3}
        d = min((d for d in diags if d.code in order), key=lambda d: order[d.code], default=None)
        if d is not None:
            fail(f"{path}:{d.line or 1}: error[{d.code}]: {d.message}", EXIT_INVALID)
    warnings = [f"{path}:{d.line or '?'}: {d.code}: {d.message}" for d in diags]
    sample = sorted({0, len(records) - 1, *range(1, min(len(records), SCHEMA_SAMPLE + 1))})
    for idx in sample:
        for p in validate("trace", records[idx], limit=3):
            warnings.append(f"{path}: record {idx + 1} ({records[idx].get('type')}): {p.code}: "
                            f"{p.pointer or '/'}: {p.message}")
    for w in warnings[:6]:
        stderr.print(f"[yellow]warning[/]: {escape(w)}", markup=True, highlight=False)
    if len(warnings) > 6:
        stderr.print(f"[yellow]warning[/]: … {len(warnings) - 6} more problem(s)")
    if warnings:
        stderr.print(f"`agspec trace validate {path}` checks every record against the schema")
    try:
        return encode(trace_data(records, name=str(path)), keyframe=keyframe, title=title)
    except EncodeError as exc:
        fail(f"{exc} (F-TRACE)", EXIT_INVALID)


def _record(impl: str, scenario: str | None, index: int, ticks: int, controller: str, observations: bool,
            save: Path | None, timeout: float) -> tuple[Path, bool]:
    """Record a trace of ``impl`` (F-PROTOCOL) into ``save`` or a temporary file; (path, failed).

    When the implementation fails mid-run the partial trace (no footer, AG604) is still rendered and
    the command exits 3 afterwards; when it fails before its first state there is nothing to show.
    """
    import tempfile

    from agspec.cli.run_cmds import load_instance
    from agspec.conform.impl import ImplSpecError
    from agspec.formats.trace import TraceWriter
    from agspec.viewer.record import RecordError, record

    if scenario is None:
        fail("--impl needs --scenario (an official scenario name, a scenario .ag file or an instance .json)", EXIT_USAGE)
    instance = load_instance(scenario, index, None)
    path = save or Path(tempfile.mkdtemp(prefix="agspec-render-")) / "trace.jsonl"
    writer = TraceWriter(path)  # F-OUTPUT-FAILURES
    try:
        rec = record(impl, instance, writer, ticks=ticks, controller=controller, observations=observations,
                     timeout=timeout)
    except ImplSpecError as exc:
        fail(str(exc), EXIT_USAGE)
    except RecordError as exc:
        writer.close()
        if writer.ticks == 0 and path.stat().st_size == 0:
            fail(str(exc), EXIT_HARNESS)
        stderr.print(f"[bold red]error[/]: {exc}; rendering the {writer.ticks} tick(s) recorded before it "
                     f"(partial trace in {path})")
        return path, True
    finally:
        writer.close()
    stderr.print(f"recorded {rec.ticks} ticks of {rec.implementation.get('name', impl)} into {path}")
    return path, False


def _diff(report: Path, case_id, replay: bool, impl, timeout: float, keyframe: int) -> dict:
    from agspec.conform.impl import ImplSpecError
    from agspec.viewer.divergence import ReportError, build_diff
    from agspec.viewer.record import RecordError

    try:
        return build_diff(report, case_id=case_id, replay=replay, impl=impl, timeout=timeout, keyframe=keyframe)
    except ReportError as exc:
        fail(str(exc), EXIT_USAGE if exc.usage else EXIT_INVALID)
    except ImplSpecError as exc:
        fail(str(exc), EXIT_USAGE)
    except RecordError as exc:
        fail(str(exc), EXIT_HARNESS)


__all__ = ["render"]
