"""Shrinking a divergence to a minimal counterexample, and saving it as a replayable case.

Input: an instance, an execution seed, the symbolic joint-action script of an episode on which
two implementations diverged (:mod:`agspec.conform.explore.diff`), and that divergence.  Output: a
:class:`Shrunk` counterexample whose replay still diverges *the same way* — same compared part and
same JSON Pointer up to the ids and indices in it (:meth:`Divergence.signature`) — with

1. the script truncated to the diverging tick;
2. as many actions as possible replaced by idle (delta debugging, ddmin, over the non-idle
   (tick, robot) actions);
3. as many ticks as possible dropped (ddmin over ticks; later actions move earlier, and keep their
   meaning because they are symbolic: option ids, candidate ids, directions);
4. the instance reduced where the IR allows it: the horizon (or batch timeout) cut to the diverging
   tick and the realization cut to the products that horizon can release (AG511 ties the two), the
   batch size lowered, recipes no remaining product uses removed — each reduction kept only if the
   instance still validates and the divergence persists;

repeated until nothing changes or the budget (replays, seconds) is spent.

Why delta debugging here rather than hypothesis: hypothesis shrinks what *it* generated and cannot
start from a given counterexample, which is what a controller episode produces.  Sequences that
hypothesis generates itself (``agspec diff --hypothesis-examples``) are shrunk by hypothesis first
(:func:`agspec.conform.explore.diff.hypothesis_search`) and only polished here.

:func:`to_case` turns the result into a conformance case (schemas/case.schema.json): the inline
instance, the seed, the symbolic script and one expectation — the expected side's value at the
diverging pointer after the diverging tick — so ``agspec conform`` replays it against any
implementation; :func:`write_case` saves it.
"""

from __future__ import annotations

import copy
import json
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import yaml

from agspec.conform.explore.diff import Divergence, JointAction, Pair, Run, is_idle, non_idle, replay
from agspec.conform.lockstep.compare import MISSING as _MISSING
from agspec.conform.lockstep.eventdiff import differing
from agspec.formats import output
from agspec.ir.schemas import validate_schema
from agspec.ir.validate import errors, validate_instance

Json = dict[str, Any]


@dataclass
class Shrunk:
    instance: Json
    execution_seed: int | None
    script: list[JointAction]
    divergence: Divergence
    original_ticks: int
    original_actions: int
    checks: int = 0
    seconds: float = 0.0
    instance_notes: list[str] = field(default_factory=list)
    exhausted: bool = False  # the budget ran out before a fixpoint

    @property
    def actions(self) -> int:
        return sum(1 for _ in non_idle(self.script))

    @property
    def ticks(self) -> int:
        return max(0, self.divergence.tick + 1)


class _Budget(Exception):
    pass


class Shrinker:
    def __init__(self, pair: Pair, execution_seed: int | None, signature: tuple[str, str], *,
                 max_checks: int = 400, max_seconds: float = 120.0, same_signature: bool = True):
        self.pair = pair
        self.seed = execution_seed
        self.signature = signature
        self.max_checks = max_checks
        self.deadline = time.perf_counter() + max_seconds
        self.same = same_signature
        self.checks = 0

    def test(self, instance: Mapping[str, Any], script: Sequence[JointAction], ticks: int) -> Run | None:
        """Replay; the run if it still diverges the same way within ``ticks`` ticks, else None."""
        if self.checks >= self.max_checks or time.perf_counter() > self.deadline:
            raise _Budget()
        self.checks += 1
        padded = list(script[:ticks]) + [{} for _ in range(max(0, ticks - len(script)))]
        run = replay(self.pair, instance, self.seed, padded, ticks)
        d = run.divergence
        if d is None or (self.same and d.signature() != self.signature):
            return None
        return run


