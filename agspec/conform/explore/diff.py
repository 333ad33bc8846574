"""Differential testing: two implementations in lockstep on generated episodes.

``agspec diff --impl A --impl B`` resets both implementations on the same instance and execution
seed, sends both the same joint action every tick and compares what they answer — the canonical
global state (O-GLOBAL-STATE), the events of the tick, the observations and masks when both declare
the capability, and the end flag — field by field.  The first difference is a :class:`Divergence`
(tick, JSON Pointer, expected vs actual).  :mod:`agspec.conform.explore.shrink` then reduces the episode to a
minimal counterexample that is printed and saved as a replayable conformance case.

Where the joint actions come from (:class:`Policy`):

* seeded controllers — ``random`` (C-RANDOM, uniform over the mask) and ``greedy`` (C-GREEDY) —
  acting on the *expected side's* observations: the reference if one of the two implementations is
  the reference, otherwise implementation A (the other's observations are only compared); each
  robot's action replaced with probability ``illegal_rate`` (default :data:`ILLEGAL_RATE`) by an
  illegal one, masked or out of range (F-DIFF-ACTIONS), so that R-ACTION-VALIDATION is exercised;
* hypothesis-generated joint-action sequences (:func:`hypothesis_search`, ``GenePolicy``):
  ``hypothesis.find`` searches for a sequence that makes the two diverge and shrinks it with
  hypothesis' own shrinker (integers towards 0 = idle, shorter lists = fewer ticks and robots);
* a symbolic script (``ScriptPolicy``) — what shrinking replays, resolved against the expected
  side's option lists of that tick exactly as the conformance suite resolves symbolic scripts
  (F-SYMBOLIC-ACTIONS: an option no longer offered makes the replay invalid, not idle).

The lockstep loop, the comparison and the divergence are the conformance harness's own
(:mod:`agspec.conform.lockstep.driver`); this module chooses the instances and the policies.

Instances: catalogue scenarios (suite indices 0, 1, …), instance IR files, and small generated
instances — each scenario's recipes and profile on a 1..3 x 2..4 grid (:func:`small_instances`).
"""

from __future__ import annotations

import copy
import random
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Callable, Iterable, Iterator, Mapping, Sequence

from hypothesis import HealthCheck, Phase, find, settings
from hypothesis import strategies as st
from hypothesis.errors import NoSuchExample

from agspec.campaign.executor import Done, ExecutorSpec, Task, run_ordered
from agspec.catalogue import load_scenario_bundle, read_instance_file
from agspec.conform.confirm import in_fresh_process, judge
from agspec.conform.impl import ImplSpecError, make_impl
from agspec.conform.lockstep.actions import GENE_RANGE, ControllerPolicy, GenePolicy, ScriptPolicy, with_illegal
from agspec.conform.lockstep.compare import Divergence, generalize
from agspec.conform.lockstep.driver import ImplementationFailure, JointAction, Pair, Run, error_kind, failure_message
from agspec.conform.lockstep.driver import lockstep, robot_order
from agspec.formats import limits
from agspec.formats.actions import is_idle
from agspec.ir.instance import make_instance
from agspec.ir.schemas import validate_schema
from agspec.ir.validate import errors, validate_instance

Json = dict[str, Any]
# F-DIFF-ACTIONS: the share of generated actions replaced by illegal ones (masked or out of range)
ILLEGAL_RATE = 0.05


# =============================================================================================
# the pair


def _label(spec: str) -> str:
    return spec if len(spec) <= 48 else spec[:45] + "..."


def open_pair(spec_a: str, spec_b: str, *, timeout: float = 5.0) -> Pair:
    """Start both implementations (``--impl`` values, agspec.conform.impl.make_impl) and hand-shake.

    Raises ValueError for an unusable spec (usage) and :class:`ImplementationFailure` when one cannot
    be started.  The expected side — whose observations the policies act on and whose values are
    expected — is the reference when exactly B is the reference, else A.
    """
    impls: list[Any] = []
    try:
        for side, spec in (("A", spec_a), ("B", spec_b)):
            try:
                impl = make_impl(spec, timeout=timeout)
            except ImplSpecError as exc:
                raise ValueError(str(exc)) from None
            impls.append(impl)
            try:
                impl.start()
            except Exception as exc:
                raise ImplementationFailure(side, error_kind(exc), f"implementation {side} ({spec}) cannot be "
                                            f"started: {error_kind(exc)}: {failure_message(exc)}") from exc
    except Exception:
        for impl in impls:
            try:
                impl.close()
            except Exception:
                pass
        raise
    if spec_b == "reference" and spec_a != "reference":
        return Pair(impls[1], impls[0], (_label(spec_b), _label(spec_a)), (spec_b, spec_a), expected_side="B")
    return Pair(impls[0], impls[1], (_label(spec_a), _label(spec_b)), (spec_a, spec_b), expected_side="A")


