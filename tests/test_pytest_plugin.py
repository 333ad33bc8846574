"""The pytest plugin (agspec.conform.pytest_plugin): the conformance suite as pytest items."""

from __future__ import annotations

import shlex
import importlib.util
import subprocess
import sys
import tomllib
from importlib.metadata import entry_points
from pathlib import Path

import pytest

from agspec.conform.cases import load_suite
from agspec.conform.items import EPISODE_SCENARIOS

pytest_plugins = ["pytester"]

ROOT = Path(__file__).resolve().parent.parent
SIM = ROOT / "tests" / "mutants" / "sim.py"
PLUGIN = "agspec.conform.pytest_plugin"


def _entry_point_active() -> bool:
    return any(ep.name == "agspec" and ep.value == PLUGIN for ep in entry_points(group="pytest11"))


# The pytest11 entry point is active once the package is (re)installed; until then load it with -p.
LOAD = [] if _entry_point_active() else ["-p", PLUGIN]


def sim(mutant: str | None = None) -> str:
    return shlex.join([sys.executable, str(SIM)] + (["--mutant", mutant] if mutant else []))


@pytest.fixture
def project(pytester: pytest.Pytester) -> pytest.Pytester:
    """A simulator author's project with one test of its own."""
    pytester.makepyfile(test_own="def test_own():\n    assert 1 + 1 == 2\n")
    return pytester


@pytest.fixture(scope="module")
def n_cases() -> int:
    return len(load_suite())


def test_entry_point_is_declared():
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    assert meta["project"]["entry-points"]["pytest11"] == {"agspec": PLUGIN}


def test_without_the_option_nothing_changes(project):
    result = project.runpytest(*LOAD, "-p", "no:cacheprovider")
    result.assert_outcomes(passed=1)
    assert "agspec:" not in result.stdout.str()
    collected = project.runpytest(*LOAD, "--collect-only", "-q", "-p", "no:cacheprovider")
    assert "c-" not in collected.stdout.str()


def test_importing_the_plugin_is_cheap():
    """Loading the plugin (every pytest run once installed) imports no harness, interpreter or schema code."""
    heavy = ("agspec.conform.run_item", "agspec.conform.lockstep.driver", "agspec.interp.tick", "agspec.conform.cases",
             "jsonschema")
    # each name is a module that exists: a renamed module must fail here, not make the check vacuous
    assert [m for m in heavy if importlib.util.find_spec(m) is None] == []
    code = f"import sys, {PLUGIN}; print([m for m in {heavy!r} if m in sys.modules])"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=60)
    assert out.stdout.strip() == "[]"


def test_reference_passes_every_case(project, n_cases):
    result = project.runpytest(*LOAD, "--agspec-impl", "reference", "--agspec-episodes", "0", "-p", "no:cacheprovider")
    result.assert_outcomes(passed=n_cases + 1)
    assert "agspec: conformance of 'reference'" in result.stdout.str()


def test_items_ids_markers_and_episodes(project):
    ids = project.runpytest(*LOAD, "--agspec-impl", "reference", "--agspec-episodes", "0", "--collect-only", "-q",
                            "-m", "R-HANDOFF", "-p", "no:cacheprovider")
    lines = [ln for ln in ids.stdout.lines if ln.startswith("c-")]
    handoff_cases = [c for c in load_suite() if "R-HANDOFF" in c.rules]
    assert sorted(lines) == sorted(c.id for c in handoff_cases)  # node id = case id, one marker per rule ID
    episode = project.runpytest(*LOAD, "--agspec-impl", sim(), "--agspec-episodes", "1", "--agspec-horizon", "3",
                                "-k", "e-flow-easy", "-p", "no:cacheprovider", "-v")
    episode.assert_outcomes(passed=1)
    assert "e-flow-easy-greedy PASSED" in episode.stdout.str()


def test_a_mutant_fails_with_the_divergence_report(project):
    result = project.runpytest(*LOAD, "--agspec-impl", sim("dup-handoff"), "--agspec-episodes", "0",
                               "-m", "R-HANDOFF", "-p", "no:cacheprovider")
    outcomes = result.parseoutcomes()
    assert outcomes.get("failed", 0) >= 1
    text = result.stdout.str()
    assert "first divergence in the reply to step " in text and "/state/robots/" in text
    assert "its reply is the one that failed" in text  # the joint action of the failing step, as in conform
    assert "INV-CONSERVATION" in text
    assert result.ret == pytest.ExitCode.TESTS_FAILED


def test_a_crash_is_an_implementation_error(project):
    result = project.runpytest(*LOAD, "--agspec-impl", sim("crash"), "--agspec-episodes", "1", "--agspec-ticks", "6",
                               "--agspec-timeout", "2", "-k", "e-flow-easy", "-p", "no:cacheprovider")
    result.assert_outcomes(failed=1)
    text = result.stdout.str()
    assert "implementation error" in text and "crash (exit) at tick 3" in text


