"""Differential testing: two implementations in lockstep on generated episodes (issue 4, part 5).

``agspec diff --impl A --impl B`` resets both implementations on the same instance and execution
seed, sends both the same joint action every tick and compares what they answer — the canonical
global state (O-GLOBAL-STATE), the events of the tick, the observations and masks when both declare
the capability, and the end flag — field by field.  The first difference is a :class:`Divergence`
(tick, JSON Pointer, expected vs actual).  :mod:`agspec.conform.shrink` then reduces the episode to a
minimal counterexample that is printed and saved as a replayable conformance case.

Where the joint actions come from (:class:`Policy`):

* seeded controllers — ``random`` (C-RANDOM, uniform over the mask) and ``greedy`` (C-GREEDY) —
  acting on the *driver's* observations: the reference if one of the two implementations is the
  reference, otherwise implementation A (B's observations are only compared, never used);
* hypothesis-generated joint-action sequences (:func:`hypothesis_search`): per tick and robot a
  non-negative integer, mapped onto the robot's legal actions ``legal[g mod |legal|]`` (legal in
  ascending order, so 0 is idle).  ``hypothesis.find`` searches for a sequence that makes the two
  diverge and shrinks it with hypothesis' own shrinker (integers towards 0 = idle, shorter lists =
  fewer ticks and robots);
* a symbolic script (:class:`ScriptPolicy`) — what shrinking replays: ``{"pick": id}``,
  ``{"support": candidate id}``, ``{"handoff": "E"}``, ``{"receive": "W"}``, ``"deliver"``,
  ``"idle"`` or an integer, resolved against the driver's option lists of that tick exactly as the
  conformance suite resolves symbolic scripts, so that dropping an earlier tick does not change
  what a later action means.

Instances: catalogue scenarios (suite indices 0, 1, …), instance IR files, and small generated
instances — each scenario's recipes and profile on a 1..3 x 2..4 grid (:func:`small_instances`).
"""

from __future__ import annotations

import copy
import random
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Iterable, Iterator, Mapping, Protocol, Sequence

from agspec.conform.compare import MISSING as _MISSING
from agspec.conform.compare import compare_reply as _compare_reply
from agspec.formats import limits

IDLE, DELIVER, PICK0, HANDOFF0, RECEIVE0, OP0 = 0, 1, 2, 34, 42, 50
PICK_SLOTS, OP_SLOTS = 32, 64
DIRECTIONS = ("N", "NE", "E", "SE", "S", "SW", "W", "NW")

Json = dict[str, Any]
JointAction = dict[str, Any]  # robot id -> int or symbolic action


class Implementation(Protocol):
    """The interface of agspec.conform.impl (CONFORM.md): what the lockstep driver needs."""

    info: Json

    def load(self, instance: Mapping[str, Any]) -> Any: ...

    def reset(self, seed: int | None) -> Json: ...

    def step(self, actions: Mapping[str, int]) -> Json: ...

    def close(self) -> None: ...


# =============================================================================================
# divergences


@dataclass(frozen=True)
class Divergence:
    """The first difference between the two implementations.

    ``tick`` is the epoch whose step produced it (the case format's ``after_tick``); -1 means the
    replies to ``reset``.  ``where`` is a part of agspec.conform.compare.COMPARED or ``"error"`` (one
    side failed: crash, timeout, protocol error — ``pointer`` is then ``kind/code`` and ``side`` the
    failing one).
    ``pointer`` is a JSON Pointer into the compared record (the global state, the event list,
    ``{robot: observation}``, ``{robot: mask}``).  ``expected`` is the driver's value (the reference
    when one side is the reference), ``actual`` the other's.
    """

    tick: int
    where: str
    pointer: str
    expected: Any
    actual: Any
    message: str = ""
    side: str = ""  # "A" or "B" for errors

    def signature(self) -> tuple[str, str]:
        """What must stay the same while shrinking: the compared part and the pointer with every token
        holding a digit generalised (``/robots/0,1/holding`` -> ``/robots/*/holding``)."""
        if self.where == "error":
            return ("error", f"{self.side}:{self.pointer}")
        return (self.where, generalize(self.pointer))

    def show(self, expected_label: str = "expected", actual_label: str = "actual") -> str:
        if self.where == "error":
            return f"{self.message}"
        at = "after reset" if self.tick < 0 else f"after tick {self.tick}"
        width = max(len(expected_label), len(actual_label))
        return (f"{at}: {self.where} {self.pointer or '(whole)'}\n"
                f"    {expected_label:<{width}} : {show_value(self.expected)}\n"
                f"    {actual_label:<{width}} : {show_value(self.actual)}")

    def to_json(self) -> Json:
        return {"tick": self.tick, "where": self.where, "pointer": self.pointer,
                "expected": None if self.expected is _MISSING else self.expected,
                "actual": None if self.actual is _MISSING else self.actual,
                "expected_absent": self.expected is _MISSING, "actual_absent": self.actual is _MISSING,
                "message": self.message, "side": self.side or None}