def ddmin(items: list, test: Callable[[list], bool]) -> list:
    """Zeller's delta debugging: a 1-minimal sublist of ``items`` for which ``test`` holds
    (``test(items)`` is assumed to hold)."""
    n = 2
    while len(items) >= 2:
        size = math.ceil(len(items) / n)
        chunks = [items[i:i + size] for i in range(0, len(items), size)]
        reduced = False
        for k, chunk in enumerate(chunks):
            if len(chunks) > 2 and test(chunk):
                items, n, reduced = chunk, 2, True
                break
            complement = [x for j, c in enumerate(chunks) if j != k for x in c]
            if test(complement):
                items, n, reduced = complement, max(n - 1, 2), True
                break
        if not reduced:
            if n >= len(items):
                break
            n = min(len(items), 2 * n)
    if len(items) == 1 and test([]):
        return []
    return items


def trim_script(script: Sequence[JointAction]) -> list[JointAction]:
    """The script without idle entries and without trailing all-idle ticks."""
    out = [dict(j) for j in script]
    while out and not any(not is_idle(a) for a in out[-1].values()):
        out.pop()
    return [{r: a for r, a in j.items() if not is_idle(a)} for j in out]


def shrink(pair: Pair, instance: Mapping[str, Any], execution_seed: int | None, script: Sequence[JointAction],
           divergence: Divergence, *, max_checks: int = 400, max_seconds: float = 120.0,
           same_signature: bool = True, shrink_instance: bool = True) -> Shrunk:
    """Shrink (script, instance) while the divergence persists; see the module docstring."""
    start = time.perf_counter()
    sh = Shrinker(pair, execution_seed, divergence.signature(), max_checks=max_checks, max_seconds=max_seconds,
                  same_signature=same_signature)
    best_inst = copy.deepcopy(dict(instance))
    best_div = divergence
    best = trim_script(script[: divergence.tick + 1]) if divergence.tick >= 0 else []
    result = Shrunk(best_inst, execution_seed, best, divergence, original_ticks=max(0, divergence.tick + 1),
                    original_actions=sum(1 for _ in non_idle(script[: divergence.tick + 1])))

    def accept(run: Run, inst: Mapping[str, Any]) -> None:
        nonlocal best, best_div, best_inst
        best_div = run.divergence
        best = trim_script(run.script[: best_div.tick + 1])
        best_inst = dict(inst)

    try:
        progress = True
        rounds = 0
        while progress and rounds < 4:
            progress = False
            rounds += 1
            # (2) actions -> idle, timing unchanged
            actions = list(non_idle(best))
            if actions:
                ticks = best_div.tick + 1

                def keep_actions(subset: list) -> bool:
                    cand: list[JointAction] = [dict() for _ in range(ticks)]
                    for t, robot, a in subset:
                        cand[t][robot] = a
                    run = sh.test(best_inst, cand, ticks)
                    if run is not None:
                        accept(run, best_inst)
                        return True
                    return False

                kept = [] if keep_actions([]) else ddmin(actions, keep_actions)  # all idle first: often enough
                if len(kept) < len(actions):
                    progress = True
            # (3) drop ticks: later actions move earlier (pointless once every action is idle)
            n_ticks = best_div.tick + 1
            if n_ticks > 1 and any(True for _ in non_idle(best)):
                index = list(range(n_ticks))
                snapshot = [dict(j) for j in best] + [{} for _ in range(n_ticks - len(best))]

                def keep_ticks(subset: list) -> bool:
                    if not subset:
                        return False
                    cand = [snapshot[i] for i in subset]
                    run = sh.test(best_inst, cand, len(subset))
                    if run is not None:
                        accept(run, best_inst)
                        return True
                    return False

                kept_ticks = ddmin(index, keep_ticks)
                if len(kept_ticks) < n_ticks:
                    progress = True
            # (4) the instance
            changed = shrink_instance
            while changed:  # each reduction is derived from the current instance
                changed = False
                for note, cand_inst in instance_reductions(best_inst, best_div.tick):
                    run = sh.test(cand_inst, best, best_div.tick + 1)
                    if run is not None:
                        accept(run, cand_inst)
                        result.instance_notes.append(note)
                        progress = changed = True
                        break
    except _Budget:
        result.exhausted = True
    result.instance, result.script, result.divergence = best_inst, best, best_div
    result.checks, result.seconds = sh.checks, time.perf_counter() - start
    return result


