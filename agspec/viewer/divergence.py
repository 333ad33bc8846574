"""The two sides of a conformance divergence (F-REPORT, F-REPRO) for ``agspec render --diff``.

A report line records the first difference (tick, part, JSON Pointer, expected and actual values,
further differing pointers in ``more``) and the path of a reproducer: the instance, execution seed
and every joint action sent up to the failing tick. It does not hold whole states, so both sides
are rebuilt from the reproducer, deterministically (D-DETERMINISM):

* expected — the reference interpreter re-run with the reproducer's actions;
* actual — with ``replay``, the implementation itself re-run with the same actions (its command is
  the reproducer's ``impl``, or the one given); otherwise the expected states with the report's
  recorded difference applied at the diverging state, the other differing pointers flagged without
  values (the report does not carry them).
"""

from __future__ import annotations

import copy
import io
from pathlib import Path
from typing import Any, Mapping

from agspec.formats import limits
from agspec.formats.jsonl import iter_lines
from agspec.formats.pointer import iter_differences, show
from agspec.formats.trace import TraceWriter, read_records
from agspec.viewer.encode import TraceData, encode, trace_data
from agspec.viewer.record import record

DIFF_FORMAT = "agspec-replay-diff/1"
MAX_POINTERS = 200  # differing pointers kept per tick


class ReportError(ValueError):
    """The report has no usable divergence (exit 1) — or cannot be read (``usage`` True: exit 2)."""

    def __init__(self, message: str, usage: bool = False):
        super().__init__(message)
        self.usage = usage


def read_report(path: Path) -> list[dict[str, Any]]:
    records = []
    try:  # F-LIMITS: bounded, located reading; a missing or special file is a usage error
        for line in iter_lines(path):
            if not line.ok:
                raise ReportError(line.describe(str(path)))
            if not isinstance(line.value, dict):
                raise ReportError(f"{path}:{line.lineno}: a report record must be a JSON object")
            records.append(line.value)
    except limits.InputError as exc:
        raise ReportError(str(exc), usage=exc.exit_code == limits.EXIT_USAGE) from None
    except OSError as exc:
        raise ReportError(f"{path}: cannot read: {exc}", usage=True) from None
    if not records or records[0].get("type") != "header" or not str(records[0].get("format", "")).startswith(
            "agspec-conform-report/"):
        raise ReportError(f"{path}:1: not a conformance report (F-REPORT): the first record must be its header "
                          "with format agspec-conform-report/1 (written by `agspec conform --report FILE`)")
    return records


def pick_case(records: list[dict[str, Any]], case_id: str | None, path: Path) -> dict[str, Any]:
    """The failing case to show: ``case_id``, else the first case whose failure is a divergence."""
    cases = [r for r in records if r.get("type") == "case"]
    if case_id is not None:
        for c in cases:
            if c.get("id") == case_id:
                if (c.get("failure") or {}).get("type") != "divergence":
                    raise ReportError(f"{path}: case {case_id} has outcome {c.get('outcome')!r} and no divergence "
                                      "to show")
                return c
        raise ReportError(f"{path}: no case {case_id!r} in the report")
    for c in cases:
        if (c.get("failure") or {}).get("type") == "divergence":
            return c
    kinds = sorted({(c.get("failure") or {}).get("type") for c in cases if c.get("failure")} - {None})
    raise ReportError(f"{path}: the report has no divergence to show ({len(cases)} case(s)"
                      + (f"; failures of type {', '.join(kinds)}" if kinds else ", none failing") + ")")


def load_reproducer(case: Mapping[str, Any], report: Path) -> dict[str, Any]:
    ref = (case.get("failure") or {}).get("reproducer")
    if not ref:
        raise ReportError(f"{report}: case {case.get('id')} has no reproducer (run conform with --repro-dir)")
    candidates = [Path(ref)] if Path(ref).is_absolute() else [Path.cwd() / ref, report.parent / ref]
    for p in candidates:
        if p.is_file():
            try:
                data = limits.load_json(p)
            except limits.InputError as exc:
                raise ReportError(f"cannot read the reproducer: {exc}", usage=exc.exit_code == limits.EXIT_USAGE
                                  ) from None
            if not isinstance(data, dict) or not isinstance(data.get("actions"), list) or not isinstance(
                    data.get("instance"), dict):
                raise ReportError(f"{p}: not a reproducer (F-REPRO: instance, execution_seed, actions)")
            return data
    raise ReportError(f"{report}: the reproducer {ref} of case {case.get('id')} is not found (looked in "
                      f"{', '.join(str(c.parent) for c in candidates)})", usage=True)


