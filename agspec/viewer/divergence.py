"""The two sides of a conformance divergence (F-REPORT, F-REPRO) for ``agspec render --diff``.

A report line records the first difference (tick, part, JSON Pointer, expected and actual values,
further differing pointers in ``more``) and the path of a reproducer: the instance, execution seed
and every joint action sent up to the failing tick, and the failing reply's own state and events
(``observed``), not the earlier ones.  The expected side is rebuilt from the reproducer,
deterministically (D-DETERMINISM):

* expected — the reference interpreter re-run with the reproducer's actions;
* observed — what the implementation sent: by default the states of the report's run (equal to the
  reference's up to the failing reply, which the report records whole in ``failure.observed``); with
  ``replay``, the implementation itself re-run with the same actions (its command is the
  reproducer's ``impl``, or the one given).  A simulator that sends no state has no observed side
  to draw: only the expected one is shown, with the differing pointers.
"""

from __future__ import annotations

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
                          "with format agspec-conform-report/1 (written by `agspec conform -o FILE`)")
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


def _differences(expected: Mapping[str, Any], actual: Mapping[str, Any], t: int, differences: dict[str, list[str]],
                 values: dict[str, list[str]]) -> None:
    """Every differing pointer of state ``t`` (as the report writes its paths, F-REPORT ``path``)."""
    ptrs = []
    for ptr, e, a in iter_differences(expected, actual):
        ptr = "/state" + ptr
        ptrs.append(ptr)
        if len(ptrs) <= 40:
            values[f"{t}|{ptr}"] = [show(e, 120), show(a, 120)]
        if len(ptrs) >= MAX_POINTERS:
            break
    if ptrs:
        differences[str(t)] = ptrs


def _implementation(records: list[dict[str, Any]], spec: str | None) -> dict[str, Any]:
    """The implementation as its start reply named it (report header), for the observed side's labels."""
    described = (records[0].get("implementation") or {}).get("implementation")
    if isinstance(described, dict) and described.get("name"):
        return {k: described[k] for k in ("name", "version", "language") if k in described}
    return {"name": spec or "implementation", "version": ""}


def _observed(expected: TraceData, failure: Mapping[str, Any], focus: int, implementation: dict[str, Any],
              capabilities: Mapping[str, Any]) -> TraceData | None:
    """The implementation's side as the report recorded it: the states it sent up to the failing
    reply — those before it were compared equal to the reference's (their behavioural fields,
    F-TRACE-STATE) — and the state and events of the failing reply itself (``failure.observed``).
    None when the report holds no observed state (a simulator without ``privileged_state``)."""
    observed = failure.get("observed") or {}
    state = observed.get("state")
    if not isinstance(state, dict) or not 0 <= focus < len(expected.states):
        return None
    own_events = bool(capabilities.get("events"))
    states = list(expected.states[:focus]) + [state]
    events = [list(e) if own_events else [] for e in expected.events[:focus]]
    events.append(list(observed.get("events") or []))
    header = {**expected.header, "implementation": implementation}
    return TraceData(header, states, events, list(expected.actions[:focus]), None, None)


def build_diff(report: Path, *, case_id: str | None = None, replay: bool = False, impl: str | None = None,
               timeout: float = 5.0, keyframe: int = 25) -> dict[str, Any]:
    """The diff document: the expected and the observed side encoded, the differing pointers per state
    index, the failure.  The observed side is what the implementation sent (``failure.observed`` of
    the report, or, with ``replay``, the implementation re-run from the reproducer); never the
    reference's states with a difference patched in."""

    records = read_report(report)
    case = pick_case(records, case_id, report)
    failure = dict(case["failure"])
    repro = load_reproducer(case, report)
    expected = _run("reference", repro, timeout)
    focus = int(failure.get("tick", -1)) + 1  # the reply to step t carries the state of epoch t + 1
    where = failure.get("where")
    spec = impl or repro.get("impl") or ((records[0].get("implementation") or {}).get("spec"))
    implementation = _implementation(records, spec)
    capabilities = (records[0].get("implementation") or {}).get("capabilities") or {}
    differences: dict[str, list[str]] = {}
    values: dict[str, list[str]] = {}
    actual: TraceData | None
    if replay or impl:
        if not spec:
            raise ReportError(f"{report}: no implementation to replay (give --impl)", usage=True)
        actual = _run(spec, repro, timeout)
        source = f"observed: the implementation re-run from the reproducer with {spec}"
        for t in range(min(len(expected.states), len(actual.states))):
            _differences(expected.states[t], actual.states[t], t, differences, values)
    else:
        actual = _observed(expected, failure, focus, implementation, capabilities)
        if actual is not None:
            source = (f"observed: the states {spec or 'the implementation'} sent (those before state {focus} "
                      f"matched the reference's; state {focus} is its failing reply, as the report recorded it)")
            _differences(expected.states[focus], actual.states[focus], focus, differences, values)
        else:
            source = ("the report holds no state of the implementation (it does not declare privileged_state, or "
                      "the report predates `failure.observed`): only the expected side is drawn; --replay re-runs "
                      "the implementation")
    path = failure.get("path") or failure.get("pointer") or f"/{where}"
    if where != "state" and path not in differences.get(str(focus), []):
        differences.setdefault(str(focus), []).insert(0, path)
        values[f"{focus}|{path}"] = [show(failure.get("expected"), 120), show(failure.get("actual"), 120)]
    exp_doc = encode(expected, keyframe=keyframe, title="expected (reference)")
    act_doc = encode(actual, keyframe=keyframe, title=f"observed ({spec or 'implementation'})") if actual else None
    title = f"divergence \u00b7 {case.get('id')} \u00b7 {case.get('title') or ''}".strip(" \u00b7")
    ref = expected.header.get("implementation") or {}
    return {"mode": "diff", "format": DIFF_FORMAT, "title": title, "case_id": case.get("id"),
            "failure": {k: failure.get(k) for k in ("type", "message", "tick", "reply", "where", "pointer", "path",
                                                    "ids", "reproducer", "known_divergence")},
            "focus": focus, "differences": differences, "values": values, "actual_source": source,
            "labels": {"expected": f"reference interpreter ({ref.get('name', 'agspec')} {ref.get('version', '')})".strip(),
                       "actual": f"{implementation.get('name', '')} {implementation.get('version', '')}".strip()
                       + (f" \u2014 {spec}" if spec else "")},
            "expected": exp_doc, "actual": act_doc}


__all__ = ["build_diff", "ReportError", "DIFF_FORMAT"]