# =============================================================================================
# instances


@dataclass(frozen=True)
class Subject:
    """An instance to run episodes on, with a short label."""

    label: str
    instance: Json
    execution_seed: int | None


def catalogue_subjects(scenario: str, indices: Iterable[int]) -> list[Subject]:

    sc, recipes, profile = load_scenario_bundle(scenario)
    out = []
    for k in indices:
        inst = make_instance(sc, recipes, profile, index=k) if (sc.get("suite") or {}).get("generation_seed_base") \
            is not None else make_instance(sc, recipes, profile, generation_seed=k)
        out.append(Subject(f"{sc['id']}#{k}", inst, (inst.get("seeds") or {}).get("execution")))
    return out


def small_instances(scenario: str, count: int, seed: int) -> list[Subject]:
    """Small generated instances: the scenario's recipes and profile on a 1..3 x 2..4 grid, a short
    horizon and frequent releases; invalid or unrealizable draws are skipped."""

    sc, recipes, profile = load_scenario_bundle(scenario)
    rng = random.Random(f"{scenario}:{seed}")
    out: list[Subject] = []
    attempts = 0
    while len(out) < count and attempts < 20 * max(1, count):
        attempts += 1
        small = copy.deepcopy(sc)
        rows, cols = rng.randint(1, 3), rng.randint(2, 4)
        small["id"] = f"{sc['id']}-{rows}x{cols}"
        small["grid"] = {**small["grid"], "rows": rows, "cols": cols}
        small.pop("suite", None)
        small["release"] = {"interval": rng.choice([1, 2, 3, 5]), "wip_cap": rng.randint(1, 4)}
        small["evaluation"] = {"mode": "continuing", "horizon": rng.choice([20, 30, 40])}
        gen = rng.randrange(1, 10**6)
        try:
            inst = make_instance(small, recipes, profile, generation_seed=gen)
        except Exception:
            continue
        if errors(validate_schema(inst)) or errors(validate_instance(inst)):
            continue
        out.append(Subject(f"{small['id']}-g{gen}", inst, (inst.get("seeds") or {}).get("execution")))
    return out


def load_subjects(target: str, indices: Sequence[int] | int, seed: int, *, small: int = 0) -> list[Subject]:
    """Subjects for one ``--scenario`` value: an instance IR file, or a scenario (name or .ag path)
    at the suite ``indices`` (an int ``n``: indices 0..n-1) plus ``small`` generated small instances."""
    path = Path(target)
    if path.suffix == ".json" and path.exists():
        # F-LIMITS bounded reading, schema and S-INSTANCE checks (CatalogueError, InvalidInstanceError)
        data = read_instance_file(path)
        if data is None:
            raise limits.InputError("AG004", "not an instance IR (kind must be \"instance\")", file=target)
        return [Subject(data.get("id") or path.stem, data, (data.get("seeds") or {}).get("execution"))]
    out = catalogue_subjects(target, range(max(1, indices)) if isinstance(indices, int) else list(indices))
    if small:
        out += small_instances(target, small, seed)
    return out


# =============================================================================================
# exploration


@dataclass
class Finding:
    """A divergence found on one episode, before and after shrinking."""

    subject: Subject
    policy: str
    run: Run
    shrunk: Any = None  # agspec.conform.explore.shrink.Shrunk
    # F-CONFORM-HISTORY: per side ("A", "B"), the requests its process had received before this episode
    history: dict[str, Any] | None = None


@dataclass
class Exploration:
    episodes: int = 0
    ticks: int = 0
    states: int = 0
    hypothesis_examples: int = 0
    findings: list[Finding] = field(default_factory=list)
    errors: list[tuple[Subject, str]] = field(default_factory=list)  # subjects whose worker failed (CAMP-FAULTS)
    seconds: float = 0.0


@dataclass(frozen=True)
class Plan:
    """What every exploration item needs, shipped to the workers once per run (CAMP-SHIP-ONCE)."""

    subjects: tuple[Subject, ...]
    controllers: tuple[str, ...]
    seed: int
    ticks: int
    first_only: bool
    illegal_rate: float = ILLEGAL_RATE  # F-DIFF-ACTIONS


def histories(pair: Pair) -> dict[str, Any] | None:
    """What each side's process has received so far (F-CONFORM-HISTORY); None when a log overflowed."""
    out = {side: impl.requests.snapshot() for side, impl in pair.sides()}
    return None if any(h is None for h in out.values()) else out