def _run(impl: str, repro: Mapping[str, Any], timeout: float) -> TraceData:
    buf = io.StringIO()
    record(impl, repro["instance"], TraceWriter(buf), ticks=len(repro["actions"]),
           execution_seed=repro.get("execution_seed"), actions=repro["actions"], observations=False, timeout=timeout)
    return trace_data(read_records(buf.getvalue().splitlines()), name=impl)


def _pointer_set(pointer: str, state: Any, value: Any) -> Any:
    """Set the value at an RFC 6901 pointer inside ``state`` (a copy), creating nothing."""

    out = copy.deepcopy(state)
    tokens = [t.replace("~1", "/").replace("~0", "~") for t in pointer.split("/")[1:]]
    if not tokens:
        return value
    parent = out
    for tok in tokens[:-1]:
        parent = parent[int(tok)] if isinstance(parent, list) else parent[tok]
    last = tokens[-1]
    if isinstance(parent, list):
        idx = int(last)
        if idx < len(parent):
            parent[idx] = value
        else:
            parent.append(value)
    else:
        parent[last] = value
    return out


def build_diff(report: Path, *, case_id: str | None = None, replay: bool = False, impl: str | None = None,
               timeout: float = 5.0, keyframe: int = 25) -> dict[str, Any]:
    """The diff document: both sides encoded, the differing pointers per state index, the failure."""

    records = read_report(report)
    case = pick_case(records, case_id, report)
    failure = dict(case["failure"])
    repro = load_reproducer(case, report)
    expected = _run("reference", repro, timeout)
    focus = int(failure.get("tick", -1)) + 1  # after tick t the compared state is s_{t+1}
    where = failure.get("where")
    spec = impl or repro.get("impl") or ((records[0].get("implementation") or {}).get("spec"))
    differences: dict[str, list[str]] = {}
    values: dict[str, list[str]] = {}
    if replay or impl:
        if not spec:
            raise ReportError(f"{report}: no implementation to replay (give --impl)", usage=True)
        actual = _run(spec, repro, timeout)
        source = f"actual states re-run from the reproducer with {spec}"
        n = min(len(expected.states), len(actual.states))
        for t in range(n):
            ptrs = []
            for ptr, e, a in iter_differences(expected.states[t], actual.states[t]):
                ptr = "/state" + ptr  # as the report writes its paths (F-REPORT `path`)
                ptrs.append(ptr)
                if len(ptrs) <= 40:
                    values[f"{t}|{ptr}"] = [show(e, 120), show(a, 120)]
                if len(ptrs) >= MAX_POINTERS:
                    break
            if ptrs:
                differences[str(t)] = ptrs
    else:
        states = list(expected.states)
        pointer = failure.get("pointer") or ""
        source = "actual = expected with the report's recorded difference (re-run with --replay for full states)"
        if where == "state" and 0 <= focus < len(states) and not failure.get("actual_absent"):
            try:
                states[focus] = _pointer_set(pointer, states[focus], failure.get("actual"))
            except (KeyError, IndexError, ValueError, TypeError):
                pass
        actual = TraceData(expected.header, states, expected.events, expected.actions, None, expected.footer)
        path = failure.get("path") or pointer
        ptrs = [path] + [p if p.startswith("/" + str(where)) else f"/{where}{p}" for p in failure.get("more") or []]
        differences[str(focus)] = ptrs
        values[f"{focus}|{path}"] = [show(failure.get("expected"), 120), show(failure.get("actual"), 120)]
    if where != "state" and str(focus) not in differences:
        differences[str(focus)] = [failure.get("path") or failure.get("pointer") or f"/{where}"]
    exp_doc = encode(expected, keyframe=keyframe, title="expected (reference)")
    act_doc = encode(actual, keyframe=keyframe, title=f"actual ({spec or 'implementation'})")
    title = f"divergence · {case.get('id')} · {case.get('title') or ''}".strip(" ·")
    return {"mode": "diff", "format": DIFF_FORMAT, "title": title, "case_id": case.get("id"),
            "failure": {k: failure.get(k) for k in ("type", "message", "tick", "where", "pointer", "path", "ids",
                                                    "reproducer")},
            "focus": focus, "differences": differences, "values": values, "actual_source": source,
            "labels": {"expected": "reference interpreter", "actual": spec or "implementation"},
            "expected": exp_doc, "actual": act_doc}


__all__ = ["build_diff", "ReportError", "DIFF_FORMAT"]
