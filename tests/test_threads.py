"""The thread budget of every process agspec starts that runs torch (spec/14-campaigns.md, CAMP-THREADS,
RES-THREADS-ONE).

The class: a process that runs torch — a policy host, a fresh repeat, a training run — starts with
torch's default of one thread per core, and ``-j N`` of them oversubscribe the machine.  Each such
process must see the budget its command computed (``workers × threads ≤ cores``, ``--threads``
overriding), and the results bundle or the run record must say what it was.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from agspec import threads

ROOT = Path(__file__).resolve().parents[1]
FAKE = ROOT / "tests" / "fakes" / "thread_policy.py"
AGSPEC = [sys.executable, "-c", "from agspec.cli.main import main; main()"]


def _clean_env(**extra: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in (threads.BUDGET_VAR, *threads.LIBRARY_VARS)}
    return {**env, "AGSPEC_SELF_CHECK": "1", **extra}


@pytest.mark.parametrize("cores", [1, 2, 3, 16])
def test_workers_times_threads_never_exceed_the_cores(monkeypatch, cores):  # CAMP-THREADS
    monkeypatch.setattr(threads, "cores", lambda: cores)
    for workers in (1, cores, 2 * cores):
        n = threads.budget(workers)
        assert n >= 1
        assert workers * n <= max(cores, workers)  # more workers than cores: one thread each, the least there is
    assert threads.budget(1) == min(threads.PER_PROCESS, cores)  # RES-THREADS-ONE
    assert threads.budget(cores, requested=3) == 3  # --threads overrides


def test_cores_are_the_ones_this_process_may_use():  # CAMP-THREADS
    if hasattr(os, "sched_getaffinity"):
        assert threads.cores() == len(os.sched_getaffinity(0))
    else:
        assert threads.cores() == (os.cpu_count() or 1)


def test_child_env_carries_the_budget(monkeypatch):  # CAMP-THREADS
    monkeypatch.delenv(threads.BUDGET_VAR, raising=False)
    env = threads.child_env({"PATH": "/bin"})
    assert env[threads.BUDGET_VAR] == env["OMP_NUM_THREADS"] == env["MKL_NUM_THREADS"] == str(threads.budget(1))
    monkeypatch.setenv(threads.BUDGET_VAR, "3")
    assert threads.child_env({})["OMP_NUM_THREADS"] == "3"  # a child of a budgeted process inherits it


def _evaluate(tmp_path: Path, *extra: str) -> tuple[dict, list[dict]]:
    log, bundle = tmp_path / "threads.jsonl", tmp_path / "bundle.json"
    proc = subprocess.run([*AGSPEC, "evaluate", "--policy", f"{FAKE}:make_policy", "--scenario", "flow-easy",
                           "--indices", "0-0", "--controller", "greedy", "--repeat", "1", "--format", "json",
                           "-o", str(bundle), *extra],
                          env=_clean_env(AGSPEC_FAKE_THREADS=str(log)), capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    return json.loads(bundle.read_text()), [json.loads(x) for x in log.read_text().splitlines()]


def test_policy_host_and_fresh_repeat_see_the_budget(tmp_path):  # CAMP-THREADS, F-POLICY-HOST
    pytest.importorskip("torch", reason="the train extra is not installed: pip install \'agspec[train]\'")
    data, seen = _evaluate(tmp_path)
    assert len(seen) == 2 and len({s["pid"] for s in seen}) == 2  # the host's episode and the fresh repeat's
    n = threads.budget(1)
    assert all(s["torch"] == n and s["omp"] == s["agspec"] == str(n) for s in seen)
    assert data["threads"] == {"per_process": n, "workers": 1, "cores": threads.cores(), "requested": None}


def test_threads_option_overrides_the_budget(tmp_path):  # CAMP-THREADS
    pytest.importorskip("torch", reason="the train extra is not installed: pip install \'agspec[train]\'")
    data, seen = _evaluate(tmp_path, "--threads", "2")
    assert all(s["omp"] == s["agspec"] == "2" for s in seen)
    assert all(s["torch"] == min(2, threads.cores()) for s in seen)  # torch caps OMP_NUM_THREADS at the cores
    assert data["threads"]["per_process"] == 2 and data["threads"]["requested"] == 2


def test_jobs_as_many_as_cores_keep_within_the_cores(tmp_path):  # CAMP-THREADS
    pytest.importorskip("torch", reason="the train extra is not installed: pip install \'agspec[train]\'")
    cores = threads.cores()
    data, seen = _evaluate(tmp_path, "-j", str(cores))
    budget = data["threads"]
    assert budget["workers"] == cores and budget["per_process"] * budget["workers"] <= cores
    assert all(s["agspec"] == str(budget["per_process"]) for s in seen)


def test_a_training_run_records_its_budget(tmp_path):  # CAMP-THREADS, T-CLI
    pytest.importorskip("torch", reason="the train extra is not installed: pip install 'agspec[train]'")
    for extra, want in (((), threads.budget(1)), (("--threads", "2"), min(2, threads.cores()))):
        out = tmp_path / f"run{len(extra)}"
        proc = subprocess.run([*AGSPEC, "train", "--algorithm", "ippo", "--scenario", "flow-easy", "--seed", "0",
                               "-o", str(out), "--steps", "10", "--set", "ppo.steps_per_update=2",
                               "--set", "ppo.minibatch=32", "--set", "validation.indices=[]",
                               "--set", "record.every_steps=2", "--format", "json", *extra],
                              env=_clean_env(), capture_output=True, text=True, timeout=300)
        assert proc.returncode == 0, proc.stderr
        assert json.loads((out / "run.json").read_text())["versions"]["threads"] == want
