"""One episode of a policy on the reference interpreter, here, in this process (F-POLICY-RUNNER).

:func:`run_episode` drives the reference interpreter with a reference controller or a user policy
(optionally writing a trace); :func:`run_here` runs one campaign :class:`Job` that way and returns its
results-bundle record.  This is the floor every process that plays an episode imports: the campaign's
dispatcher (:mod:`agspec.evaluate`), a policy host's child (:mod:`agspec.policy.host`) and the fresh
process of a repeat (:mod:`agspec.policy.fresh`), so that the children never import the dispatcher
that starts them.
"""

from __future__ import annotations

import hashlib
import json
import time
from dataclasses import dataclass
from typing import Any, Callable, Mapping

from agspec.formats.actions import NotAnAction, action_value
from agspec.interp.observe import N_ACTIONS
from agspec.interp.snapshot import global_state
from agspec.ir.fingerprint import fingerprint
from agspec.policy.contract import PolicyError, PolicySpec, PolicySpecError
from agspec.policy.sessions import open_session

DEFAULT_LOAD_TIMEOUT = 600.0  # seconds to import a policy module and call its factory (F-POLICY-HOST)


@dataclass(frozen=True)
class EpisodeResult:
    instance_id: str
    controller: str
    metrics: dict[str, Any]
    illegal_actions: int = 0  # masked actions executed as idle (R-ACTION-VALIDATION, F-POLICY-ILLEGAL)
    actions_digest: str = ""  # sha256 of the joint actions in tick order (F-POLICY-DETERMINISM)


def as_policy(policy: str | PolicySpec) -> PolicySpec:
    """A reference controller name or a PolicySpec (F-POLICY-SPEC)."""
    return policy if isinstance(policy, PolicySpec) else PolicySpec("controller", policy, policy)


def check_joint(raw: Any, agents: list[str], t: int) -> dict[str, int]:
    """F-POLICY-ERRORS: a joint action names every agent once with an integer in 0..113 (O-ACTION-ENCODING)."""
    if not isinstance(raw, Mapping):
        raise PolicyError("bad_action", f"the policy returned {type(raw).__name__}, not a mapping agent -> action",
                          tick=t)
    known = set(agents)
    for agent in raw:
        if agent not in known:
            raise PolicyError("unknown_agent", f"action for unknown agent {agent!r}; agents are robot ids such as "
                                               f"{agents[0]!r}", tick=t, agent=str(agent))
    joint: dict[str, int] = {}
    for agent in agents:
        if agent not in raw:  # RES-POLICY-MISSING-AGENT: unlike A-PZ-STEP, never an implicit idle
            raise PolicyError("missing_agent", f"no action for agent {agent!r}", tick=t, agent=agent)
        try:  # RES-INTEGRAL-ACTIONS: 2, 2.0 and 2e0 are the action 2 (F-VALUES)
            value = action_value(raw[agent])
        except NotAnAction as exc:
            raise PolicyError("bad_action", f"agent {agent!r}: {exc}; an action is an integer in 0..{N_ACTIONS - 1}",
                              tick=t, agent=agent) from None
        if not 0 <= value < N_ACTIONS:
            raise PolicyError("bad_action", f"action {value!r} of agent {agent!r} is not an integer in "
                                            f"0..{N_ACTIONS - 1}", tick=t, agent=agent)
        joint[agent] = value
    return joint


