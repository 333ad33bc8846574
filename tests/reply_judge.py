"""Running a mutated reply through the harness and judging the verdict (shared by
tests/test_reply_generator.py and benchmarks/fuzz_replies.py).

:func:`judge` runs one small item (a greedy episode on a 2x2 instance) through ``runner.run`` — the
Python API of ``agspec conform``, report file included — against :class:`line_sim.LineSim` with one
mutation (:mod:`reply_mutations`), live and with a warm golden cache, and returns what is wrong with
the verdicts (an empty list: nothing).  Wrong is: an exception out of the run; a ``harness`` failure
(agspec's own bug) or exit code 4; a report that is incomplete or fails its schema; a changed verdict
for a mutation that keeps the reply (F-VALUES); another code than the one right code; a golden
verdict other than the live one (RES-GOLDEN-IDENTITY).
"""

from __future__ import annotations

import json
import random
import sys
import tempfile
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE / "fakes"))

from agspec.conform import runner  # noqa: E402
from agspec.conform.items import Item  # noqa: E402
from agspec.conform.run_item import Options  # noqa: E402
from agspec.formats.report import read_report  # noqa: E402

from line_sim import POSITIONS, LineSim  # noqa: E402
from reply_mutations import CLASSES, Mutation, mutate  # noqa: E402

TICKS = 5


def item() -> Item:
    """A greedy episode on a 2x2 instance: picks, handoffs and an operation within a few ticks."""
    inst = json.loads((HERE.parent / "conformance" / "instances" / "pair-2x2-official.json").read_text("utf-8"))
    return Item(id="e-mutated", kind="episode", title="mutated replies", instance=inst,
                execution_seed=inst["seeds"]["execution"], ticks=TICKS, controller={"name": "greedy", "seed": 0})


def run(target: str | None, klass: str | None, seed: int, golden_dir: str | None,
        report: Path) -> tuple[Any, Mutation | None, Any]:
    """One run of :func:`item`; (summary or the exception it raised, the mutation applied, the record)."""
    sim = LineSim(target, (lambda reply: mutate(reply, klass, random.Random(seed))) if klass else None)
    try:
        summary: Any = runner.run([item()], "line-sim", impl=sim, report_path=str(report),
                                  opts=Options(impl_spec="line-sim", golden_dir=golden_dir))
    except Exception as exc:  # noqa: BLE001 - what is judged
        summary = exc
    finally:
        sim.close()
    return summary, sim.applied, (summary.records[0] if not isinstance(summary, Exception) and summary.records else None)


def verdict(record: Any) -> tuple:
    f = (record or {}).get("failure") or {}
    return (record or {}).get("outcome"), f.get("type"), f.get("code"), f.get("tick"), f.get("path")


def problems_of(summary: Any, mutation: Mutation | None, record: Any, report: Path) -> list[str]:
    if isinstance(summary, Exception):
        return [f"exception: {type(summary).__name__}: {summary}"]
    out: list[str] = []
    failure = (record or {}).get("failure") or {}
    if failure.get("type") == "harness" or summary.exit_code == 4:
        out.append(f"harness: {failure.get('code')}: {str(failure.get('message'))[:160]}")
    records, report_problems = read_report(report)
    if report_problems:
        out.append(f"report: {report_problems[0][:200]}")
    if mutation is not None and mutation.same and verdict(record)[0] != "pass":
        out.append(f"same reply, other verdict: {verdict(record)}")
    if mutation is not None and mutation.code and failure.get("code") != mutation.code:
        out.append(f"code {failure.get('code')}, expected {mutation.code}")
    return out


def judge(klass: str, target: str, seed: int, cache: str) -> tuple[Mutation | None, list[str]]:
    """Live and warm runs of one mutation; (the mutation, what is wrong)."""
    with tempfile.TemporaryDirectory() as tmp:
        live = run(target, klass, seed, None, Path(tmp) / "live.jsonl")
        wrong = problems_of(*live, Path(tmp) / "live.jsonl")
        warm = run(target, klass, seed, cache, Path(tmp) / "warm.jsonl")
        wrong += [f"golden {p}" for p in problems_of(*warm, Path(tmp) / "warm.jsonl")]
        if verdict(live[2]) != verdict(warm[2]):
            wrong.append(f"identity: golden verdict {verdict(warm[2])} != live {verdict(live[2])}")
    return live[1], wrong


def warm_cache(directory: str) -> None:
    """Record the item's golden trace (an unmutated live run that passes)."""
    summary, _, record = run(None, None, 0, directory, Path(directory) / "record.jsonl")
    assert not isinstance(summary, Exception) and verdict(record)[0] == "pass", verdict(record)


__all__ = ["CLASSES", "POSITIONS", "TICKS", "item", "run", "judge", "warm_cache", "verdict"]
