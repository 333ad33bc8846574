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
