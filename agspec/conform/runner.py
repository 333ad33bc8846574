"""``agspec conform``: run items against an implementation and decide conformance (F-CONFORM).

``run`` drives a list of :class:`~agspec.conform.items.Item` (suite cases, catalogue episodes or a
replay) through :func:`~agspec.conform.run_item.run_item` on a campaign executor (spec chapter
14: in this process, local worker processes or Ray actors, each worker with its own
implementation), applies the expected-failures file, writes the JSONL report incrementally and
in item order (F-REPORT, CAMP-ORDER) and returns a :class:`Summary` whose ``exit_code`` follows
F-EXIT-CODES: 0 conformant at the level proven; 1 nonconformant (a fail, an xpass, a stale
expectation, or less proven than ``--require``); 3 harness or protocol error (an error outcome and
no failure, or a vacuous run); 5 nondeterministic (the first failure did not reproduce on replay).

The level (F-CONFORM-LEVELS) is what the run compared: the behavioural parts of the replies
(:data:`~agspec.conform.run_item.LEVEL_PARTS`) compared at least once, ``full`` when all of them.
"""

from __future__ import annotations

import contextlib
import tempfile
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping, Sequence

from agspec.campaign.executor import Done, ExecutorSpec, Task, run_ordered
from agspec.conform import confirm, workers
from agspec.conform import expect as expect_mod
from agspec.conform.coverage.values import rules_exercised
from agspec.conform.impl import Implementation, make_impl
from agspec.conform.items import Item
from agspec.conform.run_item import LEVEL_PARTS, Options, Result, run_item
from agspec.formats.protocol import PROTOCOL
from agspec.formats.report import OUTCOMES, ReportWriter, header_record

FAILING = ("fail", "error", "xpass")  # outcomes that count towards -x / --max-fail
EXIT_NONDETERMINISTIC = 5  # F-EXIT-CODES, F-CONFORM-NONDETERMINISM, RES-EXIT-NONDETERMINISTIC
FULL = "full"


def parse_level(text: str) -> tuple[str, ...]:
    """``--require``: ``full`` or a comma-separated subset of LEVEL_PARTS -> the parts required."""
    words = [w.strip() for w in (text or "").split(",") if w.strip()]
    if words == [FULL]:
        return LEVEL_PARTS
    bad = [w for w in words if w not in LEVEL_PARTS]
    if not words or bad:
        raise ValueError(f"--require {text!r}: expected `full` or a comma-separated list of {', '.join(LEVEL_PARTS)}")
    return tuple(p for p in LEVEL_PARTS if p in words)


