"""Training campaigns: algorithms × scenarios × seeds on the campaign executor (T-CAMPAIGN).

A plan (``schemas/training-plan.schema.json``; the preset ``paper`` is the paper's 270 runs) names
the runs and the settings every run shares.  :func:`run_campaign` maps the runs through
:func:`agspec.campaign.executor.run_ordered` — local processes or Ray actors, with GPU resources
per run where asked — and each run, in its worker, trains (:func:`agspec.train.api.train`), then
evaluates its final policy on the plan's evaluation instances (final-test 1000–1049 by default)
through the one episode runner.  A run already complete with its evaluation is skipped; a run cut
short is resumed from its last checkpoint (T-RESUME).

The campaign record ``campaign.jsonl`` holds one line per run, in plan order, made only of what the
runs computed (steps, digests, the evaluation's per-episode digest and means) and never of where or
when they ran, so the same plan gives the same bytes on every executor (CAMP-IDENTICAL).
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterator, Mapping

from agspec import threads
from agspec.catalogue import OFFICIAL_SCENARIOS, SPLITS
from agspec.formats import output
from agspec.train.config import ALGORITHMS

PLAN_SCHEMA = "agspec-training-plan/1"
RECORD_FILE, PLAN_FILE, RUNS_DIR, EVALUATION_FILE = "campaign.jsonl", "plan.json", "runs", "evaluation.json"
# what every campaign run fixes unless the plan says otherwise: one intra-op thread per run, so a run's
# floating-point sums do not depend on the worker's core count (CAMP-IDENTICAL)
CAMPAIGN_DEFAULTS: Mapping[str, Any] = {"runtime.threads": 1}  # RES-CAMPAIGN-THREADS
EVALUATION_METRICS = ("delivered", "completion_rate")


class PlanError(ValueError):
    """A plan that cannot be run (message names the field); a usage error (exit 2)."""


def paper_plan() -> dict[str, Any]:
    """The paper's campaign: IPPO, MAPPO, QMIX × the nine official scenarios × seeds 0–9, 1,536,000 steps,
    each final policy evaluated on the 50 final-test instances."""
    return {"schema": PLAN_SCHEMA, "algorithms": list(ALGORITHMS), "scenarios": list(OFFICIAL_SCENARIOS),
            "seeds": list(range(10)), "settings": {}, "algorithm_settings": {},
            "evaluation": {"split": "final-test", "indices": list(SPLITS["final-test"])}}


def check_plan(plan: Any, where: str = "plan") -> dict[str, Any]:
    """The plan, schema-checked (``schemas/training-plan.schema.json``), with its defaults filled in."""
    from agspec.formats.schemas import validate

    problems = validate("training-plan", plan, limit=1)
    if problems:
        raise PlanError(f"{where}{problems[0].pointer}: {problems[0].message}")
    out = {**paper_plan(), **plan}
    evaluation = {**paper_plan()["evaluation"], **plan.get("evaluation", {})}
    split = evaluation["split"]
    outside = [k for k in evaluation["indices"] if k not in SPLITS[split]]
    if outside:
        raise PlanError(f"{where}/evaluation/indices: {outside[0]} is not a {split} index "
                        f"({SPLITS[split].start}-{SPLITS[split].stop - 1})")
    out["evaluation"] = evaluation
    return out


@dataclass(frozen=True)
class RunItem:
    """One run of the campaign: what to train, where, with which settings (plain data: it travels)."""

    algorithm: str
    scenario: str
    seed: int
    run_dir: str
    settings: tuple[tuple[str, Any], ...]
    evaluation: tuple[str, tuple[int, ...]]  # split, indices

    @property
    def name(self) -> str:
        return f"{self.algorithm}-{Path(self.scenario).stem}-s{self.seed}"


def items(plan: Mapping[str, Any], out: Path) -> list[RunItem]:
    """The runs of a plan, algorithm-major as the paper's tables read (the order of ``campaign.jsonl``)."""
    evaluation = (plan["evaluation"]["split"], tuple(plan["evaluation"]["indices"]))

    def settings(algorithm: str) -> tuple[tuple[str, Any], ...]:
        own = plan.get("algorithm_settings", {}).get(algorithm, {})
        return tuple(sorted({**CAMPAIGN_DEFAULTS, **plan["settings"], **own}.items()))

    return [RunItem(a, s, k, str(out / RUNS_DIR / f"{a}-{Path(s).stem}-s{k}"), settings(a), evaluation)
            for a in plan["algorithms"] for s in plan["scenarios"] for k in plan["seeds"]]


# --------------------------------------------------------------------------- one run, in its worker


def _evaluation_record(bundle: Mapping[str, Any]) -> dict[str, Any]:
    """What a run's evaluation says, without wall times or hosts: per-episode digest, n, means."""
    from agspec.evaluate import summarize

    episodes = sorted((ep for ep in bundle["episodes"] if not ep.get("repeat")), key=lambda ep: ep["index"])
    canonical = [[ep["index"], ep["status"], ep.get("actions_sha256"), ep.get("metrics")] for ep in episodes]
    digest = hashlib.sha256(json.dumps(canonical, sort_keys=True, separators=(",", ":")).encode()).hexdigest()
    summary = summarize(episodes, EVALUATION_METRICS)
    means = {m: summary[0][m] if summary else {"mean": None, "half_width": None, "n": 0} for m in EVALUATION_METRICS}
    return {"episodes": len(episodes), "ok": sum(ep["status"] == "ok" for ep in episodes),
            "errors": sum(ep["status"] == "error" for ep in episodes), "episodes_sha256": digest, **means}


