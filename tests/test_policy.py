"""Evaluating a user's policy (spec/13-policy.md, F-POLICY-*): the contract, the one runner, errors,
nondeterminism, option checks, the results bundle, the paired comparison, tables and the figure."""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

pytest.importorskip("pettingzoo", reason="the MARL extra is not installed: pip install 'agspec[marl]'")
stats = pytest.importorskip("scipy.stats", reason="the eval extra is not installed: pip install 'agspec[eval]'")

from agspec.catalogue import CatalogueError, load_instance, parse_indices  # noqa: E402
from agspec.cli.evaluate_view import nondeterminism  # noqa: E402
from agspec.formats.schemas import validate  # noqa: E402
from agspec.evaluate import Job, run_episode, run_job  # noqa: E402
from agspec.policy import published  # noqa: E402
from agspec.policy.bundle import BundleError, BundleWriter, combine, read_bundle  # noqa: E402
from agspec.policy.contract import PolicySpecError, parse_policy  # noqa: E402
from agspec.policy.stats import compare, paired  # noqa: E402
from agspec.pettingzoo import parallel_env  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
FAKES = ROOT / "tests" / "fakes"
EXAMPLES = ROOT / "examples" / "policies"
SCENARIO = "coalition-easy"

# A policy written only against the documented contract (F-POLICY-PYTHON): a factory taking the
# episode's ParallelEnv, returning (observations, infos) -> actions.  It keeps per-episode state.
CONTRACT_POLICY = textwrap.dedent('''
    import numpy as np

    def make_policy(env):
        calls = {"n": 0}

        def act(observations, infos):
            calls["n"] += 1
            out = {}
            for agent, obs in observations.items():
                legal = np.flatnonzero(infos[agent]["action_mask"])
                non_idle = legal[legal > 0]
                pick = non_idle if len(non_idle) else legal
                out[agent] = int(pick[(calls["n"] + len(agent)) % len(pick)])
            return out

        return act
''')


def agspec(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "agspec.cli.main", *args], capture_output=True, text=True,
                          cwd=cwd, timeout=600)


def short_instance(horizon: int = 12, index: int = 0) -> dict:
    inst = load_instance(SCENARIO, index)
    inst["scenario"]["evaluation"]["horizon"] = horizon
    return inst


# ---------------------------------------------------------------- F-POLICY-SPEC


def test_policy_spec_kinds(tmp_path):
    f = tmp_path / "p.py"
    f.write_text(CONTRACT_POLICY)
    assert parse_policy("greedy").kind == "controller"
    spec = parse_policy(f"{f}:make_policy", "mine", "1.0")
    assert (spec.kind, spec.label, spec.version) == ("python", "mine", "1.0")
    assert len(spec.file_digest) == 64
    assert parse_policy("python3 -u x").kind == "command"
    with pytest.raises(PolicySpecError, match="no file"):
        parse_policy(f"{tmp_path}/missing.py:make_policy")
    with pytest.raises(PolicySpecError, match="no module"):
        parse_policy("no_such_module_xyz:make")


# ---------------------------------------------------------------- F-POLICY-RUNNER, F-POLICY-PROTOCOL


def test_process_policy_equals_in_process_policy():
    """The same heuristic through both policy forms takes the same actions (one runner, F-POLICY-RUNNER)."""
    inst = short_instance(40)
    a = run_job(Job(SCENARIO, 0, parse_policy(f"{EXAMPLES}/heuristic.py:make_policy"), inst))
    b = run_job(Job(SCENARIO, 0, parse_policy(f"{sys.executable} {EXAMPLES}/heuristic_process.py"), inst))
    assert a["status"] == b["status"] == "ok"
    assert a["actions_sha256"] == b["actions_sha256"] and a["metrics"] == b["metrics"]
    assert a["metrics"]["ticks"] == 40


