"""`agspec train --campaign paper|PLAN`: a training campaign on the campaign executor (T-CAMPAIGN).

Reads and checks the plan (usage errors exit 2 before anything runs), maps the runs through
:func:`agspec.train.campaign.run_campaign`, prints one line per run as it ends and a table at the
end; exits 1 when a run failed or an evaluation has errors (F-EXIT-CODES).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any, Mapping

from rich.table import Table
from rich.text import Text

from agspec import threads
from agspec.cli.common import EXIT_INVALID, EXIT_USAGE, emit_json, fail, print_table, stderr


def load_plan(text: str) -> dict[str, Any]:
    """``paper`` or a JSON/YAML plan file, checked against schemas/training-plan.schema.json."""
    from agspec.formats.limits import InputError, load_json, parse_yaml, read_text
    from agspec.train.campaign import PlanError, check_plan, paper_plan

    if text == "paper":
        return check_plan(paper_plan())
    path = Path(text)
    try:
        data = load_json(path) if path.suffix.lower() == ".json" else parse_yaml(read_text(path), str(path))
    except InputError as exc:
        fail(str(exc), EXIT_USAGE)
    try:
        return check_plan(data, str(path))
    except PlanError as exc:
        fail(str(exc), EXIT_USAGE)


def run_plan(text: str, out: Path, settings: Mapping[str, Any], executor: Any, gpus: float, fmt: str) -> None:
    from agspec.campaign.executor import ExecutorError
    from agspec.extras import MissingExtra, require_torch
    from agspec.train.campaign import items, run_campaign

    plan = load_plan(text)
    plan["settings"] = {**plan["settings"], **settings}
    # CAMP-THREADS: -j runs share the cores; each run's runtime.threads (RES-CAMPAIGN-THREADS: 1) is its budget
    threads.apply(threads.budget(executor.jobs or 1, plan["settings"].get("runtime.threads")))
    if gpus:
        if executor.kind != "ray":
            fail("--gpus-per-run needs --executor ray (local workers share the machine's devices: "
                 "give --device cuda instead)")
        plan["settings"].setdefault("runtime.device", "cuda")
        executor = replace(executor, gpus=gpus)
    try:
        require_torch()
    except MissingExtra as exc:
        fail(str(exc), EXIT_USAGE)
    total = len(items(plan, out))
    stderr.print(Text(f"campaign: {total} runs into {out}"))
    records = []
    try:
        for record in run_campaign(plan, out, executor):
            records.append(record)
            ev = record.get("evaluation") or {}
            line = (f"[{len(records)}/{total}] {record['run']}: {record['status']}"
                    + (f", {ev['ok']} of {ev['episodes']} {ev['split']} episodes ok, delivered "
                       f"{ev['delivered']['mean']:.2f}" if ev and ev["delivered"]["mean"] is not None else "")
                    + (f" — {record['error']}" if record.get("error") else ""))
            stderr.print(Text(line))
    except ExecutorError as exc:
        fail(str(exc))
    failed = [r for r in records if r["status"] != "complete" or (r.get("evaluation") or {}).get("errors")]
    if fmt == "json":
        emit_json({"plan": plan, "runs": records}, "training-campaign")
    else:
        table = Table(title=f"campaign {out}: {total} runs")
        for col in ("run", "status", "steps", "evaluation", "n", "delivered", "completion"):
            table.add_column(col, justify="left" if col in ("run", "status", "evaluation") else "right")
        for r in records:
            ev = r.get("evaluation") or {}
            cell = lambda m: "—" if not ev or ev[m]["mean"] is None else f"{ev[m]['mean']:.3f}"  # noqa: E731
            table.add_row(r["run"], r["status"], str(r.get("steps", "—")), ev.get("split", "—"),
                          f"{ev['ok']} of {ev['episodes']}" if ev else "—", cell("delivered"), cell("completion_rate"))
        print_table(table)
    if failed:
        raise SystemExit(EXIT_INVALID)