def level_name(parts: Sequence[str]) -> str:
    return FULL if set(parts) >= set(LEVEL_PARTS) else ("+".join(parts) if parts else "none")


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
    require: tuple[str, ...] = ()  # --require: parts the run must prove
    nondeterministic: dict[str, Any] | None = None  # the evidence (F-CONFORM-NONDETERMINISM)
    history_dependent: dict[str, Any] | None = None  # the evidence (F-CONFORM-HISTORY)

    @property
    def compared(self) -> dict[str, int]:
        """Per behavioural part, how many replies compared it with the reference."""
        return {p: sum(r.compared.get(p, 0) for r, _ in self.results) for p in LEVEL_PARTS}

    @property
    def level(self) -> tuple[str, ...]:
        """F-CONFORM-LEVELS: the parts this run compared at least once."""
        c = self.compared
        return tuple(p for p in LEVEL_PARTS if c[p])

    @property
    def missing(self) -> tuple[str, ...]:
        """Required parts the run did not prove."""
        return tuple(p for p in self.require if p not in self.level)

    @property
    def skips(self) -> dict[str, int]:
        """Skipped items by reason (the simulator's `unsupported` reasons, missing capabilities)."""
        out: dict[str, int] = {}
        for r, o in self.results:
            if o == "skip":
                out[r.message or "skipped"] = out.get(r.message or "skipped", 0) + 1
        return out

    @property
    def rules_exercised(self) -> list[str]:
        """Rules whose firing the reference's events witnessed in the items run (values.EVENT_RULES)."""
        return rules_exercised({t for r, _ in self.results for t in r.event_types})

    @property
    def reproducers(self) -> list[str]:
        """Every reproducer file this run wrote (F-REPRO), in item order."""
        return [r.failure["reproducer"] for r, _ in self.results
                if r.failure and r.failure.get("reproducer") and r.item.kind != "replay"]

    @property
    def horizon(self) -> dict[str, dict[str, int]]:
        """F-CONFORM: per official scenario, the catalogue episodes run and how many of their horizons'
        ticks were checked (an episode that stops at a failure or at the end of its execution counts
        what it ran)."""
        out: dict[str, dict[str, int]] = {}
        for r, _ in self.results:
            if r.item.scenario is None or r.item.horizon is None:
                continue
            row = out.setdefault(r.item.scenario, {"episodes": 0, "ticks": 0, "horizon": 0})
            row["episodes"] += 1
            row["ticks"] += min(r.ticks, r.item.horizon)
            row["horizon"] += r.item.horizon
        return out

    @property
    def partial_horizon(self) -> bool:
        """Whether some passing catalogue episode stopped before its horizon (``--horizon``)."""
        return any(r.item.horizon is not None and o == "pass" and r.item.ticks < r.item.horizon
                   for r, o in self.results)

    @property
    def ticks(self) -> int:
        return sum(r.ticks for r, _ in self.results)

    @property
    def states(self) -> int:
        return sum(r.states for r, _ in self.results)

    @property
    def golden(self) -> int:
        """F-GOLDEN: items decided by matching a golden reference trace (the rest ran live)."""
        return sum(r.reference == "golden" for r, _ in self.results)

    @property
    def invariant_checks(self) -> int:
        return sum(r.invariant_checks for r, _ in self.results)

    @property
    def expectations(self) -> int:
        return sum(r.expectations for r, _ in self.results)

    @property
    def assertions(self) -> dict[str, Any]:
        """RES-ASSERTION-LEVEL: suite assertions evaluated, and skipped by the part they need."""
        by_part: dict[str, int] = {}
        for r, _ in self.results:
            for part, n in r.assertions_skipped.items():
                by_part[part] = by_part.get(part, 0) + n
        return {"checked": sum(r.assertions_checked for r, _ in self.results), "skipped": sum(by_part.values()),
                "skipped_by_part": dict(sorted(by_part.items()))}

    @property
    def known_divergences(self) -> dict[str, list[str]]:
        """F-CONFORM-KNOWN: the failing items whose failure is a known divergence, by DIV id."""
        out: dict[str, list[str]] = {}
        for r, o in self.results:
            named = (r.failure or {}).get("known_divergence")
            if named and o in ("fail", "xfail"):
                out.setdefault(named["id"], []).append(r.item.id)
        return out

    @property
    def vacuous(self) -> bool:
        """Vacuity guard: no behavioural part was compared and no invariant was checked."""
        return not self.level and self.invariant_checks == 0

    @property
    def exit_code(self) -> int:
        c = self.counts
        if self.nondeterministic is not None:
            return EXIT_NONDETERMINISTIC
        if c["fail"] or c["xpass"] or self.stale or (self.missing and not c["error"] and not self.vacuous):
            return 1
        if c["error"] or self.vacuous:
            return 3
        return 0

    @property
    def verdict(self) -> str:
        """The one-line verdict: "conformant" only at level full (F-CONFORM-LEVELS)."""
        code = self.exit_code
        if code == 0:
            skipped = sum(self.skips.values())
            checked = sum(row["ticks"] for row in self.horizon.values())
            total = sum(row["horizon"] for row in self.horizon.values())
            return ("conformant" if self.level == LEVEL_PARTS else f"conformant at level {level_name(self.level)}") \
                + (f" ({skipped} item(s) skipped, see the skips by reason)" if skipped else "") \
                + (f" (catalogue episodes checked {checked} of {total} horizon ticks: --horizon)"
                   if self.partial_horizon else "")
        if code == EXIT_NONDETERMINISTIC:
            return "nondeterministic implementation"
        if code == 1:
            if self.missing and not (self.counts["fail"] or self.counts["xpass"] or self.stale):
                return (f"insufficient level: proved {level_name(self.level)}, --require needs "
                        f"{', '.join(self.missing)}")
            if self.history_dependent is not None:
                return "nonconformant: history-dependent (a failure needs what the simulator process did before)"
            return "nonconformant"
        return "vacuous" if self.vacuous else "harness or protocol error"

    def footer(self) -> dict[str, Any]:
        return {
            "type": "footer", "complete": self.not_run == 0, "counts": dict(self.counts), "stale": len(self.stale),
            "total": len(self.results), "not_run": self.not_run, "ticks": self.ticks, "replies_compared": self.states,
            "states_compared": self.compared["state"],
            "invariant_checks": self.invariant_checks, "expectations_checked": self.expectations,
            "assertions": self.assertions, "known_divergences": self.known_divergences,
            "compared": self.compared, "level": level_name(self.level), "required": list(self.require),
            "skips": self.skips, "reproducers": self.reproducers, "rules_exercised": self.rules_exercised, "nondeterministic": self.nondeterministic,
            "history_dependent": self.history_dependent, "horizon": self.horizon,
            "duration_s": round(self.duration_s, 3), "golden_items": self.golden,
            "conformant": self.exit_code == 0 and self.level == LEVEL_PARTS, "vacuous": self.vacuous,
            "verdict": self.verdict, "exit_code": self.exit_code,
        }


# --------------------------------------------------------------------------- workers (CAMP-EXECUTOR)


def _open_impl(shared: tuple[str, float, bool, Options, str | None]) -> tuple[Implementation, Options, str | None]:
    """Per worker: its own implementation (never shared), made once and used for all its items."""
    spec, timeout, validate, opts, watch = shared
    return make_impl(spec, timeout=timeout, validate=validate), opts, watch


def _close_impl(context: tuple[Implementation, Options, str | None]) -> None:
    context[0].close()  # stops the worker's simulator (CAMP-CANCEL)


