"""The reference held to its own spec on generated scenarios (the self-check).

For one valid scenario (``strategies_scenarios.bundles``) :func:`check_bundle` checks:

* **fmt** — every document's DSL text is a fixpoint: text -> IR -> text -> IR gives the same IR and
  the same text (F-DSL);
* **fingerprint** — every document's fingerprint survives the round trip, and the instance realized
  from the round-tripped documents has the same fingerprint (F-FINGERPRINT, S-REALIZATION);
* **traces** — the reference runs under every reference controller (``agspec.evaluate.run_episode``,
  what ``agspec run`` uses) and under random actions of which a stated share is illegal (masked or
  out of range, R-ACTION-VALIDATION); each trace, with observations, is checked as
  ``agspec check`` does (``agspec.trace.check.check_file``: schema, every INV-*, record count,
  footer metrics recomputed);
* **determinism** — optionally one controller run again in a fresh process through the CLI
  (``agspec run … --trace``) must write the same bytes (D-DETERMINISM).

Each problem is a :class:`Finding` whose ``kind`` names what failed (an invariant ID, a whole-trace
code, ``fmt``, ``fingerprint``, ``cross-process``, ``instance`` or ``exception``).  Test code: the
product never imports it; ``tests/test_selfcheck.py`` runs it bounded, ``benchmarks/selfcheck.py``
long.
"""

from __future__ import annotations

import json
import random
import subprocess
import sys
import traceback
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from agspec.trace.check import check_file
from agspec.controllers import CONTROLLERS
from agspec.dsl.fmt import format_ir
from agspec.evaluate import run_episode
from agspec.formats.actions import N_ACTIONS
from agspec.formats.trace import TraceWriter, read_records
from agspec.interp.snapshot import global_state
from agspec.interp.tick import Simulator
from agspec.ir.fingerprint import fingerprint
from agspec.ir.instance import make_instance
from strategies_scenarios import Bundle, dsl_form

ILLEGAL_RATE = 0.25  # share of random actions drawn from all integers -2 .. N_ACTIONS + 1, legal or not
RANDOM_ACTIONS = "random-actions"
CLI = [sys.executable, "-c", "from agspec.cli.main import main; main()"]


@dataclass(frozen=True)
class Finding:
    kind: str  # INV-…, a trace code, fmt, fingerprint, cross-process, instance, exception
    run: str  # the controller or "random-actions"; "" for document checks
    detail: str


@dataclass
class Tally:
    scenarios: int = 0
    runs: int = 0
    ticks: int = 0
    findings: list[Finding] = field(default_factory=list)
    # what the runs exercised: event types, with blocked causes, lost-release reasons and coalition sizes
    events: Counter = field(default_factory=Counter)

    def add(self, other: "Tally") -> None:
        self.scenarios += other.scenarios
        self.runs += other.runs
        self.ticks += other.ticks
        self.findings += other.findings
        self.events.update(other.events)

    def kinds(self) -> dict[str, int]:
        out: dict[str, int] = {}
        for f in self.findings:
            out[f.kind] = out.get(f.kind, 0) + 1
        return dict(sorted(out.items()))


# --------------------------------------------------------------------------- documents


def document_findings(bundle: Bundle) -> list[Finding]:
    """F-DSL fixpoint and F-FINGERPRINT stability of every document, and of the instance."""
    out: list[Finding] = []
    docs = {f"recipe:{rid}": ir for rid, ir in bundle.recipes.items()}
    docs.update(profile=bundle.profile, scenario=bundle.scenario)
    again: dict[str, Any] = {}
    for key, ir in docs.items():
        text = bundle.texts[key]
        text2, ir2 = dsl_form(ir)
        text3, ir3 = dsl_form(ir2)
        if ir2 != ir or ir3 != ir2:
            out.append(Finding("fmt", "", f"{key}: DSL -> IR -> DSL -> IR is not a fixpoint"))
        if text2 != text or text3 != text2 or format_ir(ir3) != text:
            out.append(Finding("fmt", "", f"{key}: the formatted text changes on a round trip"))
        if fingerprint(ir3) != fingerprint(ir):
            out.append(Finding("fingerprint", "", f"{key}: the fingerprint changes on a DSL round trip"))
        again[key] = ir3
    if bundle.instance is not None:
        recipes = {k.split(":", 1)[1]: v for k, v in again.items() if k.startswith("recipe:")}
        seeds = bundle.instance["seeds"]
        inst2 = make_instance(again["scenario"], recipes, again["profile"], index=seeds["index"])
        if fingerprint(inst2) != fingerprint(bundle.instance):
            out.append(Finding("fingerprint", "", "the instance realized from the round-tripped documents differs"))
        if fingerprint(json.loads(json.dumps(bundle.instance))) != fingerprint(bundle.instance):
            out.append(Finding("fingerprint", "", "the instance fingerprint changes through JSON"))
    out += [Finding("instance", "", p) for p in bundle.problems]
    return out


# --------------------------------------------------------------------------- runs


