"""A policy that records the thread budget of the process it runs in (tests/test_threads.py, CAMP-THREADS).

Its factory imports torch (as a trained policy does) and appends one JSON line to the file named by
``AGSPEC_FAKE_THREADS``: the pid, ``torch.get_num_threads()``, ``OMP_NUM_THREADS`` and
``AGSPEC_THREADS``; it then plays the highest legal action.
"""

import json
import os

import numpy as np


def make_policy(env):
    import torch

    with open(os.environ["AGSPEC_FAKE_THREADS"], "a", encoding="utf-8") as fh:
        fh.write(json.dumps({"pid": os.getpid(), "torch": torch.get_num_threads(),
                             "omp": os.environ.get("OMP_NUM_THREADS"),
                             "agspec": os.environ.get("AGSPEC_THREADS")}) + "\n")

    def act(observations, infos):
        return {a: int(np.flatnonzero(o["action_mask"])[-1]) for a, o in observations.items()}

    return act
