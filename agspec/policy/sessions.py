"""One episode's decision maker behind one interface (F-POLICY-RUNNER).

A session owns the episode's :class:`~agspec.interp.tick.Simulator` (``sim``), proposes the raw
joint action of the current epoch (``act``) and advances the simulator with a checked joint action
(``step``).  The episode loop, the action checks and the counting of illegal actions live in
:func:`agspec.policy.episode.run_episode`, once for every kind of policy.

* :class:`ControllerSession`  a reference controller (chapter 11);
* :class:`PettingZooSession`  an in-process factory ``NAME(env)`` given that episode's PettingZoo
  ``ParallelEnv`` (F-POLICY-PYTHON); observations and infos are exactly what ``env.reset`` and
  ``env.step`` return, and the joint action goes through ``env.step``;
* :class:`ProcessSession`     a policy process speaking ``agspec-policy/1`` (F-POLICY-PROTOCOL).
"""

from __future__ import annotations

import shlex
import signal
import threading
import traceback
from contextlib import contextmanager
from typing import Any, Callable, Iterator, Mapping, NamedTuple

from agspec.formats.protocol import ProtocolError
from agspec.interp.tick import Simulator
from agspec.policy.contract import PolicyError, PolicySpec, PolicySpecError, load_factory
from agspec.transport.peer import Peer

POLICY_PROTOCOL = "agspec-policy/1"


class Step(NamedTuple):
    applied: dict[str, int]
    events: list[dict[str, Any]]


@contextmanager
def deadline(seconds: float | None, what: str, tick: int | None) -> Iterator[None]:
    """Interrupt an in-process call that takes longer than ``seconds`` (F-POLICY-ERRORS ``timeout``).

    Uses the real-time interval timer, so it works only in a process's main thread (the CLI and the
    worker processes of the episode map); elsewhere the call is not bounded.
    """
    if not seconds or threading.current_thread() is not threading.main_thread():
        yield
        return

    def expire(signum: int, frame: Any) -> None:
        raise PolicyError("timeout", f"{what} took longer than {seconds:g} s", tick=tick)

    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def alarm_guard(load_timeout: float | None, timeout: float | None) -> Callable[[str, str, int | None], Any]:
    """The in-process guard of one episode: ``deadline`` with the load or the decision limit.

    Used where the process ends with the episode (``agspec run --policy``) or the caller chose
    in-process episodes; a campaign times its Python policies from outside (F-POLICY-HOST).
    """
    def guard(phase: str, what: str, tick: int | None):
        return deadline(load_timeout if phase == "load" else timeout, what, tick)

    return guard


def _raised(what: str, exc: Exception, tick: int | None) -> PolicyError:
    return PolicyError("exception", f"{what} raised {type(exc).__name__}: {exc}", tick=tick,
                       detail=traceback.format_exc())


class ControllerSession:
    """A reference controller (C-INFORMATION: the global view only for ``information == "global"``)."""

    def __init__(self, spec: PolicySpec, instance: Mapping[str, Any], exec_seed: int | None, **_: Any):
        from agspec.controllers import make_controller

        self.sim = Simulator(instance)
        self.sim.reset(exec_seed)
        self.controller = make_controller(spec.target, grid=instance["scenario"]["grid"])
        self.controller.reset(exec_seed)
        self.name, self.information = self.controller.name, self.controller.information
        self.observations: Mapping[str, Any] | None = None

    def act(self) -> Mapping[str, Any]:
        self.observations = self.sim.observe()
        return self.controller.act(self.observations, self.sim if self.information == "global" else None)

    def step(self, joint: Mapping[str, int]) -> Step:
        result = self.sim.step(joint)
        return Step(result.applied, result.events)

    def close(self) -> None:
        pass


class PettingZooSession:
    """F-POLICY-PYTHON: ``factory(env)`` once per episode, then ``policy(observations, infos)`` per epoch.

    ``guard(phase, what, tick)`` bounds the loading phase (module import and factory call, phase
    ``load``) and each decision (phase ``decide``): by default an in-process alarm with
    ``load_timeout`` and ``timeout``; in a campaign's policy host, messages to the worker that
    times them from outside (F-POLICY-HOST).
    """

    def __init__(self, spec: PolicySpec, instance: Mapping[str, Any], exec_seed: int | None, *,
                 timeout: float | None = None, load_timeout: float | None = None,
                 guard: Callable[[str, str, int | None], Any] | None = None, **_: Any):
        try:
            from agspec.pettingzoo import parallel_env
        except ImportError as exc:
            raise PolicyError("setup", f"in-process policies need the PettingZoo adapter: pip install 'agspec[marl]' "
                                       f"({exc})") from None
        self.guard = guard or alarm_guard(load_timeout, timeout)
        self.env = parallel_env(instance, capacity=True)  # A-PZ-CAPACITY: evaluation reports M-CAPACITY
        self.sim = self.env.sim
        self.name, self.information = spec.label, "local"
        self.observations = None
        self._obs, self._infos = self.env.reset(seed=exec_seed)
        what = f"loading the policy ({spec.target}: import once per worker, factory(env) once per episode)"
        try:
            with self.guard("load", what, None):
                factory = load_factory(spec)
                self.policy = factory(self.env)
        except (PolicyError, PolicySpecError):
            raise
        except Exception as exc:
            raise _raised(f"the policy factory {spec.target}(env)", exc, None) from None
        if not callable(self.policy):
            raise PolicyError("setup", f"the policy factory {spec.target}(env) returned "
                                       f"{type(self.policy).__name__}, not a callable (observations, infos) -> actions")

    def act(self) -> Mapping[str, Any]:
        t = self.sim.t
        try:
            with self.guard("decide", "the policy's decision", t):
                return self.policy(self._obs, self._infos)
        except PolicyError:
            raise
        except Exception as exc:
            raise _raised("the policy", exc, t) from None

    def step(self, joint: Mapping[str, int]) -> Step:
        self._obs, _rewards, _terms, _truncs, self._infos = self.env.step(joint)
        applied = {a: int(info["applied_action"]) for a, info in self._infos.items()}
        return Step(applied, list(self.env.last_events))

    def close(self) -> None:
        self.env.close()