def generalize(pointer: str) -> str:
    return "/".join("*" if any(ch.isdigit() for ch in tok) else tok for tok in pointer.split("/"))


def show_value(value: Any, limit: int = 200) -> str:
    import json

    if value is _MISSING:
        return "<absent>"
    text = json.dumps(value, sort_keys=True, ensure_ascii=False)
    return text if len(text) <= limit else text[: limit - 3] + "..."


class ImplementationFailure(Exception):
    """Raised by the lockstep driver when one implementation fails (wraps the underlying error)."""

    def __init__(self, side: str, kind: str, message: str):
        super().__init__(message)
        self.side, self.kind, self.message = side, kind, message


def error_kind(exc: BaseException) -> str:
    """A stable kind for an implementation failure: ``category/code`` of a ProtocolError
    (F-PROTOCOL-ERRORS, e.g. ``crash/eof``, ``timeout/timeout``, ``protocol/wrong_seq``), else a
    classification of the exception."""
    kind, code = getattr(exc, "kind", None), getattr(exc, "code", None)
    if isinstance(kind, str) and kind:
        return f"{kind}/{code}" if isinstance(code, str) and code and code != kind else kind
    if isinstance(code, str) and code:
        return code
    if isinstance(exc, TimeoutError):
        return "timeout"
    if isinstance(exc, (EOFError, BrokenPipeError, ConnectionError)):
        return "crash"
    return type(exc).__name__


def _message(exc: BaseException) -> str:
    """The failure's message, with the last lines of the simulator's stderr when it left any."""
    message = getattr(exc, "message", None)
    text = message if isinstance(message, str) and message else str(exc)
    stderr = getattr(exc, "stderr", None)
    if isinstance(stderr, str) and stderr.strip():
        tail = stderr.strip().splitlines()[-5:]
        text += "\n    stderr of the simulator:\n" + "\n".join(f"      | {line}" for line in tail)
    return text


def compare_replies(tick: int, exp: Mapping[str, Any], act: Mapping[str, Any],
                    parts: Sequence[str]) -> Divergence | None:
    """The first difference of two replies (agspec.conform.compare.compare_reply, in its COMPARED order)
    over ``parts``; the
    optional ``applied`` map is compared only when both replies carry it, ``done`` only after a step."""
    use = [p for p in parts if not (p == "done" and tick < 0)]
    if "applied" in exp and "applied" in act:
        use.append("applied")
    d = _compare_reply(tick, exp, act, use)
    if d is None:
        return None
    one_sided = not d.pointer and (d.expected is _MISSING or d.actual is _MISSING)
    return Divergence(d.tick, d.where, d.pointer, d.expected, d.actual,
                      f"{d.where} present on one side only" if one_sided else "")


# =============================================================================================
# policies: where the joint actions come from


def legal_actions(mask: Sequence[Any]) -> list[int]:
    return [a for a, ok in enumerate(mask) if ok]


def robot_order(robots: Iterable[str]) -> list[str]:
    return sorted(robots, key=lambda r: tuple(int(x) for x in r.split(",")))


