"""Long run of the policy-host fault class (F-POLICY-HOST): random plans, violations found.

Usage:  python benchmarks/fuzz_policy_host.py [--plans 40] [--seed 0]

Each plan picks a phase (module import, factory call, a decision), a behaviour (slow within the
limit, hang, hang with SIGALRM blocked, crash, raise), the faulty episode, the number of episodes
and the worker count, and runs it through ``agspec.evaluate.evaluate`` with the misbehaving policy
of ``tests/fakes/phase_policy.py``.  A violation is: the faulty episode without the expected code,
any other episode not ``ok`` or with metrics unlike a clean run, a host reused after a timeout or
a crash, a module executed more often than once per host, or a host left running.  The bounded
version is tests/test_policy_host.py.  The target is 0 violations; nothing here is asserted.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import tempfile
import time
from pathlib import Path

from _common import ROOT, emit

from agspec.catalogue import load_instance
from agspec.evaluate import Job, evaluate, run_job
from agspec.policy.contract import parse_policy

FAKE = ROOT / "tests" / "fakes" / "phase_policy.py"
EXPECTED = {"slow": None, "hang": "timeout", "hang_blocked": "timeout", "crash": "crash", "raise": "exception"}


def jobs(n: int, timeout: float, load_timeout: float) -> list[Job]:
    spec = parse_policy(f"{FAKE}:make_policy", "phased")
    out = []
    for k in range(n):
        inst = load_instance("coalition-easy", k)
        inst["scenario"]["evaluation"]["horizon"] = 12
        out.append(Job("coalition-easy", k, spec, inst, timeout=timeout, load_timeout=load_timeout))
    return out


def alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
        return True
    except ProcessLookupError:
        return False


def one(rng: random.Random, clean: list[dict], violations: list[str]) -> str:
    phase = rng.choice(["import", "factory", "decide"])
    action = rng.choice([a for a in EXPECTED if not (phase == "import" and a == "hang_blocked")])
    n = rng.randint(2, len(clean))
    faulty = 0 if phase == "import" else rng.randrange(n)
    workers = rng.choice([1, 2])
    folder = Path(tempfile.mkdtemp(prefix="agspec-host-"))
    os.environ["AGSPEC_FAKE_PLAN"] = json.dumps({"dir": str(folder), "phase": phase, "action": action,
                                                 "episode": faulty, "tick": rng.randint(0, 11), "seconds": 0.2})
    runs = evaluate(jobs(n, 0.6, 1.5), workers=workers)
    code = EXPECTED[action] if not (phase == "import" and action == "raise") else "setup"
    label = f"{phase}-{action} episode {faulty}/{n} -j {workers}"
    if phase == "import" and code is not None:  # the first import of any worker's host misbehaves
        hit = [k for k, run in enumerate(runs[:workers]) if run["status"] == "error"]
        faulty = hit[0] if len(hit) == 1 else faulty
    for k, run in enumerate(runs):
        want = code if k == faulty else None
        if want is None and (run["status"] != "ok" or run["metrics"] != clean[k]):
            violations.append(f"{label}: episode {k} is {run['status']} {run['error']}")
        if want is not None and (run["error"] or {}).get("code") != want:
            violations.append(f"{label}: faulty episode {k} has {run['error']}, expected {want}")
    imports = [int(x) for x in (folder / "imports").read_text().split()] if (folder / "imports").exists() else []
    hosts_allowed = workers + (1 if code in ("timeout", "crash") else 0)
    executions_allowed = hosts_allowed + (1 if (phase, action) == ("import", "raise") else 0)  # a failed import is retried
    if len(imports) > executions_allowed or len(set(imports)) > hosts_allowed:
        violations.append(f"{label}: module executed {len(imports)} times in {len(set(imports))} hosts "
                          f"(at most {executions_allowed} in {hosts_allowed})")
    if any(alive(pid) for pid in imports):
        violations.append(f"{label}: a host is still running after the campaign")
    return label


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plans", type=int, default=40)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    rng = random.Random(args.seed)
    os.environ["AGSPEC_FAKE_PLAN"] = json.dumps({"dir": tempfile.mkdtemp()})
    clean = [run_job(job)["metrics"] for job in jobs(4, 5.0, 5.0)]
    violations: list[str] = []
    started = time.perf_counter()
    for _ in range(args.plans):
        print(one(rng, clean, violations), flush=True)
    result = {"plans_tried": args.plans, "violations": len(violations), "examples": violations[:20],
              "seconds": round(time.perf_counter() - started, 1)}
    emit(result, [result], ["plans_tried", "violations", "seconds"], "policy-host fault plans", args.json)


if __name__ == "__main__":
    main()
