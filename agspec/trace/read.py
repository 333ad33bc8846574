"""Reading and validating a trace exchange file (F-TRACE) with located errors.

``read_trace(path)`` returns ``(records, diagnostics)``: the records that parsed, and one
:class:`~agspec.formats.diagnostics.Diagnostic` per problem, located by line number and JSON Pointer into
the record — never a traceback.  Checks, in order:

* the file can be read (AG001/AG002) and every non-blank line is a JSON object (AG003);
* every record satisfies ``schemas/trace.schema.json`` (AG2xx, with the pointer of the offending
  field; at most ``max_schema_errors`` are reported);
* the structure of the trace (AG6xx, F-CODES): a header first (AG601), tick records with
  consecutive epochs whose state is at ``t + 1`` (AG602), nothing after the footer and a single
  header (AG603), a footer (AG604: the trace is truncated), a footer that agrees with the records
  and declares the execution complete (AG605), at least one record (AG606);
* the header's claims (F-TRACE-CLAIMS, :mod:`agspec.trace.claims`): a fingerprint that is the
  instance's (AG607), a valid instance (AG5xx), the instance it names (AG610), its own fields
  (AG611), the initial state and reset events of its instance (AG612).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from agspec.formats import limits
from agspec.formats.diagnostics import Diagnostic
from agspec.formats.jsonl import iter_lines
from agspec.formats.schemas import validate
from agspec.formats.trace import values_of
from agspec.trace.claims import CLAIM_CODES, check_claims

TRACE_CODES = {
    "AG601": "the trace does not start with a header record",
    "AG602": "tick records out of order (epochs not consecutive, or the state is not at t + 1)",
    "AG603": "a record after the footer, or a second header",
    "AG604": "the trace is truncated: no footer",
    "AG605": "the footer disagrees with the trace (tick count) or declares the execution incomplete",
    "AG606": "the trace is empty",
    "AG607": "the header fingerprint is not the fingerprint of its instance",
    "AG608": "the trace stops before its horizon without terminating, or runs past it (agspec check)",
    "AG609": "an event and the states disagree: a change without its event, or an event without its change "
             "(agspec check, F-TRACE-PAIRING)",
    **CLAIM_CODES,
}


def _diag(code: str, message: str, file: str, line: int | None, pointer: str | None = None,
          col: int | None = None, hint: str | None = None) -> Diagnostic:
    text = f"{pointer}: {message}" if pointer else message
    return Diagnostic(code, text, file=file, line=line, col=col, hint=hint, pointer=pointer)


def read_trace(path: str | Path, *, schema: bool = True, max_schema_errors: int = 20, claims: bool = True
               ) -> tuple[list[dict[str, Any]], list[Diagnostic]]:
    """Read ``path``; returns the parsed records and the diagnostics (empty: a valid, complete trace).

    ``claims``: check the header's claims (F-TRACE-CLAIMS); only a reader that shows a trace without
    judging it (the viewer) leaves them out."""
    path = Path(path)
    file = str(path)
    diags: list[Diagnostic] = []
    records: list[dict[str, Any]] = []
    lines: list[int] = []
    schema_errors = 0
    try:  # F-LIMITS: file type and size first, then each record within the record limits
        for line in iter_lines(path):
            if not line.ok:
                diags.append(line.diagnostic(file))
                continue
            rec = line.value
            if not isinstance(rec, dict):
                diags.append(_diag("AG003", "a trace record must be a JSON object", file, line.lineno, col=1))
                continue
            if schema and schema_errors < max_schema_errors:
                for p in validate("trace", rec, limit=3):
                    diags.append(_diag(p.code, p.message, file, line.lineno, pointer=p.pointer or "/"))
                    schema_errors += 1
            records.append(values_of(rec))  # F-VALUES: what the invariants and the whole-trace checks read
            lines.append(line.lineno)
    except limits.InputError as exc:  # missing, not a regular file, over the size limit
        return [], [exc.diagnostic()]
    except OSError as exc:  # a read error after the file was opened
        diags.append(_diag("AG002", f"cannot read {file}: {exc.strerror or exc}", file, None))
    diags += _structure(records, lines, file, claims)
    # by line, except that a limit (F-LIMITS, AG006) comes first: the file was not read past it
    diags.sort(key=lambda d: (d.code != "AG006", d.line or 0))
    return records, diags


def _structure(records: list[dict[str, Any]], lines: list[int], file: str, claims: bool = True) -> list[Diagnostic]:
    """F-TRACE structure checks (AG601-AG606) and the header's claims (F-TRACE-CLAIMS)."""
    out: list[Diagnostic] = []
    if not records:
        return [_diag("AG606", "the trace is empty: no records", file, None,
                      hint="a trace is a header, one tick record per transition and a footer")]
    if records[0].get("type") != "header":
        out.append(_diag("AG601", f"the first record is a {records[0].get('type')!r} record, not the header",
                         file, lines[0], pointer="/type"))
    header = records[0] if records[0].get("type") == "header" else None
    if header is not None and claims:  # F-TRACE-CLAIMS: AG607, the instance's AG5xx, AG610-AG612
        out += check_claims(header, file, lines[0], _diag)
    expected_t = None
    if header is not None and isinstance(header.get("state"), dict) and isinstance(header["state"].get("t"), int):
        expected_t = header["state"]["t"]
    footer_at = None
    ticks = 0
    for rec, lineno in zip(records[1:], lines[1:]):
        kind = rec.get("type")
        if footer_at is not None:
            out.append(_diag("AG603", f"a {kind!r} record follows the footer (line {footer_at})", file, lineno,
                             pointer="/type"))
            continue
        if kind == "header":
            out.append(_diag("AG603", "a second header record", file, lineno, pointer="/type"))
        elif kind == "tick":
            ticks += 1
            t = rec.get("t")
            if isinstance(t, int) and expected_t is not None and t != expected_t:
                out.append(_diag("AG602", f"tick record t={t} follows epoch {expected_t - 1}: expected t={expected_t}",
                                 file, lineno, pointer="/t"))
            state_t = (rec.get("state") or {}).get("t") if isinstance(rec.get("state"), dict) else None
            if isinstance(t, int) and isinstance(state_t, int) and state_t != t + 1:
                out.append(_diag("AG602", f"the state after tick {t} is at t={state_t}, expected {t + 1}", file, lineno,
                                 pointer="/state/t"))
            expected_t = (t + 1) if isinstance(t, int) else None
        elif kind == "footer":
            footer_at = lineno
            if rec.get("ticks") != ticks:
                out.append(_diag("AG605", f"the footer declares {rec.get('ticks')} ticks, the trace has {ticks}", file,
                                 lineno, pointer="/ticks"))
            if rec.get("complete") is False:
                out.append(_diag("AG605", "the footer declares the execution incomplete", file, lineno,
                                 pointer="/complete"))
    if footer_at is None and header is not None:
        last = lines[-1] if lines else None
        out.append(_diag("AG604", f"the trace is truncated: no footer after {ticks} tick record(s)", file, last,
                         hint="the writer stopped before the end of the run; a checker must not trust it"))
    return out


__all__ = ["read_trace", "TRACE_CODES"]
