"""Misbehaving in-process policies for tests/test_policy.py (F-POLICY-ERRORS, F-POLICY-DETERMINISM).

Each factory follows the contract of F-POLICY-PYTHON; each misbehaves in one documented way at
tick 3 on agent "0,0" (or always, for ``masked`` and ``nondeterministic``).
"""

import os
import time

import numpy as np

BAD_TICK = 3


def _lowest_legal(observations):
    return {a: int(np.flatnonzero(o["action_mask"])[-1]) for a, o in observations.items()}


def _after(env, misbehave):
    def act(observations, infos):
        actions = _lowest_legal(observations)
        if env.sim.t == BAD_TICK:
            misbehave(actions)
        return actions

    return act


def raises(env):
    def boom(actions):
        raise RuntimeError("policy bug")

    return _after(env, boom)


def unknown_agent(env):
    return _after(env, lambda actions: actions.__setitem__("99,99", 0))


def missing_agent(env):
    return _after(env, lambda actions: actions.pop("0,0"))


def out_of_range(env):
    return _after(env, lambda actions: actions.__setitem__("0,0", 114))


def hangs(env):
    return _after(env, lambda actions: time.sleep(60))


def masked(env):
    """Always plays deliver (1), masked for every robot that holds nothing at the output column."""
    return lambda observations, infos: {a: 1 for a in observations}


def nondeterministic(env):
    rng = np.random.default_rng(int.from_bytes(os.urandom(4), "little"))

    def act(observations, infos):
        return {a: int(rng.choice(np.flatnonzero(o["action_mask"]))) for a, o in observations.items()}

    return act


def not_callable(env):
    return 42


# --------------------------------------------------------------------------- process-dependent policies
# Each picks among the legal actions by something that is fixed within one Python process and differs
# between processes — the same episode run twice in one process gives the same actions, in two
# processes different ones (F-POLICY-DETERMINISM: the repeat runs in a fresh process).


def _pick(observations, key):
    return {a: int(np.flatnonzero(o["action_mask"])[key(a) % len(np.flatnonzero(o["action_mask"]))])
            for a, o in observations.items()}


def by_hash(env):
    """str hashes are salted per process (PYTHONHASHSEED)."""
    return lambda observations, infos: _pick(observations, lambda a: hash(f"{a}:{env.sim.t}"))


def by_set_order(env):
    """The iteration order of a set of strings follows their hashes."""
    def act(observations, infos):
        order = list({f"{a}:{env.sim.t}" for a in observations})
        return _pick(observations, lambda a: order.index(f"{a}:{env.sim.t}") + env.sim.t)

    return act


def by_pid(env):
    return lambda observations, infos: _pick(observations, lambda a: os.getpid() + env.sim.t)


_PROCESS_DRAW = int.from_bytes(os.urandom(4), "little")  # drawn once per process, at import


def by_process_draw(env):
    return lambda observations, infos: _pick(observations, lambda a: _PROCESS_DRAW + env.sim.t + len(a))


PROCESS_DEPENDENT = ("by_hash", "by_set_order", "by_pid", "by_process_draw")