def symbolic(action: int, obs: Mapping[str, Any] | None) -> Any:
    """The symbolic form of an action integer against one robot's observation (its option lists)."""
    if action == IDLE:
        return "idle"
    if action == DELIVER:
        return "deliver"
    if HANDOFF0 <= action < HANDOFF0 + 8:
        return {"handoff": DIRECTIONS[action - HANDOFF0]}
    if RECEIVE0 <= action < RECEIVE0 + 8:
        return {"receive": DIRECTIONS[action - RECEIVE0]}
    if obs is not None and PICK0 <= action < PICK0 + PICK_SLOTS:
        picks = obs.get("pick_options") or []
        if action - PICK0 < len(picks):
            return {"pick": picks[action - PICK0]["id"]}
    if obs is not None and OP0 <= action < OP0 + OP_SLOTS:
        ops = obs.get("operation_options") or []
        if action - OP0 < len(ops):
            return {"support": ops[action - OP0]["id"]}
    return int(action)


def resolve(action: Any, obs: Mapping[str, Any] | None) -> int:
    """Resolve a symbolic action against one robot's observation; an option that no longer exists
    becomes idle (the script's intent cannot be expressed at this tick)."""
    if isinstance(action, bool):
        raise TypeError("an action is an int or a symbolic action")
    if isinstance(action, int):
        return action
    if action == "idle":
        return IDLE
    if action == "deliver":
        return DELIVER
    if isinstance(action, Mapping) and len(action) == 1:
        (kind, arg), = action.items()
        if kind == "handoff":
            return HANDOFF0 + DIRECTIONS.index(arg)
        if kind == "receive":
            return RECEIVE0 + DIRECTIONS.index(arg)
        if obs is None:
            return IDLE
        if kind == "pick":
            ids = [p["id"] for p in obs.get("pick_options") or []]
            return PICK0 + ids.index(arg) if arg in ids else IDLE
        if kind == "support":
            ids = [o["id"] for o in obs.get("operation_options") or []]
            return OP0 + ids.index(arg) if arg in ids else IDLE
    raise ValueError(f"not an action: {action!r}")


def is_idle(action: Any) -> bool:
    return action == IDLE or action == "idle"


class Policy(Protocol):
    name: str

    def reset(self) -> None: ...

    def act(self, t: int, observations: Mapping[str, Any] | None, robots: Sequence[str]) -> dict[str, int]: ...


class ControllerPolicy:
    """A seeded reference controller (C-RANDOM, C-GREEDY, C-PARALLEL-AWARE) on the driver's observations."""

    def __init__(self, controller: str, seed: int | None):
        from agspec.controllers import make_controller

        if controller == "centralized":
            raise ValueError("the centralized controller needs privileged state; diff drives local controllers")
        self.name = f"{controller}(seed={seed})"
        self.controller, self.seed = controller, seed
        self._ctl = make_controller(controller, seed)

    def reset(self) -> None:
        self._ctl.reset(self.seed)

    def act(self, t: int, observations, robots) -> dict[str, int]:
        if observations is None:
            raise ValueError("controllers need observations from the driving implementation")
        return {r: int(a) for r, a in self._ctl.act(observations).items()}


class ScriptPolicy:
    """A fixed (symbolic) script; ticks past its end are idle."""

    name = "script"

    def __init__(self, script: Sequence[Mapping[str, Any]]):
        self.script = [dict(j) for j in script]

    def reset(self) -> None:
        pass

    def act(self, t: int, observations, robots) -> dict[str, int]:
        joint = self.script[t] if t < len(self.script) else {}
        out = {}
        for robot, action in joint.items():
            obs = observations.get(robot) if observations else None
            a = resolve(action, obs)
            if a != IDLE:
                out[robot] = a
        return out


class GenePolicy:
    """Hypothesis genes: per tick, per robot (row-major) an integer g -> legal[g mod |legal|]."""

    name = "hypothesis"

    def __init__(self, genes: Sequence[Sequence[int]]):
        self.genes = [list(g) for g in genes]

    def reset(self) -> None:
        pass

    def act(self, t: int, observations, robots) -> dict[str, int]:
        genes = self.genes[t] if t < len(self.genes) else []
        out = {}
        for k, robot in enumerate(robots):
            if k >= len(genes) or genes[k] == 0:
                continue
            obs = (observations or {}).get(robot)
            mask = (obs or {}).get("mask")
            if mask is None:
                continue
            legal = legal_actions(mask)
            a = legal[genes[k] % len(legal)]
            if a != IDLE:
                out[robot] = a
        return out