def _evaluate(item: RunItem, run_dir: Path, policy_sha256: str) -> dict[str, Any]:
    """The final policy on the plan's evaluation instances (F-POLICY-EVALUATION), one worker, its host."""
    from agspec.catalogue import load_scenario_bundle
    from agspec.evaluate import Job, evaluate
    from agspec.ir.fingerprint import fingerprint
    from agspec.ir.instance import make_instance
    from agspec.policy.bundle import BundleWriter, header, read_bundle
    from agspec.policy.contract import parse_policy

    path = run_dir / EVALUATION_FILE
    if path.is_file():  # resumable: an evaluation of this very policy is kept
        doc = read_bundle(path)
        if doc.get("complete") and [p.get("file_sha256") for p in doc["policies"]] == [policy_sha256]:
            return _evaluation_record(doc)
    spec = parse_policy(str(run_dir), label=item.name)
    split, indices = item.evaluation
    bundle = load_scenario_bundle(item.scenario)
    instances = [make_instance(*bundle, index=k) for k in indices]
    head = header([spec.identity()], [{"scenario": item.scenario, "index": k, "id": inst["id"],
                                       "fingerprint": fingerprint(inst),
                                       "execution_seed": inst["seeds"]["execution"]}
                                      for k, inst in zip(indices, instances)],
                  split=split, workers=1, options={"campaign": True},
                  planned={(spec.label, item.scenario): frozenset(indices)},
                  threads=threads.facts(1, None, threads.inherited() or threads.budget(1)))  # CAMP-THREADS: the run's budget
    writer = BundleWriter(path, head)
    runs = evaluate([Job(item.scenario, k, spec, inst) for k, inst in zip(indices, instances)], workers=1,
                    on_done=writer.add)
    writer.close(nondeterminism=[])
    return _evaluation_record({"episodes": runs})


def run_one(_: Any, item: RunItem) -> dict[str, Any]:
    """Train (or resume, or skip) one run, then evaluate it: its campaign record (T-CAMPAIGN)."""
    from agspec.train.api import is_complete, read_summary, resolve_config, train

    run_dir = Path(item.run_dir)
    config = resolve_config(item.algorithm, item.scenario, item.seed, dict(item.settings))
    if is_complete(run_dir):
        summary = read_summary(run_dir)
    else:
        summary = train(config, run_dir, resume=(run_dir / "run.json").is_file())
    policy_sha256 = summary["policy"]["sha256"]
    return {"run": item.name, "algorithm": item.algorithm, "scenario": item.scenario, "seed": item.seed,
            "status": summary["status"], "steps": summary["steps"], "config_sha256": summary["config_sha256"],
            "policy_sha256": policy_sha256, "evaluation": {"split": item.evaluation[0],
                                                           "indices": list(item.evaluation[1]),
                                                           **_evaluate(item, run_dir, policy_sha256)}}


# --------------------------------------------------------------------------- the campaign


def run_campaign(plan: Mapping[str, Any], out: Path, executor: Any,
                 on_record: Callable[[dict[str, Any]], None] | None = None) -> Iterator[dict[str, Any]]:
    """Every run of ``plan`` under ``out`` through the campaign executor; records in plan order.

    ``campaign.jsonl`` is rewritten as records arrive (plan order, so a cut campaign leaves a prefix);
    a run that failed gives a record with ``status: "error"`` and the cause.
    """
    from agspec.campaign.executor import Done, Task, run_ordered

    output.make_dir(out)  # F-OUTPUT-FAILURES: an unusable directory is found before any run
    output.write_text(out / PLAN_FILE, json.dumps(plan, indent=2, sort_keys=True) + "\n")
    todo = items(plan, out)
    tmp = out / (RECORD_FILE + ".tmp")  # a cut campaign leaves it, a prefix of the record
    fh = output.Stream(tmp)
    try:
        for i, outcome in run_ordered(Task(run_one), todo, executor):
            item = todo[i]
            if isinstance(outcome, Done):
                record = outcome.value
            else:
                record = {"run": item.name, "algorithm": item.algorithm, "scenario": item.scenario, "seed": item.seed,
                          "status": "error", "error": outcome.message()}
            fh.write(json.dumps(record, sort_keys=True, separators=(",", ":")) + "\n")
            if on_record is not None:
                on_record(record)
            yield record
    finally:
        fh.abandon()
    try:
        os.replace(tmp, out / RECORD_FILE)
    except OSError as exc:
        raise output.OutputError(out / RECORD_FILE, exc) from None


__all__ = ["CAMPAIGN_DEFAULTS", "PLAN_SCHEMA", "PlanError", "RunItem", "check_plan", "items", "paper_plan",
           "run_campaign", "run_one"]
