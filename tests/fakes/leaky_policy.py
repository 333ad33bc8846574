"""A Python policy whose module, when imported, leaves a helper process behind (tests/fakes/helpers.py).

``AGSPEC_LEAK`` = ``HOW:TAG`` (HOW: group, session or detached).  It plays the first legal action; with
``AGSPEC_LEAK_MODE`` ``crash`` it exits its process at tick 3, with ``hang`` it sleeps there.
"""

import os
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from helpers import leave  # noqa: E402

_how, _, _tag = os.environ.get("AGSPEC_LEAK", "group:agspec-leak-none").partition(":")
leave(_how, _tag)


MODE = os.environ.get("AGSPEC_LEAK_MODE", "ok")


def make_policy(env):
    ticks = iter(range(10**9))

    def act(observations, infos):
        if next(ticks) == 3:
            if MODE == "crash":
                os._exit(3)
            if MODE == "hang":
                import time

                time.sleep(600)
        return {agent: int(np.flatnonzero(obs["action_mask"])[0]) for agent, obs in observations.items()}

    return act
