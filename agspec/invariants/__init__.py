"""The eleven formal invariants of AssemblyGrid v1 as trace predicates (spec chapter 08).

Each invariant is ONE function named after its spec ID (``inv_conservation`` is INV-CONSERVATION,
and so on) with the signature ``(ctx, prev, rec) -> list[Violation]``:

* ``ctx``  — a :class:`Context`: the instance IR, what is derived from it once (recipes, grid
  relations, capacities) and the little memory some invariants need across records
  (INV-LIFETIME: activity id -> fixed attributes first seen; INV-CONSERVATION: items that
  disappeared);
* ``prev`` — the previous record (the header or a tick record), or ``None`` for the header;
* ``rec``  — the record checked: the header (state ``s_0``) or a tick record
  ``{t, actions, events, state: s_{t+1}, observations?: I_t}`` (F-TRACE).

State clauses are evaluated on ``rec["state"]``; transition clauses on the pair
``(prev["state"], rec)``; observation and mask clauses on ``rec["observations"]`` against the
pre-action state ``prev["state"]`` (O-OBSERVATION: observations of epoch ``t`` are built from
``s_t``).

The checker reads traces only — JSON produced by any implementation — and never the reference
interpreter: nothing here imports :mod:`agspec.interp` (STYLE §2, INV-TRACE).  It may read
``agspec.ir`` (the grid relations of D-TOPOLOGY).  Events are read for two things only: the
activities that start and complete within one transition (realized duration 1, never visible in a
state record: ``pick_started``, ``handoff_started``, ``admitted``, ``delivery_started`` with their
``end``) and coerced actions (``action_coerced``, R-ACTION-VALIDATION).

:func:`check_trace` runs all eleven over a whole trace with the INV-TRACE vacuity guard.

The eleven ``inv_*`` functions are in their group modules and listed, in spec order, in
:data:`INVARIANTS`.  Modules: ``context`` (record views, :class:`Context`), one module per group of invariants
(``material``, ``coordination``, ``space``, ``information``) and ``checker`` (:func:`check_trace`).
"""

from __future__ import annotations

from agspec.invariants.checker import INVARIANTS, REMEMBERING, Report, check_records, check_trace, check_trace_file
from agspec.invariants.checker import parse_trace_text, read_trace, remember_records
from agspec.invariants.context import INVARIANT_IDS, Context, Violation
from agspec.invariants.coordination import canonical_roles
from agspec.invariants.information import expected_mask, expected_pick_ids

__all__ = [
    "Context",
    "Violation",
    "Report",
    "INVARIANTS",
    "INVARIANT_IDS",
    "check_trace",
    "check_records",
    "remember_records",
    "REMEMBERING",
    "check_trace_file",
    "read_trace",
    "parse_trace_text",
    "canonical_roles",
    "expected_mask",
    "expected_pick_ids",
]