class ProcessSession:
    """F-POLICY-PROTOCOL: a policy process, started for the episode and torn down after it."""

    def __init__(self, spec: PolicySpec, instance: Mapping[str, Any], exec_seed: int | None, *,
                 timeout: float | None = None, scenario: str | None = None, index: int | None = None, **_: Any):
        self.sim = Simulator(instance)
        self.sim.reset(exec_seed)
        self.name, self.information = spec.label, "local"
        self.observations: Mapping[str, Any] | None = None
        try:
            argv = shlex.split(spec.target)
        except ValueError as exc:
            raise PolicySpecError(f"--policy {spec.target!r}: {exc}") from None
        try:
            self.peer = Peer(argv, display=spec.target, name="policy", timeout=timeout or 10.0)
        except ProtocolError as exc:
            raise PolicyError("crash", exc.message, detail=exc.stderr) from None
        try:
            reply = self._ask("start", None, timeout=max(timeout or 10.0, 10.0), protocol=POLICY_PROTOCOL)
            if reply.get("protocol") != POLICY_PROTOCOL:
                raise PolicyError("protocol", f"the policy announced protocol {reply.get('protocol')!r}, "
                                              f"expected {POLICY_PROTOCOL!r}")
            model = self.sim.model
            self._ask("episode", None, scenario=scenario, index=index, instance_id=instance.get("id"),
                      execution_seed=exec_seed, agents=self.sim.agents(), grid=[model.rows, model.cols],
                      horizon=model.horizon)
        except BaseException:
            self.close()
            raise

    def _ask(self, cmd: str, tick: int | None, timeout: float | None = None, **fields: Any) -> dict[str, Any]:
        try:
            reply = self.peer.request(cmd, timeout, **fields)
        except ProtocolError as exc:
            code = "timeout" if exc.code == "timeout" else ("crash" if exc.kind == "crash" else "protocol")
            raise PolicyError(code, exc.message, tick=tick, detail=exc.stderr) from None
        problems = validate_message(f"policy-{cmd}.reply", reply)
        if problems:
            raise PolicyError("protocol", f"the {cmd} reply violates schemas/protocol/policy-{cmd}.reply.schema.json: "
                                          f"{problems[0]}", tick=tick, detail=self.peer.stderr_tail())
        if reply.get("ok") is False:
            err = reply.get("error", {})
            raise PolicyError("protocol", f"the policy answered {cmd} with an error: {err.get('message', '')}",
                              tick=tick, detail=self.peer.stderr_tail())
        return reply

    def act(self) -> Mapping[str, Any]:
        self.observations = self.sim.observe()
        return self._ask("act", self.sim.t, t=self.sim.t, observations=self.observations)["actions"]

    def step(self, joint: Mapping[str, int]) -> Step:
        result = self.sim.step(joint)
        return Step(result.applied, result.events)

    def close(self) -> None:
        """Ask the process to stop, then tear its process group down whatever it does."""
        self.peer.close()


def validate_message(name: str, message: Any) -> list[str]:
    """Problems of a policy-protocol message against ``schemas/protocol/{name}.schema.json``."""
    from agspec.formats.schemas import validate

    return [str(p) for p in validate(f"protocol/{name}", message, limit=3)]


# F-POLICY-CHECKPOINT: a trained network plays through the PettingZoo environment like any factory
SESSIONS = {"controller": ControllerSession, "python": PettingZooSession, "checkpoint": PettingZooSession,
            "command": ProcessSession}


def open_session(spec: PolicySpec, instance: Mapping[str, Any], exec_seed: int | None, **options: Any):
    """The session for one episode of ``spec`` on ``instance`` (F-POLICY-RUNNER)."""
    return SESSIONS[spec.kind](spec, instance, exec_seed, **options)

