"""Running the eleven invariants over records and whole traces, with the INV-TRACE vacuity guard."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterable

from agspec.formats.trace import read_records
from agspec.invariants.context import INVARIANT_IDS, TRACE_EMPTY, TRACE_TRUNCATED, TRACE_VACUOUS, Context, Json
from agspec.invariants.context import Violation
from agspec.invariants.coordination import canonical_roles, inv_arity, inv_lifetime, inv_progress, inv_support
from agspec.invariants.information import expected_mask, expected_pick_ids, inv_masking, inv_observation
from agspec.invariants.material import inv_accounting, inv_conservation, inv_recipe
from agspec.invariants.space import inv_exclusivity, inv_locality

# --------------------------------------------------------------------------- the checker

Invariant = Callable[[Context, "Json | None", Json], list[Violation]]

INVARIANTS: tuple[tuple[str, Invariant], ...] = (
    ("INV-CONSERVATION", inv_conservation),
    ("INV-SUPPORT", inv_support),
    ("INV-PROGRESS", inv_progress),
    ("INV-RECIPE", inv_recipe),
    ("INV-LOCALITY", inv_locality),
    ("INV-LIFETIME", inv_lifetime),
    ("INV-ARITY", inv_arity),
    ("INV-EXCLUSIVITY", inv_exclusivity),
    ("INV-OBSERVATION", inv_observation),
    ("INV-MASKING", inv_masking),
    ("INV-ACCOUNTING", inv_accounting),
)


@dataclass
class Report:
    """The result of :func:`check_trace` (INV-TRACE vacuity guard).

    ``ticks``: tick records checked; ``agents``: robots of the instance; ``states``: state records
    checked; ``checks``: invariant ID -> objects evaluated (items, activities, robots, products, …);
    ``records``: invariant ID -> records on which it ran; ``skipped``: invariant ID -> why clauses
    were skipped (inputs absent from the trace); ``violations``: everything that failed.
    """

    ticks: int = 0
    agents: int = 0
    states: int = 0
    checks: dict[str, int] = field(default_factory=dict)
    records: dict[str, int] = field(default_factory=dict)
    skipped: dict[str, str] = field(default_factory=dict)
    violations: list[Violation] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not self.violations

    @property
    def total_checks(self) -> int:
        return sum(self.checks.values())

    def ids(self) -> set[str]:
        return {v.invariant for v in self.violations}

    def by_invariant(self, invariant: str) -> list[Violation]:
        return [v for v in self.violations if v.invariant == invariant]

    def summary(self) -> str:
        lines = [f"{self.ticks} ticks, {self.agents} agents, {self.states} states, {self.total_checks} checks: "
                 + ("ok" if self.ok else f"{len(self.violations)} violation(s)")]
        for inv in INVARIANT_IDS:
            note = f" (skipped: {self.skipped[inv]})" if inv in self.skipped else ""
            lines.append(f"  {inv:<18} {self.checks.get(inv, 0):>8} checks{note}")
        lines += [f"  {v}" for v in self.violations[:50]]
        if len(self.violations) > 50:
            lines.append(f"  … {len(self.violations) - 50} more")
        return "\n".join(lines)


# The invariants with memory across records (Context.lifetime / lifetime_gone, Context.gone_items);
# every other one is a function of the record pair alone (a guard test holds this list to that).
REMEMBERING = ("INV-CONSERVATION", "INV-LIFETIME")


def remember_records(ctx: Context, prev: Json | None, rec: Json) -> None:
    """Bring the invariants' memory across records up to ``rec`` without checking the others — for a
    record whose every check is known to hold (F-GOLDEN, RES-GOLDEN-IDENTITY)."""
    for inv_id, fn in INVARIANTS:
        if inv_id in REMEMBERING:
            fn(ctx, prev, rec)


def check_records(ctx: Context, prev: Json | None, rec: Json) -> list[Violation]:
    """All eleven invariants on one record (header: ``prev`` is None)."""
    out: list[Violation] = []
    for inv_id, fn in INVARIANTS:
        ctx.evaluated[inv_id] += 1
        out += fn(ctx, prev, rec)
    return out


def check_trace(records: Iterable[Json]) -> Report:
    """Check a whole trace (header, tick records, footer) against the eleven invariants.

    Vacuity guard (INV-TRACE): an empty trace or one without transitions is ``TRACE-EMPTY``; a missing
    footer, a footer that declares the run incomplete or a tick count different from the tick records
    read, or a gap in the epochs, is ``TRACE-TRUNCATED``; an invariant that evaluated nothing on a trace
    with transitions (without a reported skip) is ``TRACE-VACUOUS``.
    """
    records = list(records)
    report = Report()
    if not records or records[0].get("type") != "header":
        report.violations.append(Violation(TRACE_EMPTY, None, None, "the trace has no header record"
                                           if records else "the trace is empty"))
        return report
    header = records[0]
    ticks = [r for r in records[1:] if r.get("type") == "tick"]
    footers = [r for r in records[1:] if r.get("type") == "footer"]
    report.ticks = len(ticks)
    try:
        ctx = Context.from_instance(header["instance"])
    except (KeyError, TypeError, ValueError) as exc:
        report.violations.append(Violation(TRACE_EMPTY, None, None, f"the header carries no usable instance IR ({exc})"))
        return report
    report.agents = ctx.rows * ctx.cols
    if not ticks:
        report.violations.append(Violation(TRACE_EMPTY, None, None, "the trace has no tick records"))
    if not footers:
        report.violations.append(Violation(TRACE_TRUNCATED, None, None, f"the trace ends after {len(ticks)} tick "
                                                                        "record(s) without a footer"))
    else:
        footer = footers[-1]
        if records[-1] is not footer:
            report.violations.append(Violation(TRACE_TRUNCATED, None, None, "records follow the footer"))
        if footer.get("ticks") != len(ticks):
            report.violations.append(Violation(TRACE_TRUNCATED, None, None, f"the footer declares {footer.get('ticks')} "
                                                                            f"ticks, the trace has {len(ticks)}"))
        if footer.get("complete") is False:
            report.violations.append(Violation(TRACE_TRUNCATED, None, None, "the footer declares the execution "
                                                                            "incomplete"))
    prev: Json | None = None
    expected_t = int((header.get("state") or {}).get("t", 0))
    for rec in [header] + ticks:
        if "state" not in rec:
            report.violations.append(Violation(TRACE_TRUNCATED, rec.get("t"), None, "a record carries no state"))
            break
        if prev is not None:
            if rec.get("t") != expected_t or (rec["state"] or {}).get("t") != expected_t + 1:
                report.violations.append(Violation(
                    TRACE_TRUNCATED, rec.get("t"), None,
                    f"tick record t={rec.get('t')} (state t={(rec['state'] or {}).get('t')}) follows epoch "
                    f"{expected_t}: records are missing or out of order"))
                break
            expected_t += 1
        report.violations += check_records(ctx, prev, rec)
        report.states += 1
        prev = rec
    report.checks = {inv: int(ctx.counts.get(inv, 0)) for inv in INVARIANT_IDS}
    report.records = {inv: int(ctx.evaluated.get(inv, 0)) for inv in INVARIANT_IDS}
    report.skipped = dict(ctx.skipped)
    if ticks:
        for inv in INVARIANT_IDS:
            if report.records[inv] == 0 and inv not in report.skipped:
                report.violations.append(Violation(TRACE_VACUOUS, None, None, f"{inv} evaluated nothing"))
    return report


def read_trace(source: str | Path) -> list[Json]:
    """Read a JSON Lines trace file; an unparsable line ends the trace (checked as truncated)."""
    return read_records(source)


def parse_trace_text(text: str) -> list[Json]:
    """Parse trace text (JSON Lines); stops at the first unparsable line."""
    return read_records(text.splitlines())


def check_trace_file(path: str | Path) -> Report:
    return check_trace(read_trace(path))


__all__ = [
    "Context", "Violation", "Report", "INVARIANTS", "INVARIANT_IDS",
    "inv_conservation", "inv_support", "inv_progress", "inv_recipe", "inv_locality", "inv_lifetime",
    "inv_arity", "inv_exclusivity", "inv_observation", "inv_masking", "inv_accounting",
    "check_trace", "check_records", "check_trace_file", "read_trace", "parse_trace_text", "canonical_roles",
    "expected_mask", "expected_pick_ids",
]
