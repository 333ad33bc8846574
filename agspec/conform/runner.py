"""``agspec conform``: run items against an implementation and decide conformance (F-CONFORM).

``run`` drives a list of :class:`~agspec.conform.items.Item` (suite cases, catalogue episodes or a
replay) through :func:`~agspec.conform.lockstep.run_item`, sequentially or across ``jobs`` worker
processes (each with its own implementation instance), applies the expected-failures file, writes
the JSONL report incrementally (F-REPORT) and returns a :class:`Summary` whose ``exit_code`` follows
F-EXIT-CODES: 0 conformant; 1 nonconformant (a fail, an xpass or a stale expectation); 3 harness or
protocol error (an error outcome and no failure, or a vacuous run that compared nothing).
"""

from __future__ import annotations

import time
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import dataclass, field
from multiprocessing.util import Finalize
from typing import Any, Callable, Mapping, Sequence

from agspec.conform import expect as expect_mod
from agspec.conform.impl import Implementation, make_impl
from agspec.conform.items import Item
from agspec.conform.lockstep import Options, Result, run_item
from agspec.conform.protocol import PROTOCOL
from agspec.formats.report import OUTCOMES, ReportWriter, header_record

FAILING = ("fail", "error", "xpass")  # outcomes that count towards -x / --max-fail


@dataclass
class Summary:
    """What a conformance run decided."""

    results: list[tuple[Result, str]] = field(default_factory=list)  # (raw result, final outcome), in item order
    records: list[dict[str, Any]] = field(default_factory=list)  # their report lines (F-REPORT), in item order
    stale: list[str] = field(default_factory=list)
    counts: dict[str, int] = field(default_factory=lambda: {o: 0 for o in OUTCOMES})
    not_run: int = 0
    duration_s: float = 0.0
    header: dict[str, Any] = field(default_factory=dict)

    @property
    def ticks(self) -> int:
        return sum(r.ticks for r, _ in self.results)

    @property
    def states(self) -> int:
        return sum(r.states for r, _ in self.results)

    @property
    def invariant_checks(self) -> int:
        return sum(r.invariant_checks for r, _ in self.results)

    @property
    def expectations(self) -> int:
        return sum(r.expectations for r, _ in self.results)

    @property
    def vacuous(self) -> bool:
        """Vacuity guard: nothing was compared with the reference."""
        return self.states == 0

    @property
    def exit_code(self) -> int:
        c = self.counts
        if c["fail"] or c["xpass"] or self.stale:
            return 1
        if c["error"] or self.vacuous:
            return 3
        return 0

    def footer(self) -> dict[str, Any]:
        return {
            "type": "footer", "complete": self.not_run == 0, "counts": dict(self.counts), "stale": len(self.stale),
            "total": len(self.results), "not_run": self.not_run, "ticks": self.ticks, "states_compared": self.states,
            "invariant_checks": self.invariant_checks, "expectations_checked": self.expectations,
            "duration_s": round(self.duration_s, 3), "conformant": self.exit_code == 0, "vacuous": self.vacuous,
            "exit_code": self.exit_code,
        }


# --------------------------------------------------------------------------- worker processes (-j)

_WORKER: dict[str, Any] = {}  # per worker process: its own implementation (never shared)


def _init_worker(spec: str, timeout: float, validate: bool) -> None:

    impl = make_impl(spec, timeout=timeout, validate=validate)
    _WORKER["impl"] = impl
    Finalize(impl, impl.close, exitpriority=10)  # stop the worker's simulator when the worker exits


def _run_in_worker(item: Item, opts: Options) -> Result:
    return run_item(item, _WORKER["impl"], opts)


# --------------------------------------------------------------------------- the run


def run(items: Sequence[Item], impl_spec: str, *, timeout: float = 5.0, validate: bool = False, jobs: int = 1,
        opts: Options | None = None, expectations: Mapping[str, expect_mod.Expected] | None = None,
        stale: Sequence[str] = (), max_fail: int | None = None, report_path: str | None = None,
        options_record: Mapping[str, Any] | None = None, impl: Implementation | None = None,
        on_result: Callable[[Result, str], None] | None = None) -> Summary:
    """Run ``items``; results are reported through ``on_result`` as they complete.

    ``impl`` may be given (an already constructed implementation, used when ``jobs`` is 1); otherwise
    it is made from ``impl_spec``.  ``max_fail``: stop after that many failing outcomes (``-x`` = 1).
    """
    opts = opts or Options(impl_spec=impl_spec)
    expectations = dict(expectations or {})
    summary = Summary(stale=list(stale))
    t0 = time.monotonic()
    own = impl is None
    impl = impl or make_impl(impl_spec, timeout=timeout, validate=validate)
    described: dict[str, Any] = {"spec": impl_spec}
    try:
        try:
            impl.start()
            described = impl.describe()
        except Exception as exc:  # reported per case as an error; the header says why
            described = {"spec": impl_spec, "error": str(exc)}
        summary.header = header_record(described, dict(options_record or {}), len(items), protocol=PROTOCOL)
        by_index: dict[int, tuple[Result, str, dict[str, Any]]] = {}
        with ReportWriter(report_path) as report:
            report.write(summary.header)
            failures = 0

            def done(index: int, result: Result) -> bool:
                nonlocal failures
                exp = expectations.get(result.item.id)
                outcome = expect_mod.apply(result.outcome, exp)
                record = result.record(outcome, exp.to_json() if exp else None)
                by_index[index] = (result, outcome, record)
                summary.counts[outcome] += 1
                report.write(record)
                if on_result:
                    on_result(result, outcome)
                if outcome in FAILING:
                    failures += 1
                return max_fail is not None and failures >= max_fail

            if jobs <= 1 or len(items) <= 1:
                for index, item in enumerate(items):
                    if done(index, run_item(item, impl, opts)):
                        break
            else:
                if own:
                    impl.close()
                with ProcessPoolExecutor(max_workers=jobs, initializer=_init_worker,
                                         initargs=(impl_spec, timeout, validate)) as pool:
                    pending = {pool.submit(_run_in_worker, item, opts): i for i, item in enumerate(items)}
                    stop = False
                    while pending and not stop:
                        finished, _ = wait(pending, return_when=FIRST_COMPLETED)
                        for fut in finished:
                            index = pending.pop(fut)
                            try:
                                result = fut.result()
                            except Exception as exc:  # a worker died: the item is a harness error
                                result = Result(items[index], "error", f"worker process failed: {exc}",
                                                {"type": "harness", "code": type(exc).__name__,
                                                 "message": f"worker process failed: {exc}", "tick": None})
                            if done(index, result) and not stop:
                                stop = True
                    if stop:
                        for fut in pending:
                            fut.cancel()
            summary.results = [by_index[i][:2] for i in sorted(by_index)]
            summary.records = [by_index[i][2] for i in sorted(by_index)]
            summary.not_run = len(items) - len(summary.results)
            for ident in summary.stale:
                exp = expectations.get(ident)
                report.write({"type": "stale", "id": ident, "expected": exp.to_json() if exp else {"outcome": "fail"},
                              "message": f"the expected-failures file lists {ident}, which names no case or episode"})
            summary.duration_s = time.monotonic() - t0
            report.write(summary.footer())
    finally:
        if own:
            impl.close()
    return summary


__all__ = ["run", "Summary", "FAILING"]