def _run_item(context: tuple, item: Item) -> Result:
    impl, opts = context[0], context[1]
    watch = context[2] if len(context) > 2 else None
    marker = workers.mark(watch, item.id, impl) if watch else None  # evidence if this worker dies
    result = run_item(item, impl, opts)
    if marker is not None:
        workers.clear(marker)
    return result


# --------------------------------------------------------------------------- the run


def run(items: Sequence[Item], impl_spec: str, *, timeout: float = 5.0, validate: bool = False, jobs: int = 1,
        opts: Options | None = None, expectations: Mapping[str, expect_mod.Expected] | None = None,
        stale: Sequence[str] = (), max_fail: int | None = None, report_path: str | None = None,
        options_record: Mapping[str, Any] | None = None, impl: Implementation | None = None,
        on_result: Callable[[Result, str], None] | None = None, require: Sequence[str] = (),
        replays: int = 1, executor: ExecutorSpec | None = None) -> Summary:
    """Run ``items``; results are reported through ``on_result`` in item order.

    ``impl`` may be given (an already constructed implementation, used when ``jobs`` is 1); otherwise
    it is made from ``impl_spec``.  ``executor`` says where the items run (spec chapter 14; default
    ``jobs`` local processes, each worker with its own implementation); results are reported in
    item order whatever order the workers finish in (CAMP-ORDER).  ``max_fail``: stop after that
    many failing outcomes (``-x`` = 1).  ``require``: the parts the run must prove (``--require``);
    ``replays``: how often the first failing item's reproducer is replayed in a fresh process to tell a
    reproducible failure from a history-dependent or a nondeterministic one (0: never; confirm).
    """
    opts = opts or Options(impl_spec=impl_spec)
    expectations = dict(expectations or {})
    summary = Summary(stale=list(stale), require=tuple(require))
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
        declared = {"state" if k == "privileged_state" else k for k, v in impl.capabilities.items() if v}
        summary.header["level"] = level_name([p for p in LEVEL_PARTS if p in declared])
        by_index: dict[int, tuple[Result, str, dict[str, Any]]] = {}
        watch: str | None = None  # the workers' markers (conform.workers), with -j
        with ReportWriter(report_path) as report, contextlib.ExitStack() as stack:
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

            executor = executor or ExecutorSpec(jobs=jobs)
            inline = executor.kind == "local" and (executor.jobs or 1) <= 1
            if inline:
                task = Task(_run_item, (impl, opts))  # in this process, on the implementation made above
            else:
                if own:
                    impl.close()
                watch = stack.enter_context(tempfile.TemporaryDirectory(prefix="agspec-workers-"))
                task = Task(_run_item, (impl_spec, timeout, validate, opts, watch), _open_impl, _close_impl)
            outcomes = run_ordered(task, items, executor)
            try:
                for index, outcome in outcomes:  # in item order (CAMP-ORDER), so the report is too
                    if isinstance(outcome, Done):
                        result = outcome.value
                    else:  # CAMP-FAULTS: the item is an error naming the cause
                        failure = workers.blame(watch, items[index].id) if outcome.worker_died else None
                        if failure is None:  # the harness cannot tell who killed its worker
                            message = f"worker failed: {outcome.message()}"
                            failure = {"type": "harness", "code": "worker", "message": message, "tick": None}
                        else:
                            failure["message"] += f" ({outcome.message()})"
                        result = Result(items[index], "error", failure["message"], failure)
                    if done(index, result):
                        break
            finally:
                outcomes.close()  # -x / --max-fail / Ctrl-C: cancel the rest, stop the workers
            summary.results = [by_index[i][:2] for i in sorted(by_index)]
            summary.records = [by_index[i][2] for i in sorted(by_index)]
            if replays > 0:
                _confirm_failures(summary, impl_spec, timeout, validate, opts, replays)
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


def failure_signature(result: Result) -> tuple[Any, ...]:
    """What must recur for a failure to count as reproduced: outcome, tick, kind, place and invariant IDs."""
    return confirm.signature(result)


def _confirm_failures(summary: Summary, impl_spec: str, timeout: float, validate: bool, opts: Options,
                      replays: int) -> None:
    """F-CONFORM-NONDETERMINISM, F-CONFORM-HISTORY: replay the failures as their reproducers will be
    replayed (a fresh process, :mod:`agspec.conform.confirm`); record what that showed and write the
    history reproducers where the failures need them (at the paths already printed)."""
    failing = [r for r, _ in summary.results if r.outcome == "fail" and r.item.kind != "replay"]
    found = confirm.confirm_failures(failing, impl_spec, timeout=timeout, validate=validate, opts=opts,
                                     replays=replays)
    summary.nondeterministic = found.nondeterministic
    written: dict[str, str | None] = {}
    for result, data in found.rewrites:
        path = (result.failure or {}).get("reproducer")
        written[result.item.id] = confirm.write(path, data)
    if found.history_dependent is not None:
        summary.history_dependent = {**found.history_dependent,
                                     "reproducer": written.get(found.history_dependent["id"])}


__all__ = ["run", "Summary", "FAILING", "EXIT_NONDETERMINISTIC", "parse_level", "level_name", "failure_signature"]
