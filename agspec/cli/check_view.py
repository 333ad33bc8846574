"""``agspec check`` over a directory or many traces: a campaign (spec chapter 14), one trace per item.

The records come back in the order of the expanded file list whatever the executor (CAMP-ORDER); the
JSON Lines report is written and flushed one trace at a time, so an interrupted run keeps every
line already written (CAMP-CANCEL).
"""

from __future__ import annotations

import json
import sys
import time
from typing import Any, Sequence

from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from agspec.campaign.executor import Done, ExecutorError, ExecutorSpec, Task, run_ordered
from agspec.cli.common import emit_json, fail, stderr, stdout
from agspec.formats.output import Stream
from agspec.formats.schemas import self_check
from agspec.trace.check import EXIT_HARNESS, check_file, exit_code, expand

VERDICT = {0: "[green]ok[/]", 1: "[bold red]fails[/]", 2: "[bold red]unreadable[/]", 3: "[bold magenta]error[/]"}
COUNTED = {0: "ok", 1: "failed", 2: "unreadable", 3: "error"}


def check_many_command(targets: Sequence[str], fmt: str, campaign: ExecutorSpec, report_path: str | None) -> int:
    paths = expand(targets)
    if not paths:
        fail(f"no trace files (*.jsonl) in {', '.join(targets)}")
    report = Stream(report_path) if report_path else None  # F-OUTPUT-FAILURES
    records: list[dict[str, Any]] = []
    show = fmt == "table" and sys.stderr.isatty()
    started = time.perf_counter()
    try:
        with Progress(TextColumn("[bold]check"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                      console=stderr, disable=not show, transient=True) as progress:
            task = progress.add_task("traces", total=len(paths))
            for i, outcome in run_ordered(Task(check_file), paths, campaign,
                                          on_progress=lambda i, o: progress.advance(task)):
                record = outcome.value if isinstance(outcome, Done) else {
                    "file": paths[i], "ok": False, "exit": EXIT_HARNESS, "error": outcome.message()}
                records.append(record)
                if report is not None:
                    self_check("check-report", {"type": "trace", **record})  # F-SCHEMAS-SELF
                    report.write(json.dumps({"type": "trace", **record}, ensure_ascii=False) + "\n")
    except ExecutorError as exc:
        fail(str(exc))
    finally:
        if report is not None and sys.exc_info()[0] is not None:
            report.abandon()
    seconds = time.perf_counter() - started
    code = exit_code(records)
    counts = {name: sum(1 for r in records if r["exit"] == c) for c, name in COUNTED.items()}
    if report is not None:
        footer = {"type": "footer", "traces": len(records), "counts": counts, "exit_code": code}
        self_check("check-report", footer)  # F-SCHEMAS-SELF
        report.write(json.dumps(footer) + "\n")
        report.close()
    if fmt == "json":
        # the timing is the one non-deterministic part of the output; the report file carries none
        emit_json({"traces": records, "counts": counts, "exit_code": code,
                   "timing": timing(sum(r.get("ticks", 0) for r in records), seconds)}, "check")
        return code
    table = Table(title=f"agspec check · {len(records)} traces")
    for col in ("Trace", "Ticks", "Checks evaluated", "Violations", "Verdict"):
        table.add_column(col, justify="right" if col in ("Ticks", "Checks evaluated", "Violations") else "left",
                         overflow="fold")
    for r in records:
        table.add_row(r["file"], str(r.get("ticks", "—")), str(r.get("total_checks", "—")),
                      str(len(r.get("violations", ()))), VERDICT[r["exit"]])
    stdout.print(table)
    for r in records:
        if r["exit"] == EXIT_HARNESS:
            stderr.print(f"[bold magenta]error[/] {r['file']}: {r['error']}")
        elif r["exit"] and r.get("diagnostics") and not r.get("violations"):
            stderr.print(f"{r['file']}: {r['diagnostics'][0]['message']}", markup=False)
    stdout.print(", ".join(f"{n} {name}" for name, n in counts.items()))
    speed = timing(sum(r.get("ticks", 0) for r in records), seconds)
    stdout.print(f"{speed['ticks']} ticks checked in {speed['seconds']:.2f} s: {speed['ticks_per_s']:.0f} ticks/s")
    return code


def timing(ticks: int, seconds: float) -> dict[str, Any]:
    """How fast the invariants were checked: ticks per second of wall time (reading included)."""
    return {"ticks": ticks, "seconds": round(seconds, 4), "ticks_per_s": round(ticks / seconds, 1) if seconds > 0 else None}


__all__ = ["check_many_command", "timing"]