def explore_subject(pair: Pair, plan: Plan, k: int) -> list[tuple[str, Run, dict[str, Any] | None]]:
    """One campaign item: the episodes of subject ``k``, one per controller (controller seed = ``seed``
    + ``k``), stopping at its first divergence when ``first_only``.  The runs travel back to the
    driver without the live parts (the exception object and the last replies), which the driver
    never reads, so a run is the same whether it was computed here or on a worker (CAMP-IDENTICAL)."""
    subject = plan.subjects[k]
    out: list[tuple[str, Run, dict[str, Any] | None]] = []
    for controller in plan.controllers:
        policy = with_illegal(ControllerPolicy(controller, plan.seed + k), plan.illegal_rate, plan.seed + k)
        before = histories(pair)
        run = lockstep(pair, subject.instance, subject.execution_seed, policy, plan.ticks)
        out.append((policy.name, replace(run, failure=None, replies=(None, None)), before))
        if run.divergence is not None and plan.first_only:
            break
    return out


def _explore_item(context: tuple[Pair, Plan], k: int) -> list[tuple[str, Run, dict[str, Any] | None]]:
    pair, plan = context
    return explore_subject(pair, plan, k)


def _open_worker_pair(shared: tuple[str, str, float, Plan]) -> tuple[Pair, Plan]:
    """Per worker: its own implementation pair, opened once and used for all its items (CAMP-EXECUTOR)."""
    spec_a, spec_b, timeout, plan = shared
    return open_pair(spec_a, spec_b, timeout=timeout), plan


def _close_worker_pair(context: tuple[Pair, Plan]) -> None:
    context[0].close()  # stops both of the worker's simulators (CAMP-CANCEL)


def inline(executor: ExecutorSpec | None) -> bool:
    """Whether the items run in this process, on the driver's own pair (``local`` with one worker)."""
    return executor is None or (executor.kind == "local" and (executor.jobs or 1) <= 1)


def explore(pair: Pair | None, subjects: Sequence[Subject], *, controllers: Sequence[str] = ("random", "greedy"),
            seed: int = 0, ticks: int = 60, on_episode: Callable[[str, Run], None] | None = None,
            first_only: bool = True, executor: ExecutorSpec | None = None, specs: tuple[str, str] = ("", ""),
            timeout: float = 5.0, illegal_rate: float = ILLEGAL_RATE) -> Exploration:
    """One episode per subject and controller; stops at the first finding when ``first_only``.

    One subject is one campaign item (spec chapter 14).  With one local worker the items run here on
    ``pair``; otherwise on ``executor``'s workers, each opening its own pair from ``specs`` (the two
    ``--impl`` values, A then B) and ``timeout``.  Results are consumed in subject order
    (CAMP-ORDER), so the exploration — and the first finding — is the same on every executor; the
    items computed beyond the first finding are discarded (RES-CAMP-DIFF).  A subject whose worker
    failed is in ``errors`` with the cause (CAMP-FAULTS).
    """
    result = Exploration()
    start = time.perf_counter()
    plan = Plan(tuple(subjects), tuple(controllers), seed, ticks, first_only, illegal_rate)
    if inline(executor):
        task = Task(_explore_item, (pair, plan))
    else:
        task = Task(_explore_item, (specs[0], specs[1], timeout, plan), _open_worker_pair, _close_worker_pair)
    outcomes = run_ordered(task, list(range(len(subjects))), executor)
    try:
        for k, outcome in outcomes:
            subject = subjects[k]
            if not isinstance(outcome, Done):
                result.errors.append((subject, f"worker failed: {outcome.message()}"))
                continue
            for name, run, before in outcome.value:
                result.episodes += 1
                result.ticks += run.ticks
                result.states += run.states
                if on_episode:
                    on_episode(f"{subject.label} {name}", run)
                if run.divergence is not None:
                    result.findings.append(Finding(subject, name, run, history=before))
            if first_only and result.findings:
                break
    finally:
        outcomes.close()  # the first finding, an error or Ctrl-C: cancel the rest, stop the workers (CAMP-CANCEL)
    result.seconds = time.perf_counter() - start
    return result


