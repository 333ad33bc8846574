"""The trace exchange format (spec F-TRACE): JSON Lines, header / one record per tick / footer.

:class:`TraceWriter` writes and flushes the records one by one, so a crash loses nothing already
computed; :func:`read_records` streams them back (:func:`agspec.formats.jsonl.iter_lines`).  The
structure checks with located diagnostics (F-TRACE-VALIDATE) are :mod:`agspec.trace.read`.
"""

from __future__ import annotations

from pathlib import Path
from typing import IO, Any, Iterable, Mapping

from agspec import SPEC_VERSION, __version__
from agspec.formats import shape
from agspec.formats.jsonl import LineWriter, dumps, read_values
from agspec.formats.schemas import self_check

TRACE_FORMAT = "agspec-trace/1"


def read_records(source: str | Path | Iterable[str | bytes]) -> list[dict[str, Any]]:
    """The records of a trace (a path or its lines); an unparsable line ends the trace (it is then
    reported as truncated by the checks that need a footer).  F-VALUES: integral numbers where the
    schema requires integers are read as integers (:func:`values_of`)."""
    return [values_of(rec) for rec in read_values(source)]


def values_of(record: Any) -> Any:
    """F-VALUES: ``record`` with every integral number (within ±(2^53 − 1)) at a position
    ``schemas/trace.schema.json`` types integer made an integer, in place; what else it holds is
    the schema validation's to judge (F-TRACE-VALIDATE)."""
    shape.conform(record, "trace")
    return record


class TraceWriter:
    def __init__(self, path: str | Path | IO[str]):
        self._out = LineWriter(path)
        self.ticks = 0

    def _write(self, record: Mapping[str, Any]) -> None:
        # F-SCHEMAS-SELF: the header, the footer and the first tick records against the whole schema;
        # the other tick records (hundreds per trace, alike) against its shape
        if record.get("type") != "tick" or self.ticks < 3:
            self_check("trace", record)
        else:
            shape.self_check_shape("trace", record)
        self._out.write(record)

    def header(self, *, instance: Mapping[str, Any], fingerprint: str, execution_seed: int | None,
               controller: Mapping[str, Any] | None, initial_state: Mapping[str, Any],
               initial_events: list, implementation: Mapping[str, Any] | None = None,
               horizon: int | None = None) -> None:
        """``horizon``: the epochs the run is to execute (F-TRACE; ``agspec check`` counts the records)."""
        self._write(
            {
                "type": "header",
                "format": TRACE_FORMAT,
                "spec_version": SPEC_VERSION,
                "implementation": dict(implementation or {"name": "agspec-reference", "version": __version__}),
                "instance": instance,
                "fingerprint": fingerprint,
                "execution_seed": execution_seed,
                "controller": dict(controller or {}),
                "state": initial_state,
                "events": initial_events,
                **({"horizon": int(horizon)} if horizon is not None else {}),
            }
        )

    def tick(self, *, t: int, actions: Mapping[str, int], events: list, state: Mapping[str, Any],
             observations: Mapping[str, Any] | None = None, chosen: Mapping[str, int] | None = None) -> None:
        """``chosen``: the submitted actions that R-ACTION-VALIDATION replaced (F-TRACE; written when not empty)."""
        record: dict[str, Any] = {"type": "tick", "t": t, "actions": dict(actions), "events": events, "state": state}
        if chosen:
            record["chosen"] = dict(chosen)
        if observations is not None:
            record["observations"] = observations
        self._write(record)
        self.ticks += 1

    def footer(self, *, metrics: Mapping[str, Any], complete: bool = True) -> None:
        self._write({"type": "footer", "ticks": self.ticks, "complete": complete, "metrics": dict(metrics)})

    def close(self) -> None:
        self._out.close()


__all__ = ["DIAGNOSTIC_FIELDS", "TRACE_FORMAT", "TraceWriter", "behavioural", "dumps", "is_diagnostic", "read_records", "values_of"]


# F-TRACE-STATE: the diagnostic fields of the canonical state — bookkeeping no observer sees, compared
# only when the implementation declares the `diagnostic_state` capability; every other field is behavioural.
DIAGNOSTIC_FIELDS: dict[str, frozenset[str]] = {
    "robots": frozenset({"busy_until", "switch_lock", "ee", "q"}),
    "activities": frozenset({"approach", "process", "retreat"}),
}


def behavioural(state: Any) -> Any:
    """``state`` without its diagnostic fields (a shallow copy; the input is not modified)."""
    if not isinstance(state, dict):
        return state
    out = dict(state)
    robots, acts = state.get("robots"), state.get("activities")
    if isinstance(robots, dict):
        drop = DIAGNOSTIC_FIELDS["robots"]
        out["robots"] = {k: {f: v for f, v in r.items() if f not in drop} if isinstance(r, dict) else r
                         for k, r in robots.items()}
    if isinstance(acts, list):
        drop = DIAGNOSTIC_FIELDS["activities"]
        out["activities"] = [{f: v for f, v in a.items() if f not in drop} if isinstance(a, dict) else a for a in acts]
    return out


def is_diagnostic(pointer: str) -> bool:
    """Whether a JSON Pointer into the state names a diagnostic field (or a part of one)."""
    tokens = pointer.split("/")[1:]
    return len(tokens) >= 3 and tokens[2] in DIAGNOSTIC_FIELDS.get(tokens[0], frozenset())
