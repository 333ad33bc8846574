"""Whole-trace verification for ``agspec check`` (F-TRACE-CHECK): the records against the header and footer.

Tick invariants (chapter 8) judge each transition; this module judges the trace as a whole:

* **record count** — a trace has one tick record per epoch up to its horizon (the header's
  ``horizon``, else the instance's evaluation horizon) unless its last state terminates the
  execution (R-TERMINATION, batch mode); a trace cut short, even with a consistent footer, is AG608;
* **footer metrics** — every footer metric that the records determine is recomputed from the
  states and events (:func:`recompute`) and compared (floats to 1e-9 relative); a footer that
  disagrees is AG605, and names the known divergence of the original release it is, if any
  (F-CONFORM-KNOWN, :func:`known_metric`).  Metrics that need the reference's internal samples
  (capacity, geometry, occupancy) are not recomputed.  Where both the states and the events
  determine a metric (``handoffs``, ``admissions``), the footer must agree with both;
* **events and states** — every state change has its event in the same record and every event its
  change (F-TRACE-PAIRING, :mod:`agspec.trace.pairing`); a disagreement is AG609.
"""

from __future__ import annotations

import math
from typing import Any, Callable, Mapping, Sequence

from agspec.formats.diagnostics import Diagnostic
from agspec.formats.divergences import by_scope
from agspec.interp.metrics import percentile
from agspec.trace.pairing import pair_records

Json = dict[str, Any]


def _ratio(a: float, b: float) -> float | None:
    return a / b if b else None


def _count(events: Sequence[Json], kind: str, **where: Any) -> int:
    return sum(1 for e in events if e.get("type") == kind and all(e.get(k) == v for k, v in where.items()))


def recompute(records: Sequence[Json]) -> dict[str, Any]:
    """The footer metrics (M-*) that the header and tick records determine, recomputed from them."""
    header = records[0]
    ticks = [r for r in records[1:] if r.get("type") == "tick"]
    final = (ticks[-1] if ticks else header)["state"]
    events = [e for r in [header] + ticks for e in (r.get("events") or [])]
    t_end = int(final["t"])
    delivered, released, lost = int(final["delivered"]), int(final["released"]), int(final["lost_releases"])
    opportunities = released + lost
    products = final.get("products") or []
    flow = [p["delivered_at"] - p["released_at"] for p in products if p.get("delivered_at") is not None]
    rmft = [(p["delivered_at"] if p.get("delivered_at") is not None else t_end) - p["released_at"] for p in products]
    ev = header["instance"]["scenario"]["evaluation"]
    batch = ev.get("mode") == "batch"
    size = ev.get("batch_size") or 0
    batch_done = batch and delivered >= size and released >= size
    admitted = [e for e in events if e.get("type") == "admitted"]
    admissions = len(admitted)
    handoffs = _count(events, "handoff_completed")
    wip = [int(r["state"]["wip"]) for r in ticks]
    return {
        "ticks": t_end,
        "delivered": delivered,
        "released": released,
        "lost_releases": lost,
        "release_opportunities": opportunities,
        "throughput": delivered / max(1, t_end),
        "completion_rate": _ratio(delivered, released),
        "release_acceptance": _ratio(released, opportunities),
        "demand_fulfillment": _ratio(delivered, opportunities),
        "unfinished_count": released - delivered,
        "mean_wip": sum(wip) / max(1, len(wip)),
        "mean_flow_time": sum(flow) / len(flow) if flow else None,
        "restricted_mean_flow_time": sum(rmft) / len(rmft) if rmft else None,
        "flow_time_p50": percentile(flow, 0.5),
        "flow_time_p90": percentile(flow, 0.9),
        "makespan": (max(p["delivered_at"] for p in products) - min(p["released_at"] for p in products))
        if batch_done else None,
        "timed_out": batch and not batch_done,
        "admissions": admissions,
        "admission_latency": sum(e.get("latency", 0) for e in admitted) / admissions if admissions else None,
        "handoffs": handoffs,
        "handoffs_per_delivered": handoffs / max(1, delivered),
        "invalid_actions": _count(events, "action_coerced"),
        "lost_releases_raw_material": _count(events, "release_lost", reason="raw_material"),
    }


def recompute_from_states(records: Sequence[Json]) -> dict[str, Any]:
    """The footer metrics that the states alone determine too, recomputed from the states only:
    ``handoffs`` (every change of an item's holder is a handoff completion, INV-CONSERVATION) and
    ``admissions`` (every operation admitted is in progress or completed in the last state)."""
    states = [r["state"] for r in records if r.get("type") in ("header", "tick")]
    moves = sum(1 for a, b in zip(states, states[1:]) for item, robot in b["items"].items()
                if item in a["items"] and a["items"][item] != robot)
    final = states[-1]
    admitted = sum(len(p["completed"]) + len(p["in_progress"]) for p in final.get("products") or [])
    return {"handoffs": moves, "admissions": admitted,
            "handoffs_per_delivered": moves / max(1, int(final["delivered"]))}


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, bool) or isinstance(b, bool) or a is None or b is None:
        return a is b or a == b and type(a) is type(b)
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        return math.isclose(a, b, rel_tol=1e-9, abs_tol=1e-12)
    return a == b


