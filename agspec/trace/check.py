"""``agspec check`` over many traces: one trace is one campaign item (CAMP-EXECUTOR).

:func:`check_file` reads a trace (F-TRACE) and checks the eleven invariants (INV-*); it returns the
trace's JSON record — the same record ``agspec check --format json`` prints for one trace, plus its
exit code (F-EXIT-CODES).  The worker reads the file itself: on a cluster the traces must be where
the workers can read them (a shared filesystem, or a Ray ``working_dir``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Iterable

from agspec.invariants import check_trace
from agspec.trace.read import _diag as trace_diag
from agspec.trace.read import read_trace
from agspec.trace.verify import verify as verify_whole

EXIT_OK, EXIT_INVALID, EXIT_USAGE, EXIT_HARNESS = 0, 1, 2, 3  # F-EXIT-CODES
TRACE_SUFFIXES = (".jsonl",)


def diag_record(d: Any) -> dict[str, Any]:
    return {"code": d.code, "message": d.message, "line": d.line, "pointer": d.pointer}


def paired_records(records: list[dict[str, Any]]) -> int:
    """The header and tick records whose events F-TRACE-PAIRING pairs with the states (``events`` not null)."""
    return sum(1 for r in records if r.get("type") in ("header", "tick") and r.get("events") is not None)


def report_record(path: str, report: Any, diags: list[Any], whole: list[Any] = (), paired: int | None = None
                  ) -> dict[str, Any]:
    """The JSON record of one checked trace (``agspec check --format json``).

    ``whole``: the whole-trace problems (F-TRACE-CHECK: record count against the horizon, footer
    metrics recomputed from the records, events against states); the trace is ok only when both
    lists are empty and so is ``diags`` — what ``agspec trace validate`` reports on the same file
    (F-TRACE-VALIDATE: one judgement; the header's claims, F-TRACE-CLAIMS, among them).
    ``paired``: the records whose events were paired with the states (F-TRACE-PAIRING).
    """
    return {
        "file": path, "ok": report.ok and not whole and not diags, "ticks": report.ticks, "agents": report.agents,
        "states": report.states,
        "checks": report.checks, "records": report.records, "skipped": report.skipped,
        "total_checks": report.total_checks,
        "violations": [{"invariant": v.invariant, "tick": v.tick, "entity": v.entity, "message": v.message}
                       for v in report.violations],
        "whole_trace": [diag_record(d) for d in whole],
        **({"events_paired_records": paired} if paired is not None else {}),
        "diagnostics": [diag_record(d) for d in diags],
    }


def check_file(_context: Any, path: str) -> dict[str, Any]:
    """Check one trace; the record carries ``exit``: 0 ok, 1 violations or malformed, 2 unreadable."""
    records, diags = read_trace(path)
    if any(d.code in ("AG001", "AG002") and d.line is None for d in diags):
        return {"file": path, "ok": False, "exit": EXIT_USAGE, "diagnostics": [diag_record(d) for d in diags]}
    if any(not d.code.startswith("AG6") for d in diags):  # unreadable records: invariants cannot run
        return {"file": path, "ok": False, "exit": EXIT_INVALID, "diagnostics": [diag_record(d) for d in diags]}
    record = report_record(path, check_trace(records), diags, verify_whole(records, path, trace_diag),
                           paired_records(records))
    record["exit"] = EXIT_OK if record["ok"] else EXIT_INVALID
    return record


def expand(targets: Iterable[str]) -> list[str]:
    """Files as given; directories by every ``*.jsonl`` below them, sorted (a stable item order)."""
    out: list[str] = []
    for target in targets:
        path = Path(target)
        if path.is_dir():
            out += sorted(str(p) for p in path.rglob("*") if p.suffix in TRACE_SUFFIXES and p.is_file())
        else:
            out.append(target)
    return out


def exit_code(records: list[dict[str, Any]]) -> int:
    """The run's exit code: 3 if a trace could not be checked (its worker failed), else 2 if one was
    unreadable, else 1 if one failed, else 0."""
    codes = {r["exit"] for r in records}
    for code in (EXIT_HARNESS, EXIT_USAGE, EXIT_INVALID):
        if code in codes:
            return code
    return EXIT_OK


__all__ = ["check_file", "report_record", "paired_records", "diag_record", "expand", "exit_code"]