# =============================================================================================
# instance reductions


def _valid(instance: Mapping[str, Any]) -> bool:

    try:
        return not (errors(validate_schema(instance)) or errors(validate_instance(instance)))
    except Exception:
        return False


def _renamed(instance: dict[str, Any]) -> dict[str, Any]:
    base = str(instance.get("id") or "instance")
    if not base.endswith("-shrunk"):
        instance["id"] = f"{base}-shrunk"
    return instance


def instance_reductions(instance: Mapping[str, Any], tick: int):
    """Candidate smaller instances (each yielded only if it validates), most aggressive first."""
    sc = instance["scenario"]
    ev = sc["evaluation"]
    need = max(1, tick + 1)
    if ev.get("mode") == "continuing" and int(ev.get("horizon", 0)) > need:
        inst = _renamed(copy.deepcopy(dict(instance)))
        inst["scenario"]["evaluation"]["horizon"] = need
        interval = int(sc["release"]["interval"])
        inst["realization"]["products"] = inst["realization"]["products"][: 1 + need // interval]
        if _valid(inst):
            old_n, new_n = len(instance["realization"]["products"]), len(inst["realization"]["products"])
            yield f"horizon {ev['horizon']} -> {need}, products {old_n} -> {new_n}", inst
    if ev.get("mode") == "batch":
        if int(ev.get("timeout", 0)) > need:
            inst = _renamed(copy.deepcopy(dict(instance)))
            inst["scenario"]["evaluation"]["timeout"] = need
            if _valid(inst):
                yield f"batch timeout {ev['timeout']} -> {need}", inst
        size = int(ev.get("batch_size", 1))
        for k in range(1, min(size, 9)):
            inst = _renamed(copy.deepcopy(dict(instance)))
            inst["scenario"]["evaluation"]["batch_size"] = k
            inst["realization"]["products"] = inst["realization"]["products"][:k]
            if _valid(inst):
                yield f"batch size {size} -> {k}", inst
                break
    used = {p["recipe"] for p in instance["realization"]["products"]}
    unused = [r for r in sc["recipes"] if r not in used]
    if unused and used:
        inst = _renamed(copy.deepcopy(dict(instance)))
        inst["scenario"]["recipes"] = [r for r in sc["recipes"] if r in used]
        inst["recipes"] = {k: v for k, v in inst["recipes"].items() if k in used}
        if _valid(inst):
            yield f"recipes {', '.join(unused)} removed", inst


# =============================================================================================
# the counterexample as a conformance case

# The rule most directly responsible for each top-level field of the global state (for the case's
# mandatory `rules` list; the divergence itself is what the case asserts).
_RULE_OF_FIELD = {
    "t": "R-CLOCK", "released": "R-RELEASE", "lost_releases": "R-RELEASE", "wip": "R-RELEASE",
    "delivered": "R-DELIVERY", "robots": "R-EXECUTION", "products": "R-COMPLETION", "items": "R-COMPLETION",
    "shelves": "R-PICK", "proposals": "R-SUPPORT-LIFECYCLE", "activities": "R-EXECUTION",
}


def rules_for(divergence: Divergence) -> list[str]:
    rules = ["R-TICK-ORDER"]
    if divergence.where == "state":
        top = divergence.pointer.split("/")[1] if divergence.pointer.count("/") >= 1 else ""
        rule = _RULE_OF_FIELD.get(top)
        if rule and rule not in rules:
            rules.append(rule)
    return rules


def expectation(divergence: Divergence) -> Json | None:
    """The case expectation asserting the expected side's value at the divergence."""
    d = divergence
    exp: Json = {"after_tick": max(0, d.tick)}
    if d.where == "state":
        if d.expected is _MISSING:
            exp["absent"] = [d.pointer]
        else:
            exp["state"] = {d.pointer: d.expected}
    elif d.where == "events":
        row = next(iter(differing(d.events)), None) if d.events is not None else None
        if row is not None and row["op"] != "extra":  # F-EVENT-DIFF: the expected event of the first differing row
            exp["events"] = [dict(row["expected"])]
            if row["op"] == "changed":
                exp["no_events"] = [dict(row["actual"])]
        elif row is not None:
            exp["no_events"] = [dict(row["actual"])]
        elif isinstance(d.expected, Mapping) and "type" in d.expected:
            exp["events"] = [dict(d.expected)]
        elif isinstance(d.actual, Mapping) and "type" in d.actual:
            exp["no_events"] = [dict(d.actual)]
        else:
            return None
    elif d.where in ("observations", "masks"):
        pointer = d.pointer
        if d.where == "masks":  # {robot: mask} -> {robot: observation}/mask
            parts = pointer.split("/")
            pointer = "/".join(parts[:2] + ["mask"] + parts[2:])
        if d.expected is _MISSING:
            return None
        exp["observations"] = {pointer: d.expected}
    elif d.where == "done":
        exp["done"] = bool(d.expected)
    else:
        return None
    return exp


def to_case(shrunk: Shrunk, *, title: str, notes: str = "", coerced: bool = False,
            instance_ref: str | None = None) -> Json:
    """The counterexample as a case; ``instance_ref`` (a path relative to the suite root) replaces the
    inline instance IR."""
    d = shrunk.divergence
    rules = rules_for(d)
    if coerced and "R-ACTION-VALIDATION" not in rules:
        rules.append("R-ACTION-VALIDATION")
    case: Json = {"title": title, "rules": rules, "invariants": [], "tags": ["diff", "shrunk"]}
    if notes:
        case["notes"] = notes
    case["instance"] = instance_ref if instance_ref is not None else shrunk.instance
    case["execution_seed"] = shrunk.execution_seed
    case["script"] = [dict(j) for j in shrunk.script]
    exp = expectation(d)
    if exp is None:  # an error divergence: the case runs the script and asserts the tick counter
        exp = {"after_tick": max(0, d.tick), "state": {"/t": max(0, d.tick) + 1}}
    case["expectations"] = [exp]
    return case


def write_case(shrunk: Shrunk, directory: str | Path, stem: str, *, title: str, notes: str = "",
               coerced: bool = False) -> Path:
    """Save the counterexample as a one-case suite: ``DIR/cases/STEM.yaml`` referencing
    ``DIR/instances/STEM.json`` (the layout of conformance/), so ``agspec conform --suite DIR
    --episodes 0`` replays it; returns the case file's path."""


    root = Path(directory)
    output.make_dir(root / "cases")  # F-OUTPUT-FAILURES
    output.make_dir(root / "instances")
    inst_path = root / "instances" / f"{stem}.json"
    output.write_text(inst_path, json.dumps(shrunk.instance, indent=1, ensure_ascii=False) + "\n")
    case = to_case(shrunk, title=title, notes=notes, coerced=coerced, instance_ref=f"instances/{stem}.json")
    path = root / "cases" / f"{stem}.yaml"
    header = ("# Counterexample found and shrunk by `agspec diff` (instance: ../instances/" + stem + ".json).\n"
              "# Replay: agspec conform --impl IMPL --suite " + str(root) + " --episodes 0\n")
    text = yaml.safe_dump(case, sort_keys=False, allow_unicode=True, default_flow_style=None, width=120)
    output.write_text(path, header + text)
    return path


__all__ = ["Shrunk", "shrink", "ddmin", "trim_script", "instance_reductions", "to_case", "write_case", "expectation",
           "rules_for"]
