"""The JSON Lines conformance report (F-REPORT, ``schemas/report.schema.json``).

``ReportWriter`` writes a header, one line per case as results arrive, stale-entry lines and a
footer, flushing every line so that a crash of the harness loses nothing already decided: the file
is then valid up to its last line and simply has no footer.  ``read_report`` reads one back and
validates every line (located errors, never a traceback).
"""

from __future__ import annotations

import datetime as _dt
from pathlib import Path
from typing import Any, Mapping

from agspec import SPEC_VERSION, __version__
from agspec.formats import limits
from agspec.formats.jsonl import LineWriter, iter_lines
from agspec.formats.schemas import self_check, validate

REPORT_FORMAT = "agspec-conform-report/1"
OUTCOMES = ("pass", "fail", "error", "skip", "xfail", "xpass")


def header_record(implementation: Mapping[str, Any], options: Mapping[str, Any], selected: int, *,
                  protocol: str) -> dict[str, Any]:
    return {
        "type": "header",
        "format": REPORT_FORMAT,
        "agspec_version": __version__,
        "spec_version": SPEC_VERSION,
        "protocol": protocol,
        "started_at": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "implementation": dict(implementation),
        "options": dict(options),
        "selected": int(selected),
    }


class ReportWriter(LineWriter):
    """Writes report records one line at a time (flush per line); a no-op without a path."""

    def __init__(self, path: str | Path | None):
        self.path = Path(path) if path else None
        super().__init__(self.path, default=str)

    def write(self, record: Mapping[str, Any]) -> None:
        self_check("report", record)  # F-SCHEMAS-SELF
        super().write(record)


def read_report(path: str | Path) -> tuple[list[dict[str, Any]], list[str]]:
    """Records of a report file and its problems (``file:line: pointer: message``); empty problems = valid.

    A report must start with a header; a missing footer is reported as incomplete.
    """
    records: list[dict[str, Any]] = []
    problems: list[str] = []
    path = Path(path)
    try:  # F-LIMITS: bounded, located reading (file type and size, then each record)
        for line in iter_lines(path):
            if not line.ok:
                problems.append(line.describe(str(path)))
                continue
            rec = line.value
            for p in validate("report", rec):
                problems.append(f"{path}:{line.lineno}: {p.pointer or '/'}: {p.message} [{p.code}]")
            if isinstance(rec, dict):
                records.append(rec)
    except limits.InputError as exc:
        return [], [str(exc)]
    if not records or records[0].get("type") != "header":
        problems.append(f"{path}:1: the report does not start with a header")
    if not records or records[-1].get("type") != "footer":
        problems.append(f"{path}: incomplete: no footer (the run was interrupted)")
    return records, problems


__all__ = ["ReportWriter", "read_report", "header_record", "REPORT_FORMAT", "OUTCOMES"]