def random_actions_trace(instance: dict[str, Any], path: Path, horizon: int, seed: int,
                         illegal_rate: float = ILLEGAL_RATE) -> None:
    """A trace of the reference under random joint actions: each robot plays, with probability
    ``illegal_rate``, any integer in -2 .. N_ACTIONS + 1 (masked and out-of-range ones included),
    otherwise a uniformly drawn legal action (C-RANDOM's choice)."""
    rng = random.Random(seed)
    sim = Simulator(instance)
    exec_seed = instance["seeds"]["execution"]
    sim.reset(exec_seed)
    limit = min(horizon, sim.model.horizon)
    writer = TraceWriter(path)
    try:
        writer.header(instance=instance, fingerprint=fingerprint(instance), execution_seed=exec_seed,
                      controller={"name": RANDOM_ACTIONS, "information": "local"},
                      initial_state=global_state(sim.state), initial_events=sim.reset_events, horizon=limit)
        while not sim.done and sim.t < limit:
            t = sim.t
            observations = sim.observe()
            joint = {}
            for robot in sim.agents():
                if rng.random() < illegal_rate:
                    joint[robot] = rng.randrange(-2, N_ACTIONS + 2)
                else:
                    mask = observations[robot]["mask"]
                    joint[robot] = rng.choice([a for a, ok in enumerate(mask) if ok])
            step = sim.step(joint)
            writer.tick(t=t, actions=step.applied, events=step.events, state=global_state(sim.state),
                        observations=observations)
        writer.footer(metrics=sim.final_metrics())
    finally:
        writer.close()


def controller_trace(instance: dict[str, Any], controller: str, path: Path, horizon: int) -> None:
    writer = TraceWriter(path)
    try:
        run_episode(instance, controller, horizon=horizon, trace=writer, observations_in_trace=True)
    finally:
        writer.close()


def trace_findings(path: Path, run: str) -> tuple[int, list[Finding]]:
    """``agspec check`` on one trace: (ticks checked, findings)."""
    record = check_file(None, str(path))
    out = [Finding(v["invariant"], run, f"t={v['tick']} {v['entity']}: {v['message']}")
           for v in record.get("violations", [])]
    out += [Finding(d["code"], run, f"line {d['line']}: {d['message']}")
            for d in [*record.get("whole_trace", []), *record.get("diagnostics", [])]]
    if not record["ok"] and not out:
        out.append(Finding("check", run, f"agspec check failed without a reason: {record}"))
    return int(record.get("ticks") or 0), out


def exercised(path: Path) -> Counter:
    """The behaviour a trace shows: its event types, refined by blocked cause, lost-release reason and
    admitted coalition size (``admitted/size=2``)."""
    out: Counter = Counter()
    for rec in read_records(path):
        for ev in rec.get("events") or []:
            kind = ev.get("type")
            out[kind] += 1
            if kind == "blocked":
                out[f"blocked/{ev.get('cause')}"] += 1
            elif kind == "release_lost":
                out[f"release_lost/{ev.get('reason')}"] += 1
            elif kind == "admitted":
                out[f"admitted/size={str(ev.get('candidate')).rsplit(':', 1)[-1].count(';') + 1}"] += 1
    return out


def cross_process_findings(instance_path: Path, controller: str, reference: Path, horizon: int,
                           workdir: Path) -> list[Finding]:
    """D-DETERMINISM: ``agspec run`` in a fresh process writes the same trace bytes."""
    out_path = workdir / f"cli-{controller}.jsonl"
    proc = subprocess.run([*CLI, "run", str(instance_path), "--controller", controller, "--horizon", str(horizon),
                           "--trace", str(out_path), "--observations", "--format", "json"],
                          capture_output=True, text=True, timeout=600)
    if proc.returncode != 0:
        return [Finding("cross-process", controller, f"agspec run exited {proc.returncode}: {proc.stderr[-2000:]}")]
    if out_path.read_bytes() != reference.read_bytes():
        return [Finding("cross-process", controller, "the trace written by a fresh process differs")]
    return []


def check_bundle(bundle: Bundle, workdir: Path, *, horizon: int = 40, seed: int = 0,
                 controllers: tuple[str, ...] = CONTROLLERS, random_runs: int = 1,
                 cross_process: str | None = None) -> Tally:
    """Every check of the module docstring on one bundle; ``cross_process`` names the controller
    whose run is repeated through the CLI in a fresh process (None: skipped)."""
    tally = Tally(scenarios=1)
    tally.findings += document_findings(bundle)
    if bundle.instance is None or bundle.problems:
        return tally
    workdir.mkdir(parents=True, exist_ok=True)
    instance_path = workdir / "instance.json"
    instance_path.write_text(json.dumps(bundle.instance), encoding="utf-8")
    runs = [(c, None) for c in controllers] + [(RANDOM_ACTIONS, seed * 1000 + k) for k in range(random_runs)]
    for name, rseed in runs:
        path = workdir / f"{name}-{rseed}.jsonl"
        try:
            if rseed is None:
                controller_trace(bundle.instance, name, path, horizon)
            else:
                random_actions_trace(bundle.instance, path, horizon, rseed)
        except Exception as exc:  # the reference (or a controller) crashed: a finding, with its traceback
            tally.findings.append(Finding("exception", name, f"{type(exc).__name__}: {exc}\n{traceback.format_exc()}"))
            continue
        ticks, found = trace_findings(path, name)
        tally.runs += 1
        tally.ticks += ticks
        tally.findings += found
        tally.events.update(exercised(path))
        if name == cross_process:
            tally.findings += cross_process_findings(instance_path, name, path, horizon, workdir)
    return tally
