"""A policy that misbehaves in one chosen phase, once (tests/test_policy_host.py, F-POLICY-HOST).

Configured by the environment variable ``AGSPEC_FAKE_PLAN`` (JSON): ``dir`` (a folder for its
logs and markers), ``phase`` (``import``, ``factory`` or ``decide``), ``action`` (``slow``: sleep
``seconds``; ``hang``: sleep an hour; ``hang_blocked``: the same with SIGALRM blocked, as C code
holding the thread would; ``crash``: exit the process; ``raise``; ``torch``: import torch),
``episode`` (the suite index of the instance whose episode misbehaves, or ``"all"``; the import
phase misbehaves at the first import only) and ``tick`` (the decision that misbehaves).  Every module execution and every
factory call appends ``pid`` to ``imports`` / ``factories`` in ``dir``, so a test counts them
across processes.
"""

import json
import os
import signal
import time
from pathlib import Path

import numpy as np

PLAN = json.loads(os.environ.get("AGSPEC_FAKE_PLAN", "{}"))
DIR = Path(PLAN.get("dir", "."))


def _log(name):
    with open(DIR / name, "a", encoding="utf-8") as fh:
        fh.write(f"{os.getpid()}\n")
    return len((DIR / name).read_text().split())


def _misbehave():
    action = PLAN["action"]
    if action == "slow":
        time.sleep(PLAN.get("seconds", 1.0))
    elif action == "hang":
        time.sleep(3600)
    elif action == "hang_blocked":
        signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGALRM})
        time.sleep(3600)
    elif action == "crash":
        os._exit(3)
    elif action == "raise":
        raise RuntimeError("planned failure")
    elif action == "torch":
        import torch  # noqa: F401  (an import that takes long: the original report's case)

        torch.nn.Linear(4, 2)


_log("imports")
if PLAN.get("phase") == "import" and not (DIR / "imported-once").exists():
    (DIR / "imported-once").write_text("")
    _misbehave()


def make_policy(env):
    _log("factories")
    faulty = PLAN.get("episode", 0) in (env.instance["seeds"]["index"], "all")
    if faulty and PLAN.get("phase") == "factory":
        _misbehave()

    def act(observations, infos):
        if faulty and PLAN.get("phase") == "decide" and env.sim.t == PLAN.get("tick", 3):
            _misbehave()
        return {a: int(np.flatnonzero(o["action_mask"])[-1]) for a, o in observations.items()}

    return act