def test_reference_controller_through_the_runner_is_unchanged():
    inst = short_instance(60)
    rec = run_job(Job(SCENARIO, 0, parse_policy("greedy"), inst))
    assert rec["metrics"] == run_episode(inst, "greedy").metrics and rec["illegal_actions"] == 0


# ---------------------------------------------------------------- F-POLICY-ERRORS


@pytest.mark.parametrize("factory, code, agent", [
    ("raises", "exception", None),
    ("unknown_agent", "unknown_agent", "99,99"),
    ("missing_agent", "missing_agent", "0,0"),  # RES-POLICY-MISSING-AGENT
    ("out_of_range", "bad_action", "0,0"),
    ("hangs", "timeout", None),
])
def test_misbehaving_in_process_policy_is_located(factory, code, agent):
    rec = run_job(Job(SCENARIO, 0, parse_policy(f"{FAKES}/policies.py:{factory}"), short_instance(), timeout=0.5))
    assert rec["status"] == "error" and rec["metrics"] is None
    err = rec["error"]
    assert (err["code"], err["tick"], err["agent"]) == (code, 3, agent)
    assert rec["wall_time"] < 30


def test_factory_not_returning_a_callable():
    rec = run_job(Job(SCENARIO, 0, parse_policy(f"{FAKES}/policies.py:not_callable"), short_instance()))
    assert rec["error"]["code"] == "setup" and "not a callable" in rec["error"]["message"]


@pytest.mark.parametrize("mode, code", [("crash", "crash"), ("garbage", "protocol"), ("hang", "timeout"),
                                        ("wrong-seq", "protocol"), ("no-handshake", "protocol")])
def test_misbehaving_process_is_reported_and_torn_down(tmp_path, mode, code):
    pids = tmp_path / "pids"
    spec = parse_policy(f"{sys.executable} {FAKES}/policy_process.py {mode} {pids}")
    rec = run_job(Job(SCENARIO, 0, spec, short_instance(), timeout=1.0))
    assert rec["status"] == "error" and rec["error"]["code"] == code
    if mode not in ("no-handshake",):
        assert rec["error"]["tick"] == 3
    for pid in map(int, pids.read_text().split()):
        with pytest.raises(ProcessLookupError):
            os.kill(pid, 0)


def test_masked_actions_are_counted_or_strict_errors():
    """F-POLICY-ILLEGAL: the count equals an independent count of masked choices on the PettingZoo env."""
    inst = short_instance(20)
    rec = run_job(Job(SCENARIO, 0, parse_policy(f"{FAKES}/policies.py:masked"), inst))
    env = parallel_env(inst)
    obs, infos = env.reset(seed=inst["seeds"]["execution"])
    expected = 0
    while env.agents:
        expected += sum(1 for a in env.agents if not obs[a]["action_mask"][1])
        obs, _, _, _, infos = env.step({a: 1 for a in env.agents})
    assert rec["status"] == "ok" and rec["illegal_actions"] == expected > 0
    strict = run_job(Job(SCENARIO, 0, parse_policy(f"{FAKES}/policies.py:masked"), inst, strict=True))
    assert strict["error"]["code"] == "illegal_action" and strict["error"]["tick"] == 0 and strict["error"]["agent"]


def test_nondeterministic_policy_is_detected():
    inst = short_instance(30)
    def twice(factory):
        spec = parse_policy(f"{FAKES}/policies.py:{factory}")
        return [run_job(Job(SCENARIO, 0, spec, inst)), run_job(Job(SCENARIO, 0, spec, inst, repeat=True))]
    found = nondeterminism(twice("nondeterministic"))
    assert len(found) == 1 and found[0]["index"] == 0 and "nondeterministic" in found[0]["message"]
    assert nondeterminism(twice("out_of_range")[:0] + [run_job(Job(SCENARIO, 0, parse_policy(
        f"{EXAMPLES}/heuristic.py:make_policy"), inst)), run_job(Job(SCENARIO, 0, parse_policy(
        f"{EXAMPLES}/heuristic.py:make_policy"), inst, repeat=True))]) == []


