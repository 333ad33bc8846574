"""The campaign executor seam (spec/14-campaigns.md): local in-process, local pool and Ray give the
same results in item order whatever order the workers finish in; dying workers are retried a
bounded number of times and then reported with their cause; an interrupted run stops every child
process its workers started."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

import campaign_tasks as T
from agspec.campaign.executor import Done, ExecutorSpec, Failed, Task, dispatch_order, run_ordered

TESTS = Path(__file__).parent

EXECUTORS = [ExecutorSpec("local", 1), ExecutorSpec("local", 2), ExecutorSpec("local", 3, dispatch_seed=7),
             ExecutorSpec("ray", 2), ExecutorSpec("ray", 2, dispatch_seed=11)]
IDS = ["local-j1", "local-j2", "local-j3-scrambled", "ray-j2", "ray-j2-scrambled"]


@pytest.fixture(scope="module")
def ray_session():
    """One local Ray for the module (the backends reuse a Ray they did not start and leave it up)."""
    ray = pytest.importorskip("ray")
    ray.cloudpickle.register_pickle_by_value(T)  # the workers cannot import the tests directory
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False, logging_level="ERROR")
    yield
    ray.shutdown()


@pytest.fixture(params=range(len(EXECUTORS)), ids=IDS)
def spec(request):
    spec = EXECUTORS[request.param]
    if spec.kind == "ray":
        request.getfixturevalue("ray_session")
    return spec


def test_results_come_in_item_order_whatever_order_workers_finish(spec):  # CAMP-ORDER, CAMP-IDENTICAL
    finished: list[int] = []
    out = list(run_ordered(Task(T.slow_square, "ctx"), list(range(12)), spec,
                           on_progress=lambda i, o: finished.append(i)))
    assert [i for i, _ in out] == list(range(12))
    assert [getattr(o, "value", o) for _, o in out] == [{"item": k, "square": k * k, "context": "ctx"} for k in range(12)]
    assert sorted(finished) == list(range(12))
    if spec.jobs and spec.jobs > 1:  # the workers did finish out of order: the driver reordered
        assert finished != sorted(finished)


def test_dispatch_seed_shuffles_only_the_dispatch_order():  # CAMP-ORDER
    order = dispatch_order(20, 3)
    assert sorted(order) == list(range(20)) and order != list(range(20))
    assert dispatch_order(20, None) == list(range(20))


@pytest.mark.parametrize("kind", ["local", "ray"])
def test_a_worker_that_dies_once_is_retried_and_one_that_always_dies_is_reported(kind, tmp_path, request):
    if kind == "ray":  # CAMP-RETRY, CAMP-FAULTS
        request.getfixturevalue("ray_session")
    items = [("a", str(tmp_path)), ("die-once", str(tmp_path)), ("b", str(tmp_path)), ("die", str(tmp_path)),
             ("c", str(tmp_path)), ("raise", str(tmp_path)), ("d", str(tmp_path))]
    out = dict(run_ordered(Task(T.dies), items, ExecutorSpec(kind, 2, retries=2)))
    assert [out[i].value for i in (0, 1, 2, 4, 6)] == ["a", "die-once", "b", "c", "d"]
    died = out[3]
    assert isinstance(died, Failed) and died.worker_died and died.attempts == 3  # 1 + 2 retries
    assert "died" in died.message() and died.cause
    raised = out[5]
    assert isinstance(raised, Failed) and not raised.worker_died and raised.attempts == 1  # never retried
    assert "ValueError: bad item" in raised.message()


def test_no_retries_means_one_attempt_and_innocent_neighbours_are_not_charged(tmp_path):  # CAMP-RETRY
    items = [("die", str(tmp_path))] + [(name, str(tmp_path)) for name in "abcde"]
    out = dict(run_ordered(Task(T.dies), items, ExecutorSpec("local", 3, retries=0)))
    assert isinstance(out[0], Failed) and out[0].attempts == 1
    assert all(isinstance(out[i], Done) for i in range(1, 6))  # in flight when the pool broke, re-run alone


def _children(directory: Path) -> list[int]:
    return [int(p.name.split("-")[1]) for p in directory.glob("child-*")]


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0]
    except OSError:
        return False
    return state != "Z"


@pytest.mark.parametrize("kind", ["local", "ray"])
def test_interrupt_stops_every_child_the_workers_started(kind, tmp_path):  # CAMP-CANCEL
    script = tmp_path / "driver.py"
    script.write_text(textwrap.dedent(f"""
        import campaign_tasks as T
        if {kind!r} == "ray":
            import ray
            ray.cloudpickle.register_pickle_by_value(T)
        from agspec.campaign.executor import ExecutorSpec, Task, run_ordered
        task = Task(T.sleeps, {str(tmp_path)!r}, T.holds_a_child, T.stop_child)
        for i, o in run_ordered(task, [0.5] * 40, ExecutorSpec({kind!r}, 2)):
            print(i, flush=True)
    """))
    env = dict(os.environ, PYTHONPATH=str(TESTS))
    proc = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                            env=env, text=True)
    try:
        assert proc.stdout.readline().strip() == "0"  # running, with a child per worker
        children = _children(tmp_path)
        assert len(children) == 2 and all(_alive(pid) for pid in children)
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=60)
        deadline = time.monotonic() + 10
        while any(_alive(pid) for pid in children) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not [pid for pid in children if _alive(pid)]
        assert proc.returncode != 0
    finally:
        proc.kill()
        for pid in _children(tmp_path):
            if _alive(pid):
                os.kill(pid, signal.SIGKILL)


# --------------------------------------------------------------------------- commands


# the command of this interpreter's agspec, found whether or not its environment's bin is on PATH
AGSPEC = [sys.executable, "-m", "agspec.cli.main"]


def _agspec(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([*AGSPEC, *args], capture_output=True, text=True, cwd=cwd, timeout=600)


EVALUATE = ["evaluate", "--scenario", "coalition-easy", "--scenario", "flow-easy", "--indices", "0-2",
            "--controller", "greedy", "--controller", "random", "--metric", "delivered", "--metric", "throughput"]
CAMPAIGN_RUNS = [["-j", "1"], ["-j", "2", "--dispatch-seed", "5"], ["--executor", "ray", "-j", "2"],
                 ["--executor", "ray", "-j", "2", "--dispatch-seed", "9"]]


# RES-CAMP-TIMING: time, host and how the run was executed may differ; nothing else
TIMING_AND_HOST = ("wall_time", "command", "workers", "host", "duration_s", "seconds", "started_at", "jobs",
                   "executor")


def _without_timing(doc):
    if isinstance(doc, dict):
        return {k: _without_timing(v) for k, v in doc.items() if k not in TIMING_AND_HOST}
    if isinstance(doc, list):
        return [_without_timing(v) for v in doc]
    return doc


@pytest.mark.ray
def test_evaluate_output_and_bundle_are_the_same_on_every_executor(tmp_path):  # CAMP-IDENTICAL, RES-CAMP-TIMING
    outputs, bundles = [], []
    for n, extra in enumerate(CAMPAIGN_RUNS):
        bundle = tmp_path / f"results-{n}.json"
        result = _agspec(*EVALUATE, "--format", "json", "-o", str(bundle), *extra)
        assert result.returncode == 0, result.stderr
        outputs.append(_without_timing(json.loads(result.stdout)))
        bundles.append(_without_timing(json.loads(bundle.read_text())))
    assert all(out == outputs[0] for out in outputs[1:])
    assert all(b == bundles[0] for b in bundles[1:])
    runs = outputs[0]["runs"]
    assert [(r["scenario"], r["controller"], r["index"]) for r in runs] == [
        (s, c, k) for s in ("coalition-easy", "flow-easy") for k in range(3) for c in ("greedy", "random")]
    assert all(r["status"] == "ok" for r in runs)


@pytest.mark.ray
def test_conform_report_and_summary_are_the_same_on_every_executor(tmp_path):  # CAMP-IDENTICAL, CAMP-ORDER
    outputs, reports = [], []
    for n, extra in enumerate(CAMPAIGN_RUNS[:3]):
        report = tmp_path / f"conform-{n}.jsonl"
        result = _agspec("conform", "--impl", "agspec serve", "-k", "handoff or support or INV-", "--episodes", "1",
                         "--horizon", "15", "--format", "json", "-o", str(report), *extra)
        assert result.returncode == 0, result.stderr
        outputs.append(_without_timing(json.loads(result.stdout)))
        reports.append([_without_timing(json.loads(line)) for line in report.read_text().splitlines()])
    assert outputs[1:] == outputs[:1] * 2 and reports[1:] == reports[:1] * 2
    ids = [r["id"] for r in reports[0] if r.get("type") not in ("header", "footer", "stale")]
    assert len(ids) > 3 and reports[0][-1]["counts"]["pass"] == len(ids)


def test_paper_reproduction_report_is_identical_on_ray(ray_session, tmp_path):  # CAMP-IDENTICAL
    from agspec.reproduce import run_paper

    plan = [("coalition-hard", "greedy", range(1000, 1003)), ("geometry-matched-low", "greedy", range(0, 3)),
            ("geometry-matched-high", "greedy", range(0, 3))]
    run_paper(out_dir=tmp_path / "local", plan=plan, executor=ExecutorSpec("local", 1))
    run_paper(out_dir=tmp_path / "ray", plan=plan, executor=ExecutorSpec("ray", 2, dispatch_seed=1))
    for name in ("reproduction.json", "reproduction.md"):
        assert (tmp_path / "local" / name).read_bytes() == (tmp_path / "ray" / name).read_bytes()


def test_a_failed_episode_is_reported_and_left_out_of_the_means():  # CAMP-FAULTS
    from agspec.catalogue import load_scenario_bundle
    from agspec.evaluate import evaluate, summarize
    from agspec.ir.instance import make_instance

    inst = make_instance(*load_scenario_bundle("flow-easy"), index=0)
    runs = evaluate([("flow-easy", "greedy", 0, inst), ("flow-easy", "no-such-controller", 0, inst)],
                    executor=ExecutorSpec("local", 2))
    assert runs[0]["status"] == "ok" and runs[0]["metrics"] is not None
    assert runs[1]["status"] == "error" and runs[1]["metrics"] is None
    assert runs[1]["error"]["code"] == "worker" and "no-such-controller" in runs[1]["error"]["message"]
    assert [s["delivered"]["n"] for s in summarize(runs)] == [1, 0]  # the failed episode has no value


@pytest.mark.ray
def test_check_over_a_directory_is_identical_on_every_executor(tmp_path):  # CAMP-ORDER, CAMP-IDENTICAL
    traces = tmp_path / "traces"
    traces.mkdir()
    for scenario, index in (("flow-easy", 0), ("coalition-easy", 1), ("concurrency-easy", 0)):
        result = _agspec("run", scenario, "--index", str(index), "--horizon", "15", "--format", "json",
                         "--trace", str(traces / f"{scenario}-{index}.jsonl"))
        assert result.returncode == 0, result.stderr
    bad = traces / "sub" / "broken.jsonl"
    bad.parent.mkdir()
    bad.write_text((traces / "flow-easy-0.jsonl").read_text().splitlines()[0] + "\n")  # header only: truncated
    outputs, reports = [], []
    for n, extra in enumerate(CAMPAIGN_RUNS[:3]):
        report = tmp_path / f"report-{n}.jsonl"
        result = _agspec("check", str(traces), "--format", "json", "-o", str(report), *extra)
        assert result.returncode == 1, result.stderr  # the truncated trace fails
        outputs.append(result.stdout)
        reports.append(report.read_bytes())
    assert reports[1:] == reports[:1] * 2
    timed = [json.loads(out) for out in outputs]
    for data in timed:  # the timing is the one part allowed to differ: the ticks checked per second
        speed = data.pop("timing")
        assert speed["ticks"] == sum(r.get("ticks", 0) for r in data["traces"]) > 0 and speed["ticks_per_s"] > 0
    assert timed[1:] == timed[:1] * 2
    data = timed[0]
    assert [Path(r["file"]).name for r in data["traces"]] == [
        "coalition-easy-1.jsonl", "concurrency-easy-0.jsonl", "flow-easy-0.jsonl", "broken.jsonl"]
    assert data["counts"] == {"ok": 3, "failed": 1, "unreadable": 0, "error": 0}
    lines = reports[0].decode().splitlines()
    assert len(lines) == 5 and json.loads(lines[-1])["type"] == "footer"


@pytest.mark.parametrize("args, message", [
    (["--address", "auto"], "need --executor ray"),
    (["-j", "0"], "0 is not in the range"),
    (["--executor", "ray", "--runtime-env", '{"working_dir": [1'], "not JSON or YAML"),
    (["--executor", "ray", "--runtime-env", "missing-env.yaml"], "cannot read it"),
])
def test_campaign_options_are_checked(args, message):
    result = _agspec(*EVALUATE, *args)
    assert result.returncode == 2 and message in result.stderr and "Traceback" not in result.stderr


MUTANTS = TESTS / "mutants"
DIFF_SUBJECTS = [str(MUTANTS / "instances" / f"{name}.json") for name in ("pair-1x2-flat", "solo-1x2-flat",
                                                                           "duo-1x2-flat")]


def _diff(*extra: str, cwd: Path, env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    args = [*AGSPEC, "diff", "--horizon", "20", "--controller", "greedy", "--controller", "random",
            "--shrink-budget", "30", "-o", "out", "--format", "json", *extra]
    for subject in DIFF_SUBJECTS:
        args += ["--scenario", subject]
    return subprocess.run(args, capture_output=True, text=True, cwd=cwd, timeout=600, env=env)


@pytest.mark.ray
def test_diff_report_and_counterexamples_are_the_same_on_every_executor(tmp_path):  # CAMP-IDENTICAL, RES-CAMP-DIFF
    mutant = f"{sys.executable} {MUTANTS / 'sim.py'} --mutant deliver-early"
    outputs, saved = [], []
    for n, extra in enumerate(CAMPAIGN_RUNS[:3]):
        cwd = tmp_path / f"run-{n}"
        cwd.mkdir()
        result = _diff("--impl", "reference", "--impl", mutant, "--keep-going", *extra, cwd=cwd)
        assert result.returncode == 1, result.stderr  # the mutant diverges
        outputs.append(_without_timing(json.loads(result.stdout)))
        saved.append({str(p.relative_to(cwd)): p.read_bytes() for p in sorted((cwd / "out").rglob("*")) if p.is_file()})
    assert outputs[1:] == outputs[:1] * 2 and saved[1:] == saved[:1] * 2
    report = outputs[0]
    assert report["errors"] == [] and report["compared"]["episodes"] == 6  # 3 instances x 2 controllers
    assert [(f["instance"], f["policy"]) for f in report["findings"]] == [  # in item order
        ("mut-pair-1x2-flat", "greedy(seed=0)"), ("mut-solo-1x2-flat", "greedy(seed=1)"),
        ("mut-solo-1x2-flat", "random(seed=1)"), ("mut-duo-1x2-flat", "greedy(seed=2)"),
        ("mut-duo-1x2-flat", "random(seed=2)")]
    assert all(f["shrunk"]["reproduces"] for f in report["findings"])
    assert len([name for name in saved[0] if name.endswith(".yaml")]) == len(report["findings"])


@pytest.mark.ray
def test_diff_stops_at_the_first_divergent_instance_on_every_executor(tmp_path):  # CAMP-ORDER, RES-CAMP-DIFF
    mutant = f"{sys.executable} {MUTANTS / 'sim.py'} --mutant deliver-early"
    outputs = []
    for n, extra in enumerate(CAMPAIGN_RUNS[:2]):
        cwd = tmp_path / f"run-{n}"
        cwd.mkdir()
        result = _diff("--impl", "reference", "--impl", mutant, "--shrink-budget", "0", *extra, cwd=cwd)
        assert result.returncode == 1, result.stderr
        outputs.append(_without_timing(json.loads(result.stdout)))
    assert outputs[1] == outputs[0] and len(outputs[0]["findings"]) == 1


@pytest.mark.parametrize("kind", ["local", "ray"])
def test_diff_worker_dying_mid_item_is_retried_then_reported(kind, tmp_path):  # CAMP-RETRY, CAMP-FAULTS
    env = dict(os.environ, AGSPEC_TEST_DIE_ONCE="mut-solo-1x2-flat", AGSPEC_TEST_DIE_ALWAYS="mut-duo-1x2-flat",
               AGSPEC_TEST_DIE_MARKERS=str(tmp_path))
    dying = f"python:{TESTS / 'fakes' / 'dying_sim.py'}:make"
    result = _diff("--impl", "reference", "--impl", dying, "--executor", kind, "-j", "2", "--retries", "1",
                   cwd=tmp_path, env=env)
    assert result.returncode == 3 and result.stdout, result.stderr  # CAMP-FAULTS: a harness error, exit 3
    report = json.loads(result.stdout)
    assert (tmp_path / "died-mut-solo-1x2-flat").exists()  # it did die once, and the retry compared it
    assert report["compared"]["episodes"] == 4 and report["findings"] == []
    [error] = report["errors"]
    assert error["instance"] == "mut-duo-1x2-flat"
    assert "worker died 2 time(s)" in error["error"]  # 1 + 1 retry, then reported with the cause


def _sims_of(tag: str) -> list[int]:
    out = []
    for proc in Path("/proc").iterdir():
        if proc.name.isdigit():
            try:
                argv = (proc / "cmdline").read_bytes().decode(errors="replace").split("\0")
                if argv[1:2] == [tag] and _alive(int(proc.name)):  # `python <tag>`: a simulator
                    out.append(int(proc.name))
            except OSError:
                pass
    return out


def test_diff_interrupt_stops_every_simulator_the_workers_started(tmp_path):  # CAMP-CANCEL
    # the unmutated adapter under a command line unique to this test; it outlives the end of its
    # input, so only the worker's teardown (which stops the process group) ends it
    wrapper = tmp_path / "wrapped_sim.py"
    wrapper.write_text(textwrap.dedent(f"""
        import runpy, sys, time
        sys.path.insert(0, {str(MUTANTS)!r})
        sys.argv = [{str(MUTANTS / 'sim.py')!r}]
        try:
            runpy.run_path(sys.argv[0], run_name="__main__")
        finally:
            time.sleep(600)
    """))
    proc = subprocess.Popen([*AGSPEC, "diff", "--impl", "reference", "--impl", f"{sys.executable} {wrapper}",
                             "--scenario", "flow-easy", "--episodes", "40", "--small", "0", "--horizon", "200",
                             "-j", "2", "-o", str(tmp_path / "out")],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stderr.readline()  # the banner: the run has started
        deadline = time.monotonic() + 60
        while len(_sims_of(str(wrapper))) < 2 and time.monotonic() < deadline:
            time.sleep(0.1)
        sims = _sims_of(str(wrapper))
        assert len(sims) == 2  # one simulator per worker (the driver's pair is closed meanwhile)
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=60)
        deadline = time.monotonic() + 10
        while _sims_of(str(wrapper)) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not _sims_of(str(wrapper)) and proc.returncode != 0
    finally:
        proc.kill()
        for pid in _sims_of(str(wrapper)):
            os.kill(pid, signal.SIGKILL)