def run_episode(
    instance: Mapping[str, Any],
    controller: str | PolicySpec = "greedy",
    *,
    horizon: int | None = None,
    seed: int | None = None,
    trace=None,
    observations_in_trace: bool = False,
    on_tick: Callable[[int, int], None] | None = None,
    strict: bool = False,
    timeout: float | None = None,
    load_timeout: float | None = None,
    guard: Callable[[str, str, int | None], Any] | None = None,
    scenario: str | None = None,
    index: int | None = None,
) -> EpisodeResult:
    """Run one episode of a reference controller or a user policy (F-POLICY-RUNNER), in this process.

    ``trace`` is an optional TraceWriter; ``horizon`` may shorten the run.  A misbehaving policy
    raises :class:`~agspec.policy.contract.PolicyError` (F-POLICY-ERRORS); a masked action is
    executed as idle and counted, or raises under ``strict`` (F-POLICY-ILLEGAL).  ``timeout``
    bounds each decision, ``load_timeout`` the loading of a Python policy; ``guard`` replaces the
    in-process alarm that enforces both (F-POLICY-HOST).
    """
    spec = as_policy(controller)
    # F-POLICY-EVALUATION: the instance's own execution seed (S-SEEDS) and the scenario horizon
    exec_seed = seed if seed is not None else instance.get("seeds", {}).get("execution")
    session = open_session(spec, instance, exec_seed, timeout=timeout, load_timeout=load_timeout, guard=guard,
                           scenario=scenario, index=index)
    try:
        sim = session.sim
        agents = sim.agents()
        limit = sim.model.horizon if horizon is None else min(horizon, sim.model.horizon)
        if trace is not None:
            trace.header(
                instance=instance,
                fingerprint=fingerprint(instance),
                execution_seed=exec_seed,
                controller={"name": session.name, "information": session.information},
                initial_state=global_state(sim.state),
                initial_events=sim.reset_events,
                horizon=limit,
            )
        digest = hashlib.sha256()
        illegal = 0
        while not sim.done and sim.t < limit:
            t = sim.t
            joint = check_joint(session.act(), agents, t)
            digest.update(json.dumps([joint[a] for a in agents]).encode())
            step = session.step(joint)
            coerced = [a for a in agents if step.applied[a] != joint[a]]
            if coerced and strict:
                a = coerced[0]
                raise PolicyError("illegal_action", f"action {joint[a]} of agent {a!r} is masked (O-MASK); "
                                                    "--strict makes this an error", tick=t, agent=a)
            illegal += len(coerced)
            if trace is not None:
                trace.tick(
                    t=t,
                    actions=step.applied,
                    events=step.events,
                    state=global_state(sim.state),
                    observations=session.observations if observations_in_trace else None,
                    chosen={a: joint[a] for a in coerced},  # F-TRACE: pairs with action_coerced
                )
            if on_tick is not None:
                on_tick(sim.t, limit)
        metrics = sim.final_metrics()
        if trace is not None:
            trace.footer(metrics=metrics)
        return EpisodeResult(instance.get("id", "?"), spec.label, metrics, illegal, digest.hexdigest())
    finally:
        session.close()


@dataclass(frozen=True)
class Job:
    """One episode of a campaign: which policy on which instance, and how (F-POLICY-RUNNER)."""

    scenario: str
    index: int
    policy: PolicySpec
    instance: Mapping[str, Any]
    strict: bool = False
    timeout: float | None = None  # seconds per decision (F-POLICY-ERRORS)
    repeat: bool = False  # a second run of the same episode, for F-POLICY-DETERMINISM
    load_timeout: float | None = None  # seconds to load a Python policy (None: the default, F-POLICY-HOST)


def job_record(job: Job, started: float, result: EpisodeResult | None = None,
               error: PolicyError | None = None) -> dict[str, Any]:
    """The results-bundle record of one episode (F-POLICY-BUNDLE): its result or its error."""
    record: dict[str, Any] = {"scenario": job.scenario, "controller": job.policy.label, "index": job.index}
    if result is not None:
        record.update(status="ok", metrics=result.metrics, illegal_actions=result.illegal_actions,
                      actions_sha256=result.actions_digest, error=None)
    else:
        record.update(status="error", metrics=None, illegal_actions=None, actions_sha256=None,
                      error=(error or PolicyError("worker", "no result")).record())
    record["wall_time"] = round(time.perf_counter() - started, 6)
    if job.repeat:
        record["repeat"] = True
    return record


def run_here(job: Job, guard: Callable[[str, str, int | None], Any] | None = None) -> dict[str, Any]:
    """The record of ``job`` played in this process, its phases bounded by ``guard`` or the in-process
    alarm (F-POLICY-HOST); a misbehaving policy gives an ``error`` record (F-POLICY-ERRORS)."""
    started = time.perf_counter()
    try:
        result = run_episode(job.instance, job.policy, strict=job.strict, timeout=job.timeout,
                             load_timeout=job.load_timeout if job.load_timeout is not None else DEFAULT_LOAD_TIMEOUT,
                             guard=guard, scenario=job.scenario, index=job.index)
    except (PolicyError, PolicySpecError) as exc:
        return job_record(job, started, error=exc if isinstance(exc, PolicyError) else PolicyError("setup", str(exc)))
    return job_record(job, started, result)


__all__ = ["DEFAULT_LOAD_TIMEOUT", "EpisodeResult", "Job", "as_policy", "check_joint", "job_record", "run_episode",
           "run_here"]