def hypothesis_search(pair: Pair, subjects: Sequence[Subject], *, examples: int, ticks: int, seed: int,
                      max_robots: int = 64, illegal_rate: float = ILLEGAL_RATE) -> tuple[Finding | None, int]:
    """Search joint-action sequences with ``hypothesis.find``; returns the finding (already shrunk by
    hypothesis) and the number of sequences tried."""

    if not subjects or examples <= 0:
        return None, 0
    genes = st.integers(min_value=0, max_value=GENE_RANGE - 1)
    strategy = st.tuples(
        st.integers(min_value=0, max_value=len(subjects) - 1),
        st.lists(st.lists(genes, max_size=max_robots), min_size=1, max_size=max(1, ticks)),
    )
    tried = 0

    def diverges(example) -> bool:
        nonlocal tried
        tried += 1
        k, seq = example
        subject = subjects[k]
        run = lockstep(pair, subject.instance, subject.execution_seed, GenePolicy(seq, illegal_rate), len(seq))
        return run.divergence is not None

    config = settings(max_examples=examples, database=None, deadline=None, derandomize=False,
                      phases=[Phase.generate, Phase.shrink], suppress_health_check=list(HealthCheck),
                      report_multiple_bugs=False)
    try:
        k, seq = find(strategy, diverges, settings=config, random=random.Random(seed))
    except NoSuchExample:
        return None, tried
    subject = subjects[k]
    before = histories(pair)
    run = lockstep(pair, subject.instance, subject.execution_seed, GenePolicy(seq, illegal_rate), len(seq))
    if run.divergence is None:  # not reproducible (a flaky implementation): report nothing shrunk
        return None, tried
    return Finding(subject, "hypothesis", run, history=before), tried


def replay(pair: Pair, instance: Mapping[str, Any], execution_seed: int | None, script: Sequence[JointAction],
           ticks: int | None = None) -> Run:
    """Replay a symbolic script on both sides (what shrinking and saved cases do)."""
    n = len(script) if ticks is None else ticks
    return lockstep(pair, instance, execution_seed, ScriptPolicy(script), n, stop_at_done=False)


def _fresh_replay(specs: tuple[str, str], timeout: float, instance: Mapping[str, Any], execution_seed: int | None,
                  script: Sequence[JointAction], ticks: int, history: dict[str, Any] | None) -> dict[str, Any]:
    pair = open_pair(specs[0], specs[1], timeout=timeout)
    try:
        if history:
            pair.send_history(history)
        run = replay(pair, instance, execution_seed, script, ticks)
    finally:
        pair.close()
    got = run.divergence
    return {"diverged": got is not None, "tick": got.tick if got else None, "where": got.where if got else None,
            "pointer": got.pointer if got else None, "signature": list(got.signature()) if got else None}


def fresh_replay(specs: tuple[str, str], timeout: float, instance: Mapping[str, Any], execution_seed: int | None,
                 script: Sequence[JointAction], ticks: int, history: dict[str, Any] | None = None) -> dict[str, Any]:
    """Replay ``script`` in a pair of new implementations — new processes, and a new Python process when a
    side is an in-process adapter — after each side's ``history`` when given: a failure is judged the way
    ``agspec conform`` judges its own (F-CONFORM-NONDETERMINISM, F-CONFORM-HISTORY).  The outcome as a
    plain record; a replay that cannot run is one that did not reproduce."""
    try:
        return in_fresh_process(any(s.startswith("python:") for s in specs), _fresh_replay, specs, timeout, instance,
                                execution_seed, list(script), ticks, history)
    except Exception as exc:
        return {"diverged": False, "error": f"{type(exc).__name__}: {exc}", "signature": None}


def judge_divergence(specs: tuple[str, str], timeout: float, instance: Mapping[str, Any], execution_seed: int | None,
                     script: Sequence[JointAction], divergence: Divergence, ticks: int,
                     history: dict[str, Any] | None, replays: int = 1) -> tuple[str, list[dict[str, Any]],
                                                                                  list[dict[str, Any]]]:
    """The one judgement of :func:`agspec.conform.confirm.judge` on a divergence of ``agspec diff``:
    REPRODUCED, HISTORY_DEPENDENT or NONDETERMINISTIC, with the fresh replays alone and with the history."""
    want = list(divergence.signature())

    def again(with_history: bool) -> dict[str, Any]:
        out = fresh_replay(specs, timeout, instance, execution_seed, script, ticks, history if with_history else None)
        out["same"] = out.get("signature") == want
        return out

    has_history = bool(history) and any(history.values())
    return judge(want, again, lambda r: r.get("signature"), replays=replays, has_history=has_history)


def non_idle(script: Sequence[JointAction]) -> Iterator[tuple[int, str, Any]]:
    for t, joint in enumerate(script):
        for robot in robot_order(joint):
            if not is_idle(joint[robot]):
                yield t, robot, joint[robot]


def describe_action(action: Any) -> str:
    if isinstance(action, Mapping) and len(action) == 1:
        (kind, arg), = action.items()
        return f"{kind} {arg}"
    return str(action)


__all__ = [
    "Divergence", "Pair", "Run", "Subject", "Finding", "Exploration", "ControllerPolicy", "ScriptPolicy",
    "GenePolicy", "lockstep", "replay", "explore", "hypothesis_search", "load_subjects", "catalogue_subjects",
    "small_instances", "Plan", "explore_subject", "inline", "non_idle", "describe_action", "generalize",
    "fresh_replay", "histories", "judge_divergence",
    "ImplementationFailure", "open_pair",
    "JointAction", "is_idle",
]
