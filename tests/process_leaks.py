"""Every process agspec starts is gone when agspec is done (F-PROCESS-TEARDOWN): child kinds × helper
kinds × exit paths, with a leak check after each run.

Shared by tests/test_process_leaks.py (a bounded share) and benchmarks/fuzz_leaks.py (the whole table).
A child (a simulator under test, a policy process, a Python policy in its host and its fresh-process
repeat, the same in the workers of a campaign with ``-j 2``) leaves a helper behind (tests/fakes/helpers.py: in its process group, in a session of its own
holding its pipes, double-forked and detached), and the ``agspec`` command ends normally, on an error
of the child, on a timeout, or by SIGINT or SIGTERM.  Wrong: a helper still alive after the command,
or a command that does not end within its bound.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
import uuid
from pathlib import Path

from teardown_cases import tagged_processes as tagged

HERE = Path(__file__).resolve().parent
FAKES = HERE / "fakes"
KINDS = ("simulator", "policy-process", "policy-python", "campaign-workers")
HELPERS = ("group", "session", "detached")
PATHS = ("normal", "error", "timeout", "sigint", "sigterm")
BOUND = 60.0  # seconds a run may take, whatever the child does


def command(kind: str, path: str, out: Path, python: str | None = None) -> tuple[list[str], dict[str, str]]:
    """The agspec command line of one case and its extra environment; ``python`` runs agspec (another
    install, to measure a baseline), the children run with this interpreter."""
    mode = {"normal": "ok", "error": "crash"}.get(path, "hang")
    agspec = [python or sys.executable, "-c", "from agspec.cli.main import main; main()"]
    if kind == "simulator":
        fail = {} if mode == "ok" else {"": {"cmd": "step", "mode": mode, "at": 2}}
        sim = f"{sys.executable} {FAKES / 'scripted_sim.py'} --fail '{json.dumps(fail)}'"
        return agspec + ["conform", "--impl", sim, "--no-suite", "--episodes", "1", "--horizon", "4", "-k",
                         "e-flow-easy-greedy", "--golden-cache", "off", "--timeout", "2", "--format", "json",
                         "--repro-dir", str(out / "repro")], {}
    policy = (f"{sys.executable} {FAKES / 'policy_process.py'} {mode}" if kind == "policy-process"
              else f"{FAKES / 'leaky_policy.py'}:make_policy")
    workers = ["-j", "2", "--indices", "0-1"] if kind == "campaign-workers" else ["--indices", "0-0"]
    return agspec + ["evaluate", "--policy", policy, "--scenario", "flow-easy", *workers, "--timeout", "2",
                     "--format", "json", "-o", str(out / "bundle.json")], {"AGSPEC_LEAK_MODE": mode}


def run_case(kind: str, helper: str, path: str, out: Path,
             python: str | None = None) -> tuple[list[str], float, int | None]:
    """Run one case; (what is wrong, seconds, exit code)."""
    tag = f"agspec-leak-{uuid.uuid4().hex[:12]}"
    argv, extra = command(kind, path, out, python)
    env = {**os.environ, **extra, "AGSPEC_LEAK": f"{helper}:{tag}"}
    start = time.monotonic()
    proc = subprocess.Popen(argv, env=env, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, start_new_session=True)
    wrong = []
    try:
        if path in ("sigint", "sigterm"):
            while not tagged(tag) and proc.poll() is None and time.monotonic() - start < BOUND:
                time.sleep(0.05)
            time.sleep(0.5)
            proc.send_signal(signal.SIGINT if path == "sigint" else signal.SIGTERM)
        code = proc.wait(BOUND)
    except subprocess.TimeoutExpired:
        code = None
        wrong.append(f"did not end within {BOUND:g} s")
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    seconds = time.monotonic() - start
    deadline = time.monotonic() + 2.0  # a helper killed at the very end may take a moment to go
    while tagged(tag) and time.monotonic() < deadline:
        time.sleep(0.05)
    left = tagged(tag)
    if left:
        wrong.append(f"{len(left)} helper process(es) left alive")
        for pid in left:
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
    return wrong, seconds, code
