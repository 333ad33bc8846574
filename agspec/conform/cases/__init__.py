"""The conformance suite: case files, content-fingerprint ids, expectations, coverage and self-lint.

A case (``conformance/cases/*.yaml``, schema ``schemas/case.schema.json``) names an instance, an
execution seed, a joint-action script (symbolic actions allowed) or a driver, and expectations on
the canonical global state (O-GLOBAL-STATE), on the events of a tick, on observations and on the
end of the execution.  Loading resolves everything an implementation needs:

* the instance IR (catalogue reference, a JSON file under the suite root, or inline IR);
* the script as integers (O-ACTION-ENCODING), symbolic actions being resolved against the
  *reference* interpreter's option lists of that epoch (``Simulator.decision.options``), padded
  with idle ticks up to the last expectation;
* for a ``{"trace": …}`` driver, the trace's applied actions, and every state and event of the
  trace as expectations (the trace *is* the expected run);
* the case id, ``"c-"`` + 12 hex digits of the SHA-256 of the RFC 8785 form of the case's
  defining content — instance fingerprint, execution seed, resolved actions or driver, expectations
  — so that titles, tags, rule lists, notes and file names can change without breaking an
  expected-failures file (the JSON-Schema-Test-Suite's stable-id request).

Malformed files raise :class:`SuiteError` with ``file:line`` locations (never a traceback).
``lint_suite`` is the suite's self-check; ``coverage`` measures it against the ``### R-…`` and
``### INV-…`` headings of the spec (``agspec.spec_index``).

Running a case (what a harness does; ``reference_run`` / ``check_reference`` do it in-process):

1. ``reset(case.execution_seed)`` on ``case.instance``;
2. for ``t`` in ``range(case.ticks)``: step with ``case.actions[t]`` (robots not listed idle) or, for
   a ``{"controller": …}`` driver, with the controller's actions; then
   ``check_expectations(case, t, state, events, observations=…, done=…)``, where ``state`` is the
   canonical global state after the step (s_{t+1}), ``events`` the events of the step, and
   ``observations`` the per-robot observations after the step (pass None for a part the simulator
   does not declare: its assertions are then not evaluated and are counted as skipped,
   RES-ASSERTION-LEVEL, ``expectations.tally``).

Expectation dicts carry the loader key ``_index`` (position in the file, or ``"trace"`` for the
per-tick expectations generated from a reference trace); it is metadata, not an assertion.

Modules: ``model`` (the case), ``suite`` (loading), ``expectations`` (checking a reply) and
``reference`` (reference runs, coverage, lint).
"""

from __future__ import annotations

from agspec.conform.cases.expectations import Mismatch, check_expectations, event_matches, mismatches
from agspec.conform.cases.model import CASE_GLOBS, STATE_KEYS, Case, Located, SuiteError
from agspec.conform.cases.reference import TickResult, check_reference, coverage, lint_suite, reference_run
from agspec.conform.cases.suite import load_case_file, load_suite, trace_records
from agspec.formats.pointer import first_difference
from agspec.formats.pointer import resolve as resolve_pointer

__all__ = [
    "Located",
    "SuiteError",
    "Case",
    "CASE_GLOBS",
    "STATE_KEYS",
    "event_matches",
    "Mismatch",
    "mismatches",
    "check_expectations",
    "load_suite",
    "load_case_file",
    "trace_records",
    "TickResult",
    "reference_run",
    "check_reference",
    "coverage",
    "lint_suite",
    "first_difference",
    "resolve_pointer",
]
