"""K*(s_t) per tick for the viewer's counters, by replaying the trace on the reference (M-CAPACITY).

Traces do not carry K*.  The page shows K*_t only where it is sure of it: the trace's instance is
replayed with the trace's own applied actions, and K*_t is kept only while the reference's state is
exactly the recorded state s_t.  From the first tick where it is not (another implementation's
divergence, a foreign or damaged trace) the series stops and the page falls back to the footer's
episode mean.  Never a guess.
"""

from __future__ import annotations

from typing import Any

from agspec.interp.metrics import capacity_snapshot
from agspec.interp.snapshot import global_state
from agspec.interp.tick import Simulator
from agspec.formats.trace import dumps as canonical  # the trace's own canonical JSON (F-TRACE)

def capacity_series(header: dict[str, Any], states: list[dict[str, Any]], actions: list[dict[str, int]]) -> list[int]:
    """[K*(s_0), K*(s_1), …] for the leading ticks whose state the reference reproduces exactly."""
    try:
        sim = Simulator(header["instance"])
        sim.reset(header.get("execution_seed"))
    except Exception:  # a trace of a foreign or broken instance still renders, just without K*_t
        return []
    series: list[int] = []
    for t, recorded in enumerate(states):
        if canonical(global_state(sim.state)) != canonical(recorded):
            break
        series.append(capacity_snapshot(sim.state, sim.model, sim.decision.candidates).k_star)
        if t < len(actions):
            try:
                sim.step(actions[t])
            except Exception:  # e.g. an action the reference cannot address: stop the series here
                break
    return series