# ---------------------------------------------------------------- F-POLICY-INDICES


@pytest.mark.parametrize("args, message", [
    (["--metric", "bogus"], "bogus"),
    (["--indices", ""], "empty"),
    (["--indices", "1000,,1001"], "empty item"),
    (["--indices", "abc"], "not an index"),
    (["--indices", "1000-1000000000"], "more than"),
    (["--indices", "5000"], "outside"),
    (["--split", "validation", "--indices", "1000"], "outside the split"),
    (["--indices", "0,1000"], "mixes splits"),
    (["--controller", "nope"], "nope"),
    (["--policy", "missing_file.py:make"], "no file"),
    (["-j", "0"], "0"),
])
def test_evaluate_option_checks(args, message):
    """F-POLICY-INDICES, RES-POLICY-INDICES-IN-SPLIT: bad options exit 2 with a message, before running."""
    r = agspec("evaluate", *args)
    assert r.returncode == 2, r.stderr
    assert message in r.stderr and "Traceback" not in r.stderr


def test_parse_indices_is_bounded_before_expanding():
    with pytest.raises(CatalogueError, match="more than 100"):
        parse_indices("0-1000000000000", limit=100)
    assert parse_indices("3,1-2,3") == [3, 1, 2]


# ---------------------------------------------------------------- a campaign through the CLI


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    d = tmp_path_factory.mktemp("campaign")
    (d / "mine.py").write_text(CONTRACT_POLICY)
    r = agspec("evaluate", "--policy", f"{d / 'mine.py'}:make_policy", "--name", "mine", "--policy-version", "7",
               "--controller", "greedy", "--controller", "random", "--scenario", SCENARIO, "--split", "catalogue",
               "--indices", "0-2", "-o", str(d / "results.json"), "--format", "json", "-j", "2")
    assert r.returncode == 0, r.stderr
    return d, json.loads(r.stdout), read_bundle(d / "results.json")


def test_outputs_validate_against_their_schemas(campaign):
    """F-POLICY-BUNDLE: the bundle and the JSON output validate; identities, instances, repeats recorded."""
    _, out, bundle = campaign
    assert validate("evaluation", out, limit=3) == []
    assert validate("results", bundle, limit=3) == []
    assert bundle["complete"] is True and bundle["nondeterminism"] == []
    mine = next(p for p in bundle["policies"] if p["label"] == "mine")
    assert mine["kind"] == "python" and mine["version"] == "7" and len(mine["file_sha256"]) == 64
    assert {(i["scenario"], i["index"]) for i in bundle["instances"]} == {(SCENARIO, k) for k in range(3)}
    assert sum(1 for ep in bundle["episodes"] if ep.get("repeat")) == 1  # F-POLICY-DETERMINISM default


def test_policy_numbers_equal_an_independent_pettingzoo_loop(campaign):
    """F-POLICY-PYTHON, F-POLICY-EVALUATION: per-episode numbers equal a plain loop over the PettingZoo env
    reset with the instance's execution seed and run to the horizon."""
    d, _, bundle = campaign
    namespace: dict = {}
    exec(compile(CONTRACT_POLICY, "contract_policy", "exec"), namespace)
    for k in range(3):
        env = parallel_env(SCENARIO, index=k, capacity=True)  # A-PZ-CAPACITY: what an evaluation reports
        obs, infos = env.reset(seed=env.instance["seeds"]["execution"])
        policy = namespace["make_policy"](env)
        while env.agents:
            obs, _, _, _, infos = env.step(policy(obs, infos))
        ep = next(e for e in bundle["episodes"] if e["controller"] == "mine" and e["index"] == k and not e.get("repeat"))
        assert ep["status"] == "ok" and ep["metrics"] == json.loads(json.dumps(env.final_metrics()))