# =============================================================================================
# lockstep


@dataclass
class Pair:
    """Two implementations compared in lockstep; ``driver`` ("A" or "B") provides the observations
    the policies act on, and its values are the *expected* ones."""

    a: Implementation
    b: Implementation
    label_a: str
    label_b: str
    driver: str = "A"
    shadow_factory: Callable[[], Any] | None = None  # an in-process reference when no side observes

    def __post_init__(self) -> None:
        self._loaded: dict[str, str] = {}
        self.specs: tuple[str, str] = (self.label_a, self.label_b)

    @property
    def other_spec(self) -> str:
        """The ``--impl`` value of the side whose values are compared against the expected ones."""
        return self.specs[1] if self.driver == "A" else self.specs[0]

    @property
    def expected(self):
        return self.a if self.driver == "A" else self.b

    @property
    def other(self):
        return self.b if self.driver == "A" else self.a

    @property
    def expected_label(self) -> str:
        return self.label_a if self.driver == "A" else self.label_b

    @property
    def actual_label(self) -> str:
        return self.label_b if self.driver == "A" else self.label_a

    def side_of(self, impl) -> str:
        return "A" if impl is self.a else "B"

    def capabilities(self, impl) -> Mapping[str, Any]:
        caps = getattr(impl, "capabilities", None)
        if isinstance(caps, Mapping) and caps:
            return caps
        info = getattr(impl, "info", None) or {}
        return info.get("capabilities") or {}

    def parts(self) -> list[str]:
        """What is compared: state and events always, the rest when both sides provide it."""
        ca, cb = self.capabilities(self.a), self.capabilities(self.b)
        parts = ["t", "done"]
        for part, cap in (("state", "privileged_state"), ("events", "events"), ("observations", "observations"),
                          ("masks", "masks")):
            if ca.get(cap, False) and cb.get(cap, False):
                parts.append(part)
        return parts

    def load(self, instance: Mapping[str, Any]) -> None:
        from agspec.ir.fingerprint import fingerprint

        fp = fingerprint(instance)
        for side, impl in (("A", self.a), ("B", self.b)):
            if self._loaded.get(side) != fp:
                self._call(side, impl.load, instance)
                self._loaded[side] = fp

    def _call(self, side: str, fn, *args):
        try:
            return fn(*args)
        except Exception as exc:  # crash, timeout, protocol error: a divergence of kind "error"
            self._loaded.pop(side, None)
            raise ImplementationFailure(side, error_kind(exc), f"implementation {side} "
                                        f"({self.label_a if side == 'A' else self.label_b}) failed: "
                                        f"{error_kind(exc)}: {_message(exc)}") from exc

    def close(self) -> None:
        for impl in (self.a, self.b):
            try:
                impl.close()
            except Exception:
                pass


def _label(spec: str) -> str:
    return spec if len(spec) <= 48 else spec[:45] + "..."


def open_pair(spec_a: str, spec_b: str, *, timeout: float = 5.0) -> Pair:
    """Start both implementations (``--impl`` values, agspec.conform.impl.make_impl) and hand-shake.

    Raises ValueError for an unusable spec (usage) and :class:`ImplementationFailure` when one cannot
    be started.  The driver — whose observations the policies act on and whose values are expected —
    is the reference when exactly B is the reference, else A.
    """
    from agspec.conform.impl import ImplSpecError, make_impl

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
                                            f"started: {error_kind(exc)}: {_message(exc)}") from exc
    except Exception:
        for impl in impls:
            try:
                impl.close()
            except Exception:
                pass
        raise
    driver = "B" if spec_b == "reference" and spec_a != "reference" else "A"
    pair = Pair(impls[0], impls[1], _label(spec_a), _label(spec_b), driver=driver)
    pair.specs = (spec_a, spec_b)
    return pair


@dataclass
class Run:
    """One lockstep episode: the joint actions sent (integers and their symbolic form) and the first
    divergence, if any."""

    divergence: Divergence | None
    actions: list[dict[str, int]] = field(default_factory=list)
    script: list[JointAction] = field(default_factory=list)  # symbolic, against the driver's options
    ticks: int = 0
    coerced: int = 0  # actions the driver coerced to idle (R-ACTION-VALIDATION)
    states: int = 0
    both_failed: str = ""  # both sides refused the same step the same way (e.g. slot_overflow): not a divergence


