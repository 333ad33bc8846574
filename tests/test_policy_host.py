"""Python policies in a campaign: loaded once per worker, timed from outside, replaced after a timeout
(spec/13-policy.md, F-POLICY-HOST, F-POLICY-PYTHON, RES-POLICY-TIMEOUT-REPLACES).

The class: a policy that is slow, hangs, crashes or raises in one phase — module import, factory
call, a decision — must cost exactly its own episode, with the right code, and leave every other
episode of the campaign as a clean run has it.  ``test_every_phase_and_failure_costs_one_episode``
enumerates the class; ``benchmarks/fuzz_policy_host.py`` draws longer random plans.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("pettingzoo", reason="the MARL extra is not installed: pip install 'agspec[marl]'")

from agspec.catalogue import load_instance  # noqa: E402
from agspec.evaluate import Job, evaluate, run_job  # noqa: E402
from agspec.policy.contract import parse_policy  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
FAKE = ROOT / "tests" / "fakes" / "phase_policy.py"
SCENARIO = "coalition-easy"
N = 2  # the faulty episode, then one on the same worker after it


def _jobs(timeout: float, load_timeout: float | None, n: int = N, horizon: int = 12) -> list[Job]:
    spec = parse_policy(f"{FAKE}:make_policy", "phased")
    out = []
    for k in range(n):
        inst = load_instance(SCENARIO, k)
        inst["scenario"]["evaluation"]["horizon"] = horizon
        out.append(Job(SCENARIO, k, spec, inst, timeout=timeout, load_timeout=load_timeout))
    return out


def _pids(folder: Path, name: str) -> list[int]:
    path = folder / name
    return [int(x) for x in path.read_text().split()] if path.exists() else []


@pytest.fixture
def plan(tmp_path, monkeypatch):
    """Set the fake policy's plan for the host processes this test starts (they inherit the environment)."""
    def set_plan(**fields):
        monkeypatch.setenv("AGSPEC_FAKE_PLAN", json.dumps({"dir": str(tmp_path), **fields}))
        return tmp_path
    return set_plan


@pytest.fixture(scope="module")
def clean_metrics(tmp_path_factory):
    d = tmp_path_factory.mktemp("clean")
    os.environ["AGSPEC_FAKE_PLAN"] = json.dumps({"dir": str(d)})
    try:
        return [run_job(job)["metrics"] for job in _jobs(1.0, None)]
    finally:
        del os.environ["AGSPEC_FAKE_PLAN"]


# (phase, action, extra plan fields, decision timeout, load timeout, expected code of the faulty episode or None)
CASES = [
    ("import", "slow", {"seconds": 1.0}, 0.3, None, None),  # loading is not decision time
    ("factory", "slow", {"seconds": 1.0}, 0.3, None, None),
    ("decide", "slow", {"seconds": 0.05}, 2.0, None, None),
    ("import", "hang", {}, 1.0, 1.5, "timeout"),
    ("factory", "hang", {}, 1.0, 1.5, "timeout"),
    ("decide", "hang", {}, 0.5, None, "timeout"),
    ("decide", "hang_blocked", {}, 0.5, None, "timeout"),  # an alarm cannot interrupt it; a kill can
    ("factory", "crash", {}, 1.0, None, "crash"),
    ("decide", "crash", {}, 1.0, None, "crash"),
    ("import", "raise", {}, 1.0, None, "setup"),
    ("factory", "raise", {}, 1.0, None, "exception"),
    ("decide", "raise", {}, 1.0, None, "exception"),
]


@pytest.mark.parametrize("phase, action, extra, timeout, load_timeout, code", CASES,
                         ids=[f"{c[0]}-{c[1]}" for c in CASES])
