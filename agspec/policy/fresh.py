"""The repeat episode of an in-process policy runs in a fresh Python process (F-POLICY-DETERMINISM).

A policy that runs inside agspec's process may depend on that process: Python salts ``str`` hashes
per process (so ``hash()`` and the iteration order of sets of strings differ between processes), a
module may draw a random number once at import, a policy may read its pid.  Run twice in one process,
such a policy repeats itself exactly and looks deterministic; the next user, in another process,
gets other actions.  So the repeat of an in-process policy's episode runs in a new interpreter, with
``PYTHONHASHSEED=random`` whatever this process was started with, and its record comes back to be
compared with the first run's.  Policy processes (``command`` policies) are started per episode
already; the reference controllers are deterministic (chapter 11).

``python -m agspec.policy.fresh JOB RECORD`` is that child: it reads a pickled
:class:`~agspec.policy.episode.Job` from the file JOB and writes the pickled record to the file RECORD.
"""

from __future__ import annotations

import os
import pickle
import subprocess
import sys
import tempfile
from dataclasses import replace
from pathlib import Path
from typing import Any

from agspec import threads
from agspec.policy.contract import PolicyError
from agspec.policy.episode import run_here
from agspec.transport.process import kill_group

STDERR_KEEP = 4000  # characters of a failed child's standard error kept in the error record


def run_fresh(job: Any) -> dict[str, Any]:
    """The record of ``job`` run in a fresh Python process (``run_here`` there).

    The child runs in a session and process group of its own, its stderr goes to a file (a helper the
    policy leaves behind cannot hold a pipe this process waits on), and once it has exited its whole
    process group is killed: whatever the policy started goes with it (F-POLICY-HOST)."""
    with tempfile.TemporaryDirectory(prefix="agspec-repeat-") as tmp:
        src, dst, err = Path(tmp) / "job.pickle", Path(tmp) / "record.pickle", Path(tmp) / "stderr"
        src.write_bytes(pickle.dumps(job))
        env = threads.child_env({**os.environ, "PYTHONHASHSEED": "random"})  # CAMP-THREADS
        with open(err, "wb") as stderr:
            proc = subprocess.Popen([sys.executable, "-m", "agspec.policy.fresh", str(src), str(dst)], env=env,
                                    stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=stderr,
                                    start_new_session=True)
            try:
                code = proc.wait()
            finally:
                kill_group(proc)
        if code == 0 and dst.is_file():
            return pickle.loads(dst.read_bytes())
        error = PolicyError("crash", f"the repeat episode's fresh process exited with status {code}",
                            detail=err.read_bytes().decode("utf-8", "replace")[-STDERR_KEEP:]).record()
        return {"scenario": job.scenario, "controller": job.policy.label, "index": job.index, "status": "error",
                "metrics": None, "illegal_actions": None, "actions_sha256": None, "error": error, "wall_time": 0.0,
                "repeat": True}


def main(argv: list[str]) -> int:
    threads.apply_inherited()  # CAMP-THREADS: the parent's budget, before a policy imports torch
    job = pickle.loads(Path(argv[0]).read_bytes())
    record = {**run_here(replace(job, repeat=False)), "repeat": True}  # here, the episode itself
    Path(argv[1]).write_bytes(pickle.dumps(record))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