def test_paired_comparison_equals_scipy(campaign):
    """F-POLICY-COMPARISON: interval, t-test and Wilcoxon equal SciPy on the bundle's own numbers."""
    _, out, bundle = campaign
    eps = [e for e in bundle["episodes"] if not e.get("repeat")]
    for ref in ("greedy", "random"):
        for metric in ("delivered", "completion_rate"):
            mine = [next(e for e in eps if e["controller"] == "mine" and e["index"] == k)["metrics"][metric]
                    for k in range(3)]
            theirs = [next(e for e in eps if e["controller"] == ref and e["index"] == k)["metrics"][metric]
                      for k in range(3)]
            row = next(c for c in out["comparisons"] if c["reference"] == ref and c["metric"] == metric)
            diffs = [a - b for a, b in zip(mine, theirs)]
            assert row["n"] == 3 and row["mean_difference"] == pytest.approx(statistics.fmean(diffs))
            if len(set(diffs)) > 1:
                res = stats.ttest_rel(mine, theirs)
                ci = res.confidence_interval(0.95)
                assert (row["t"], row["p_value"]) == (pytest.approx(res.statistic), pytest.approx(res.pvalue))
                assert (row["ci_low"], row["ci_high"]) == (pytest.approx(ci.low), pytest.approx(ci.high))
                assert row["wilcoxon_p"] == pytest.approx(stats.wilcoxon(diffs).pvalue)


def test_paired_interval_is_student_t():
    a, b = [3.0, 5.0, 4.0, 8.0, 6.0], [1.0, 2.0, 4.0, 3.0, 3.0]
    row = paired(a, b)
    d = [x - y for x, y in zip(a, b)]
    half = stats.t.ppf(0.975, len(d) - 1) * statistics.stdev(d) / len(d) ** 0.5
    assert (row["ci_low"], row["ci_high"]) == (pytest.approx(statistics.fmean(d) - half),
                                               pytest.approx(statistics.fmean(d) + half))
    assert paired([1.0, 2.0], [0.0, 1.0])["ci_low"] == 1.0  # constant differences: the point, no test


def test_from_rerenders_without_running_and_refuses_mixed_bundles(campaign, tmp_path):
    d, out, bundle = campaign
    r = agspec("evaluate", "--from", str(d / "results.json"), "--format", "json")
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["comparisons"] == out["comparisons"]
    other = dict(bundle, catalogue_digest="0" * 64)
    (tmp_path / "other.json").write_text(json.dumps(other))
    r = agspec("evaluate", "--from", str(d / "results.json"), str(tmp_path / "other.json"))
    assert r.returncode == 2 and "catalogue digests" in r.stderr
    (tmp_path / "spec.json").write_text(json.dumps(dict(bundle, spec_version="assemblygrid-v1/other")))
    with pytest.raises(BundleError, match="specification versions"):
        combine([("a", bundle), ("b", read_bundle(tmp_path / "spec.json"))])


def test_bundle_is_written_incrementally(campaign, tmp_path):
    """F-POLICY-BUNDLE: records are on disk as episodes end; an interrupted bundle reads back."""
    _, _, bundle = campaign
    head = {k: v for k, v in bundle.items() if k not in ("episodes", "complete", "wall_time", "nondeterminism")}
    w = BundleWriter(tmp_path / "partial.json", head)
    w.add(bundle["episodes"][0])
    w.add(bundle["episodes"][1])
    # the campaign is interrupted here: both records are already on disk
    partial = read_bundle(tmp_path / "partial.json")
    assert partial["complete"] is False and partial["episodes"] == bundle["episodes"][:2]
    w.close()
    assert read_bundle(tmp_path / "partial.json")["complete"] is True