def horizon_of(header: Mapping[str, Any]) -> int | None:
    """The number of epochs the run was to execute: the header's ``horizon``, else the instance's."""
    if isinstance(header.get("horizon"), int):
        return int(header["horizon"])
    try:
        ev = header["instance"]["scenario"]["evaluation"]
        return int(ev.get("horizon", ev.get("timeout")))
    except (KeyError, TypeError, ValueError):
        return None


def terminated(header: Mapping[str, Any], state: Mapping[str, Any]) -> bool:
    """R-TERMINATION (batch mode): released >= Z and delivered >= Z."""
    ev = header["instance"]["scenario"]["evaluation"]
    size = ev.get("batch_size") or 0
    return ev.get("mode") == "batch" and state["released"] >= size and state["delivered"] >= size


def known_metric(header: Mapping[str, Any], metric: str, recomputed: Any) -> str | None:
    """F-CONFORM-KNOWN: the DIV id whose ``metrics`` signature a wrong footer metric matches: the
    metric, the evaluation mode, and the value the paper gives (the recomputed one) are the signature's."""
    mode = ((header.get("instance") or {}).get("scenario") or {}).get("evaluation", {}).get("mode")
    for ident, sig in by_scope("metrics").items():
        if (sig["metric"] == metric and sig.get("evaluation_mode", mode) == mode
                and _same(recomputed, sig["reference_value"])):
            return ident
    return None


def verify(records: Sequence[Json], file: str, diag: Callable[..., Diagnostic],
           lines: Sequence[int] | None = None) -> list[Diagnostic]:
    """AG608 (the trace stops before its horizon), AG605 (a footer metric the records contradict) and
    AG609 (events and states that disagree, F-TRACE-PAIRING).

    ``lines``: the line number of each record (default: one record per line).
    """
    return _count_and_footer(records, file, diag, lines) + pairing(records, file, diag, lines)


def _count_and_footer(records: Sequence[Json], file: str, diag: Callable[..., Diagnostic],
                      lines: Sequence[int] | None) -> list[Diagnostic]:
    out: list[Diagnostic] = []
    lines = list(lines) if lines is not None else list(range(1, len(records) + 1))
    if not records or records[0].get("type") != "header":
        return out
    header = records[0]
    ticks = [r for r in records[1:] if r.get("type") == "tick"]
    footers = [(r, n) for r, n in zip(records, lines) if r.get("type") == "footer"]
    try:
        horizon = horizon_of(header)
        final = (ticks[-1] if ticks else header)["state"]
        if horizon is not None and len(ticks) < horizon and not terminated(header, final):
            where = footers[0][1] if footers else (lines[-1] if lines else None)
            out.append(diag("AG608", f"the trace stops after {len(ticks)} tick record(s), before its horizon "
                                     f"{horizon}, and its last state does not terminate the execution", file, where,
                            hint="a complete trace has one tick record per epoch up to the header's `horizon`"))
        if horizon is not None and len(ticks) > horizon:
            out.append(diag("AG608", f"the trace has {len(ticks)} tick records, more than its horizon {horizon}",
                            file, lines[-1] if lines else None))
        if not footers or not isinstance(footers[0][0].get("metrics"), dict):
            return out
        footer, line = footers[0]
        for key, want in recompute(records).items():
            if key in footer["metrics"] and not _same(footer["metrics"][key], want):
                named = known_metric(header, key, want)
                out.append(diag("AG605", f"the footer declares {key} = {footer['metrics'][key]!r}, the records "
                                         f"give {want!r}" + (f" \u2014 the known divergence {named} of the original "
                                                             "release (spec/10-divergences.md)" if named else ""),
                                file, line, pointer=f"/metrics/{key}"))
        for key, want in recompute_from_states(records).items():
            if key in footer["metrics"] and not _same(footer["metrics"][key], want):
                out.append(diag("AG605", f"the footer declares {key} = {footer['metrics'][key]!r}, the states "
                                         f"give {want!r}", file, line, pointer=f"/metrics/{key}"))
    except (KeyError, TypeError, ValueError, AttributeError, IndexError):
        pass  # a record without the fields: the schema diagnostics already say so
    return out


def pairing(records: Sequence[Json], file: str, diag: Callable[..., Diagnostic],
            lines: Sequence[int] | None = None, limit: int = 100) -> list[Diagnostic]:
    """AG609: the events and states that disagree (F-TRACE-PAIRING), at most ``limit`` of them."""
    lines = list(lines) if lines is not None else list(range(1, len(records) + 1))
    problems, _ = pair_records(records)
    out = [diag("AG609", p.message, file, lines[p.record] if p.record < len(lines) else None, pointer=p.pointer)
           for p in problems[:limit]]
    if len(problems) > limit:
        out.append(diag("AG609", f"… and {len(problems) - limit} more disagreements of events and states", file,
                        None))
    return out


__all__ = ["recompute", "recompute_from_states", "verify", "pairing", "horizon_of", "terminated"]