def lockstep(pair: Pair, instance: Mapping[str, Any], execution_seed: int | None, policy: Policy,
             ticks: int, *, stop_at_done: bool = True) -> Run:
    """Run both implementations for up to ``ticks`` steps; stop at the first divergence."""
    parts = pair.parts()
    run = Run(None)
    exp_impl, oth_impl = pair.expected, pair.other
    es, os_ = pair.side_of(exp_impl), pair.side_of(oth_impl)
    try:
        pair.load(instance)
        exp = pair._call(es, exp_impl.reset, execution_seed)
        oth = pair._call(os_, oth_impl.reset, execution_seed)
    except ImplementationFailure as failure:
        run.divergence = Divergence(-1, "error", failure.kind, None, None, failure.message, failure.side)
        return run
    shadow = None
    if exp.get("observations") is None:
        shadow = _Shadow(instance, execution_seed) if pair.shadow_factory is None else pair.shadow_factory()
    run.divergence = compare_replies(-1, exp, oth, parts)
    run.states = 1
    if run.divergence is not None:
        return run
    policy.reset()
    robots = robot_order((exp.get("state") or {}).get("robots") or {})
    for t in range(ticks):
        if stop_at_done and exp.get("done"):
            break
        observations = exp.get("observations") if shadow is None else shadow.observations()
        joint = policy.act(t, observations, robots)
        joint = {r: int(a) for r, a in joint.items() if int(a) != IDLE}
        run.actions.append(joint)
        run.script.append({r: symbolic(a, (observations or {}).get(r)) for r, a in joint.items()})
        try:
            exp = pair._call(es, exp_impl.step, joint)
        except ImplementationFailure as failure:
            # the expected side failed: a divergence only if the other side does not fail the same way
            try:
                pair._call(os_, oth_impl.step, joint)
                same = False
            except ImplementationFailure as other:
                same = other.kind == failure.kind
            run.ticks = t + 1
            if not same:
                run.divergence = Divergence(t, "error", failure.kind, None, None, failure.message, failure.side)
            else:
                run.both_failed = failure.message
            return run
        try:
            oth = pair._call(os_, oth_impl.step, joint)
        except ImplementationFailure as failure:
            run.divergence = Divergence(t, "error", failure.kind, None, None, failure.message, failure.side)
            run.ticks = t + 1
            return run
        if shadow is not None:
            shadow.step(joint)
        for robot, a in joint.items():
            masks = (observations or {}).get(robot, {}).get("mask") if observations else None
            if masks is not None and not (0 <= a < len(masks) and masks[a]):
                run.coerced += 1
        run.ticks = t + 1
        run.states += 1
        run.divergence = compare_replies(t, exp, oth, parts)
        if run.divergence is not None:
            return run
    return run


class _Shadow:
    """An in-process reference interpreter that supplies observations when the driver has none."""

    def __init__(self, instance: Mapping[str, Any], seed: int | None):
        from agspec.interp.tick import Simulator

        self.sim = Simulator(instance)
        self.sim.reset(seed)

    def observations(self) -> Json:
        return self.sim.observe()

    def step(self, joint: Mapping[str, int]) -> None:
        self.sim.step(joint)


# =============================================================================================
# instances


@dataclass(frozen=True)
class Subject:
    """An instance to run episodes on, with a short label."""

    label: str
    instance: Json
    execution_seed: int | None


def catalogue_subjects(scenario: str, indices: Iterable[int]) -> list[Subject]:
    from agspec.catalogue import load_scenario_bundle
    from agspec.ir.instance import make_instance

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
    from agspec.catalogue import load_scenario_bundle
    from agspec.ir.instance import make_instance
    from agspec.ir.schemas import validate_schema
    from agspec.ir.validate import errors, validate_instance

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