def test_report_markdown_latex_and_figures(campaign):
    """F-POLICY-TABLE (booktabs LaTeX, Markdown) and F-POLICY-FIGURE (rendered and checked as files)."""
    d, _, _ = campaign
    md = agspec("report", str(d / "results.json"), "--to", "markdown")
    assert md.returncode == 0 and "| mine | 3 |" in md.stdout and "| Greedy | 3 |" in md.stdout
    assert "3 of 5 catalogue instances" in md.stdout
    assert "MAPPO (published)" not in md.stdout  # F-POLICY-PUBLISHED: final-test rows only beside final-test ones
    tex = agspec("report", str(d / "results.json"), "--to", "latex")
    for needle in (r"\toprule", r"\midrule", r"\bottomrule", r"\cmidrule", "mine & 3 &"):
        assert needle in tex.stdout
    for fmt, magic in (("svg", b"<svg"), ("png", b"\x89PNG"), ("pdf", b"%PDF")):
        target = d / f"fig.{fmt}"
        r = agspec("report", str(d / "results.json"), "--to", fmt, "-o", str(target))
        assert r.returncode == 0, r.stderr
        head = target.read_bytes()[:4096]
        assert magic in head and target.stat().st_size > 5000
    assert "mine" in (d / "fig.svg").read_text()


def test_misbehaving_policy_costs_only_its_episodes(tmp_path):
    r = agspec("evaluate", "--policy", f"{FAKES}/policies.py:raises", "--name", "bad", "--controller", "greedy",
               "--scenario", SCENARIO, "--split", "catalogue", "--indices", "0", "--repeat", "0",
               "-o", str(tmp_path / "r.json"))
    assert r.returncode == 1
    assert f"{SCENARIO} #0, tick 3" in r.stderr and "policy bug" in r.stderr and "Traceback" not in r.stderr
    eps = read_bundle(tmp_path / "r.json")["episodes"]
    assert {(e["controller"], e["status"]) for e in eps} == {("bad", "error"), ("greedy", "ok")}


def test_run_policy(tmp_path):
    r = agspec("run", SCENARIO, "--index", "0", "--policy", f"{EXAMPLES}/heuristic.py:make_policy", "--horizon", "30",
               "--format", "json")
    assert r.returncode == 0, r.stderr
    expected = run_episode(load_instance(SCENARIO, 0), parse_policy(f"{EXAMPLES}/heuristic.py:make_policy"),
                           horizon=30).metrics
    assert json.loads(r.stdout)["metrics"] == json.loads(json.dumps(expected))
    bad = agspec("run", SCENARIO, "--policy", f"{FAKES}/policies.py:missing_agent", "--horizon", "10")
    assert bad.returncode == 1 and "tick 3" in bad.stderr and "agent 0,0" in bad.stderr


# ---------------------------------------------------------------- F-POLICY-PUBLISHED


def test_published_rows_cover_the_paper_and_agree_with_its_tables():
    from agspec.reproduce import PAPER_CENTRALIZED, PAPER_COALITION

    for metric in ("delivered", "completion_rate"):
        for name in published.MARL:
            assert len([r for r in published.rows(metric, (name,))]) == 9
    # the figure's three-decimal values round to tab:checkpoint-heldout's (copied independently)
    assert round(published.cell("delivered", "MAPPO", "coalition-easy")["mean"], 2) == 16.09
    assert round(published.cell("delivered", "IPPO", "flow-hard")["half_width"], 2) == 7.17
    for ctl, cells in PAPER_COALITION.items():
        for scenario, (mean, half) in cells.items():
            row = published.cell("delivered", ctl, scenario)
            assert (row["mean"], round(row["half_width"], 2)) == (mean, half)
    for scenario, mean in PAPER_CENTRALIZED.items():
        assert published.cell("delivered", "centralized", scenario)["mean"] == mean


def test_compare_pairs_only_common_ok_episodes():
    runs = [{"controller": "p", "scenario": "s", "index": k, "status": "ok", "metrics": {"delivered": k}} for k in range(4)]
    runs += [{"controller": "g", "scenario": "s", "index": k, "status": "ok", "metrics": {"delivered": 2 * k}}
             for k in (1, 2, 3)]
    runs[3] = dict(runs[3], status="error", metrics=None)
    (row,) = compare(runs, "p", ["g"], ["s"], "delivered")
    assert row["n"] == 2 and row["mean_difference"] == pytest.approx(-1.5)