def test_expected_failures_file(project):
    """xfail for a listed failure, a failure for a listed case that passes (XPASS) and for a stale entry."""
    cases = [c for c in load_suite() if "R-HANDOFF" in c.rules]
    fails = project.runpytest(*LOAD, "--agspec-impl", sim("dup-handoff"), "--agspec-episodes", "0", "-m", "R-HANDOFF",
                              "-p", "no:cacheprovider", "-rf")
    failing = sorted({ln.split()[1] for ln in fails.stdout.lines if ln.startswith("FAILED c-")})
    passing = sorted({c.id for c in cases} - set(failing))
    assert failing and passing
    lines = [f"{failing[0]}: {{outcome: fail, reason: known handoff bug}}",
             f"{passing[0]}: {{outcome: fail, reason: fixed since}}",
             "c-000000000000: {outcome: error, reason: a case that no longer exists}"]
    project.makefile(".yaml", expect="\n".join(lines) + "\n")
    result = project.runpytest(*LOAD, "--agspec-impl", sim("dup-handoff"), "--agspec-episodes", "0", "-m",
                               "R-HANDOFF", "--agspec-expect", "expect.yaml", "-p", "no:cacheprovider", "-rfx")
    outcomes = result.parseoutcomes()
    assert outcomes.get("xfailed") == 1
    text = result.stdout.str()
    assert f"FAILED {passing[0]}" in text and "XPASS counts as a failure" in text
    assert "FAILED agspec-stale-expectations" in text and "c-000000000000" in text
    assert outcomes.get("failed") == len(failing) - 1 + 2


def test_usage_problems_are_one_failing_item(project):
    """A broken expectations file or an unusable --agspec-impl runs nothing and fails one item."""
    project.makefile(".yaml", expect="c-1: [not, a, mapping\n")
    result = project.runpytest(*LOAD, "--agspec-impl", "reference", "--agspec-expect", "expect.yaml",
                               "-p", "no:cacheprovider")
    result.assert_outcomes(passed=1, failed=1)
    assert "FAILED agspec-setup" in result.stdout.str()
    bad = project.runpytest(*LOAD, "--agspec-impl", "python:no_such_module:make", "-p", "no:cacheprovider")
    bad.assert_outcomes(passed=1, failed=1)
    assert "no_such_module" in bad.stdout.str()


BLIND = '''
class Blind:
    """Declares no behavioural part: every item is skipped, nothing is compared."""

    def handle(self, msg):
        reply = {"seq": msg["seq"], "ok": True}
        if msg["cmd"] == "start":
            reply.update(protocol="agspec-protocol/1", implementation={"name": "blind", "version": "0"},
                         capabilities={"observations": False, "masks": False, "privileged_state": False,
                                       "events": False})
        return reply
'''


def test_a_vacuous_session_exits_3_and_the_level_is_stated(project):
    """F-CONFORM-LEVELS in the plugin: the level proven is printed, and a session that compared nothing fails."""
    project.makepyfile(blind=BLIND)
    blind = project.runpytest(*LOAD, "--agspec-impl", f"python:{project.path / 'blind.py'}:Blind",
                              "--agspec-episodes", "1", "--agspec-horizon", "3", "-k", "e-flow-easy-greedy",
                              "-p", "no:cacheprovider")
    assert blind.ret == 3
    blind.stdout.fnmatch_lines(["*agspec: level proven none*VACUOUS*"])
    ok = project.runpytest(*LOAD, "--agspec-impl", "reference", "--agspec-episodes", "1", "--agspec-ticks", "3",
                           "-k", "e-flow-easy-greedy", "-p", "no:cacheprovider")
    assert ok.ret == 0
    ok.stdout.fnmatch_lines(["*agspec: level proven full*"])


def test_golden_reference_traces_in_the_plugin(project, tmp_path):
    """F-GOLDEN: catalogue episodes record their golden traces and the next session reuses them."""
    cache = tmp_path / "golden"
    args = (*LOAD, "--agspec-impl", "reference", "--agspec-episodes", "1", "--agspec-ticks", "5", "-m",
            "agspec_episode", "--agspec-golden-cache", str(cache), "-p", "no:cacheprovider")
    n = len(EPISODE_SCENARIOS)  # one greedy episode per catalogue scenario
    first = project.runpytest(*args)
    first.assert_outcomes(passed=n)
    assert len(list(cache.glob("*/*.json"))) == n
    stamps = {p: p.stat().st_mtime_ns for p in cache.glob("*/*.json")}
    project.runpytest(*args).assert_outcomes(passed=n)
    assert {p: p.stat().st_mtime_ns for p in cache.glob("*/*.json")} == stamps  # reused, not re-recorded