def test_every_phase_and_failure_costs_one_episode(plan, clean_metrics, phase, action, extra, timeout,
                                                   load_timeout, code):
    """F-POLICY-HOST: the faulty episode gets its code; every other episode equals the clean run."""
    faulty = 0
    folder = plan(phase=phase, action=action, episode=faulty, tick=3, **extra)
    runs = evaluate(_jobs(timeout, load_timeout))
    for k, run in enumerate(runs):
        if k == faulty and code is not None:
            assert run["status"] == "error" and run["error"]["code"] == code, run["error"]
            if phase == "decide":
                assert run["error"]["tick"] == 3
            if code == "timeout":
                flag = "--load-timeout" if phase in ("import", "factory") else "--timeout"
                assert flag in run["error"]["message"]
        else:
            assert run["status"] == "ok", (k, run["error"])
            assert run["metrics"] == clean_metrics[k]
    imports = _pids(folder, "imports")
    replaced = code in ("timeout", "crash")
    # RES-POLICY-TIMEOUT-REPLACES: a host that timed out or died is never reused; any other is
    assert len(set(imports)) == (2 if replaced else 1), imports
    factories = _pids(folder, "factories")
    if replaced and phase != "import":
        assert factories[faulty] != factories[faulty + 1]
    for pid in set(imports):  # every host is torn down when the campaign ends
        with pytest.raises(ProcessLookupError):
            os.kill(pid, 0)


def test_a_policy_importing_torch_in_its_factory_is_never_cut_by_the_decision_timeout(plan):
    """The reported case: torch imported inside the factory under a short decision timeout."""
    pytest.importorskip("torch")
    folder = plan(phase="factory", action="torch", episode="all")
    runs = evaluate(_jobs(0.05, None, n=4))
    assert [r["status"] for r in runs] == ["ok"] * 4, [r["error"] for r in runs]
    assert len(_pids(folder, "imports")) == 1 and len(_pids(folder, "factories")) == 4


def test_module_runs_once_per_worker_and_the_factory_once_per_episode(plan):
    """F-POLICY-PYTHON through the CLI with -j 2: 3 instances and 1 repeat = 4 factory calls; at most one
    import per worker's host (2) and one for the repeat, which runs in a fresh process (F-POLICY-DETERMINISM)."""
    folder = plan(phase="none", action="slow")
    r = subprocess.run([sys.executable, "-m", "agspec.cli.main", "evaluate", "--policy", f"{FAKE}:make_policy",
                        "--controller", "random", "--scenario", SCENARIO, "--split", "catalogue", "--indices", "0-2",
                        "--repeat", "1", "-j", "2", "--format", "json"], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    runs = json.loads(r.stdout)["runs"]
    assert sum(1 for e in runs if e["controller"] == "phase_policy") == 4
    imports, factories = _pids(folder, "imports"), _pids(folder, "factories")
    assert len(factories) == 4
    assert 2 <= len(imports) <= 3 and len(set(imports)) == len(imports)
    assert set(factories) <= set(imports)


def test_policy_output_on_stdout_never_reaches_the_json_output(tmp_path, monkeypatch):
    monkeypatch.setenv("AGSPEC_FAKE_PLAN", json.dumps({"dir": str(tmp_path)}))
    noisy = tmp_path / "noisy.py"
    noisy.write_text(f"print('hello from the policy module')\nfrom importlib import util\n"
                     f"spec = util.spec_from_file_location('fake', {str(FAKE)!r})\n"
                     "fake = util.module_from_spec(spec); spec.loader.exec_module(fake)\n"
                     "def make_policy(env):\n    print('factory says hi')\n    return fake.make_policy(env)\n")
    r = subprocess.run([sys.executable, "-m", "agspec.cli.main", "evaluate", "--policy", f"{noisy}:make_policy",
                        "--controller", "random", "--scenario", SCENARIO, "--split", "catalogue", "--indices", "0",
                        "--repeat", "0", "--format", "json"], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    json.loads(r.stdout)
    assert "hello from the policy module" in r.stderr and "factory says hi" in r.stderr


def test_the_host_checks_catch_a_worker_that_reuses_a_timed_out_host(plan, clean_metrics, monkeypatch):
    """The class check proves itself: a worker that keeps a host after a timeout (the defect of an
    in-process alarm: the interrupted process serves the next episode) fails it."""
    from agspec.policy import host as host_module

    monkeypatch.setattr(host_module.PolicyHost, "kill", lambda self: None)
    monkeypatch.setattr(host_module.PolicyHosts, "run", lambda self, job: self.hosts.setdefault(
        job.policy.target, host_module.PolicyHost()).run(job))
    try:
        with pytest.raises(AssertionError):
            test_every_phase_and_failure_costs_one_episode(plan, clean_metrics, "factory", "hang", {}, 1.0, 1.5,
                                                           "timeout")
    finally:
        for pid in _pids(Path(json.loads(os.environ["AGSPEC_FAKE_PLAN"])["dir"]), "imports"):
            try:
                os.killpg(pid, 9)
            except ProcessLookupError:
                pass