def load_subjects(target: str, episodes: int, seed: int, *, small: int = 0) -> list[Subject]:
    """Subjects for one ``--scenario`` value: an instance IR file, or a scenario (name or .ag path)
    with suite indices 0..episodes-1 plus ``small`` generated small instances."""
    from pathlib import Path

    from agspec.catalogue import read_instance_file

    path = Path(target)
    if path.suffix == ".json" and path.exists():
        # F-LIMITS bounded reading, schema and S-INSTANCE checks (CatalogueError, InvalidInstanceError)
        data = read_instance_file(path)
        if data is None:
            raise limits.InputError("AG004", "not an instance IR (kind must be \"instance\")", file=target)
        return [Subject(data.get("id") or path.stem, data, (data.get("seeds") or {}).get("execution"))]
    out = catalogue_subjects(target, range(max(1, episodes)))
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
    shrunk: Any = None  # agspec.conform.shrink.Shrunk


@dataclass
class Exploration:
    episodes: int = 0
    ticks: int = 0
    states: int = 0
    hypothesis_examples: int = 0
    findings: list[Finding] = field(default_factory=list)
    seconds: float = 0.0


def explore(pair: Pair, subjects: Sequence[Subject], *, controllers: Sequence[str] = ("random", "greedy"),
            seed: int = 0, ticks: int = 60, on_episode: Callable[[str, Run], None] | None = None,
            first_only: bool = True) -> Exploration:
    """One episode per subject and controller (controller seed = ``seed`` + the subject's position);
    stops at the first finding when ``first_only``."""
    result = Exploration()
    start = time.perf_counter()
    for k, subject in enumerate(subjects):
        for controller in controllers:
            policy = ControllerPolicy(controller, seed + k)
            run = lockstep(pair, subject.instance, subject.execution_seed, policy, ticks)
            result.episodes += 1
            result.ticks += run.ticks
            result.states += run.states
            if on_episode:
                on_episode(f"{subject.label} {policy.name}", run)
            if run.divergence is not None:
                result.findings.append(Finding(subject, policy.name, run))
                if first_only:
                    break
        if first_only and result.findings:
            break
    result.seconds = time.perf_counter() - start
    return result


def hypothesis_search(pair: Pair, subjects: Sequence[Subject], *, examples: int, ticks: int, seed: int,
                      max_robots: int = 64) -> tuple[Finding | None, int]:
    """Search joint-action sequences with ``hypothesis.find``; returns the finding (already shrunk by
    hypothesis) and the number of sequences tried."""
    from hypothesis import HealthCheck, Phase, find, settings
    from hypothesis import strategies as st
    from hypothesis.errors import NoSuchExample

    if not subjects or examples <= 0:
        return None, 0
    genes = st.integers(min_value=0, max_value=2**16 - 1)
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
        run = lockstep(pair, subject.instance, subject.execution_seed, GenePolicy(seq), len(seq))
        return run.divergence is not None

    config = settings(max_examples=examples, database=None, deadline=None, derandomize=False,
                      phases=[Phase.generate, Phase.shrink], suppress_health_check=list(HealthCheck),
                      report_multiple_bugs=False)
    try:
        k, seq = find(strategy, diverges, settings=config, random=random.Random(seed))
    except NoSuchExample:
        return None, tried
    subject = subjects[k]
    run = lockstep(pair, subject.instance, subject.execution_seed, GenePolicy(seq), len(seq))
    if run.divergence is None:  # not reproducible (a flaky implementation): report nothing shrunk
        return None, tried
    return Finding(subject, "hypothesis", run), tried


def replay(pair: Pair, instance: Mapping[str, Any], execution_seed: int | None, script: Sequence[JointAction],
           ticks: int | None = None) -> Run:
    """Replay a symbolic script on both sides (what shrinking and saved cases do)."""
    n = len(script) if ticks is None else ticks
    return lockstep(pair, instance, execution_seed, ScriptPolicy(script), n, stop_at_done=False)


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
    "Divergence", "Pair", "Run", "Subject", "Finding", "Exploration", "Policy", "ControllerPolicy", "ScriptPolicy",
    "GenePolicy", "lockstep", "replay", "explore", "hypothesis_search", "load_subjects", "catalogue_subjects",
    "small_instances", "compare_replies", "symbolic", "resolve", "non_idle", "describe_action", "generalize",
    "ImplementationFailure", "open_pair",
]
