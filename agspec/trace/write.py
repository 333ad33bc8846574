"""Trace exchange format writer (spec F-TRACE): JSON Lines, header / one record per tick / footer.

Records are written and flushed one by one, so a crash loses nothing already computed.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import IO, Any, Mapping

from agspec import SPEC_VERSION, __version__

TRACE_FORMAT = "agspec-trace/1"


def dumps(record: Mapping[str, Any]) -> str:
    """One canonical JSON line: sorted keys, no spaces, UTF-8, shortest float repr."""
    return json.dumps(record, sort_keys=True, separators=(",", ":"), ensure_ascii=False, allow_nan=False)


class TraceWriter:
    def __init__(self, path: str | Path | IO[str]):
        if hasattr(path, "write"):
            self._fh = path  # type: ignore[assignment]
            self._owned = False
        else:
            self._fh = open(path, "w", encoding="utf-8")
            self._owned = True
        self.ticks = 0

    def _write(self, record: Mapping[str, Any]) -> None:
        self._fh.write(dumps(record) + "\n")
        self._fh.flush()

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
             observations: Mapping[str, Any] | None = None) -> None:
        record: dict[str, Any] = {"type": "tick", "t": t, "actions": dict(actions), "events": events, "state": state}
        if observations is not None:
            record["observations"] = observations
        self._write(record)
        self.ticks += 1

    def footer(self, *, metrics: Mapping[str, Any], complete: bool = True) -> None:
        self._write({"type": "footer", "ticks": self.ticks, "complete": complete, "metrics": dict(metrics)})

    def close(self) -> None:
        if self._owned:
            self._fh.close()
