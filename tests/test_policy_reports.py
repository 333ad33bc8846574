"""Numbers that cannot mislead: every renderer of a results bundle states n, names its instance set,
marks and refuses incomplete rows, and is never cut (spec/13-policy.md, F-POLICY-COVERAGE,
F-POLICY-TABLE, F-POLICY-FIGURE, F-POLICY-PUBLISHED, F-EXIT-CODES).

The class: a bundle whose rows are over fewer ok episodes than planned (errors, episodes never run,
a policy whose every episode failed, a scenario nobody finished), over a subset of a split, with
several policies.  ``bundles()`` generates any such bundle; each renderer — ``report --to
markdown|latex|svg``, ``evaluate --from`` as a table and as JSON — is checked against the truth the
generator knows.  ``benchmarks/fuzz_policy_reports.py`` runs the same checks on many more bundles.
"""

from __future__ import annotations

import json
import re
import tempfile
from pathlib import Path

import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

pytest.importorskip("scipy.stats", reason="the eval extra is not installed: pip install 'agspec[eval]'")

from agspec.catalogue import OFFICIAL_SCENARIOS, SPLITS, load_instance  # noqa: E402
from agspec.cli.main import cli  # noqa: E402
from agspec.formats.schemas import validate  # noqa: E402
from agspec.evaluate import run_episode  # noqa: E402
from agspec.policy.bundle import header  # noqa: E402
from agspec.policy.coverage import describe_indices  # noqa: E402

LONG = "a-policy-label-long-enough-to-be-cut-by-an-eighty-column-table"
LABELS = ("greedy", "random", "mine", LONG)


def _metric_template() -> dict:
    """The chapter 7 measures an episode record carries (from a 3-tick episode); values are overridden."""
    inst = load_instance("flow-easy", 0)
    inst["scenario"]["evaluation"]["horizon"] = 3
    return json.loads(json.dumps(run_episode(inst, "greedy").metrics))


METRIC_TEMPLATE = _metric_template()


@st.composite
def bundles(draw) -> dict:
    """A results bundle with the truth about it: ``(doc, truth)``; truth maps (label, scenario) to
    (planned, ok) and names the split and indices."""
    split = draw(st.sampled_from(["final-test", "validation"]))
    pool = list(SPLITS[split])
    indices = sorted(draw(st.lists(st.sampled_from(pool), min_size=1, max_size=5, unique=True)))
    if split == "validation" and draw(st.booleans()):
        indices = pool  # the whole split
    scenarios = draw(st.lists(st.sampled_from(OFFICIAL_SCENARIOS[:4]), min_size=1, max_size=2, unique=True))
    labels = draw(st.lists(st.sampled_from(LABELS), min_size=1, max_size=3, unique=True))
    with_plan = draw(st.booleans())  # bundles written before `planned` existed: policies x instances
    episodes, truth = [], {}
    status = st.sampled_from(["ok", "ok", "ok", "error", "missing"])
    for label in labels:
        for scenario in scenarios:
            ok = 0
            for k in indices:
                s = draw(status)
                if s == "missing":
                    continue
                ok += s == "ok"
                metrics = dict(METRIC_TEMPLATE, delivered=draw(st.integers(0, 40)),
                               completion_rate=draw(st.floats(0, 1, allow_nan=False)))
                episodes.append({"scenario": scenario, "controller": label, "index": k, "status": s,
                                 "metrics": metrics if s == "ok" else None, "illegal_actions": 0 if s == "ok" else None,
                                 "actions_sha256": None, "wall_time": 0.01,
                                 "error": None if s == "ok" else {"code": "exception", "message": "planned failure",
                                                                  "tick": 3, "agent": None, "detail": None}})
            truth[(label, scenario)] = (len(indices), ok)
    policies = [{"label": lab, "kind": "controller" if lab in ("greedy", "random") else "python",
                 "target": lab, "version": None, "file_sha256": None} for lab in labels]
    instances = [{"scenario": s, "index": k, "id": f"{s}-s{k}", "fingerprint": f"fp-{s}-{k}", "execution_seed": k}
                 for s in scenarios for k in indices]
    planned = {(lab, s): frozenset(indices) for lab in labels for s in scenarios} if with_plan else None
    doc = {**header(policies, instances, split=split, workers=1, options={}, planned=planned),
           "complete": True, "wall_time": 1.0, "nondeterminism": [], "episodes": episodes}
    return doc, {"cells": truth, "split": split, "indices": indices, "scenarios": scenarios, "labels": labels}


def invoke(*args: str):
    return CliRunner().invoke(cli, list(args), catch_exceptions=False)


def incomplete_cells(truth: dict) -> dict:
    return {key: v for key, v in truth["cells"].items() if v[1] < v[0]}


def check_common(text: str, truth: dict) -> None:
    """What every rendering says, whatever its format."""
    assert "…" not in text, "a table was cut"
    assert describe_indices(truth["indices"], truth["split"]) in text.replace("--", "–")
    # a split is named with its count ("3 of 50 final-test instances"), never alone
    assert not re.search(r"(?<![0-9] )\b(final-test|validation) instances", text)
    published = "(published)" in text or "IPPO" in text
    assert published == (truth["split"] == "final-test"), "published final-test rows beside other instances"
    if published:
        assert "training seeds" in text


def check_refused(res, truth: dict, output: str) -> None:  # RES-INCOMPLETE-REFUSED, F-POLICY-COVERAGE
    assert res.exit_code == 1, res.output
    assert output == "" or "±" not in output and "Method" not in output, "a refused table printed numbers"
    for (label, scenario), (planned, ok) in incomplete_cells(truth).items():
        assert f"{label} on {scenario}: {ok} of {planned} planned episodes ok" in res.stderr
    assert "--allow-incomplete" in res.stderr


def table_lines(text: str, label: str) -> list[str]:
    name = {"greedy": "Greedy", "random": "Random masked"}.get(label, label)
    text = text.split("episodes: wall time")[0]  # the metric tables, not the costs table
    return [line for line in text.splitlines()
            if re.match(rf"[|│]\s*{re.escape(name)}\s*[|│]|{re.escape(name)} &", line)]


def check_rows(text: str, truth: dict) -> None:
    """Each row shows n; each incomplete cell its mark and n of N; a complete row its N."""
    for label in truth["labels"]:
        lines = table_lines(text, label)
        assert lines, f"no row for {label}"
        for (lab, scenario), (planned, ok) in truth["cells"].items():
            if lab != label:
                continue
            if ok < planned:
                assert any(f"({ok} of {planned})" in line and ("‡" in line or r"\ddagger" in line) for line in lines)
            elif all(truth["cells"][(label, s)][1] == truth["cells"][(label, s)][0] for s in truth["scenarios"]):
                assert all(re.search(rf"[|│&]\s*{planned}\s*[|│&]", line) for line in lines), lines


@given(bundles())
@settings(max_examples=12, deadline=None, suppress_health_check=list(HealthCheck))
def test_every_table_renderer_states_n_and_refuses_incomplete_rows(tmp_path_factory, case):
    doc, truth = case
    assert validate("results", doc, limit=3) == []
    path = tmp_path_factory.mktemp("bundle") / "results.json"
    path.write_text(json.dumps(doc))
    incomplete = bool(incomplete_cells(truth))
    renderers = [("report", str(path), "--to", "markdown"), ("report", str(path), "--to", "latex"),
                 ("evaluate", "--from", str(path))]
    for args in renderers:
        refused = invoke(*args)
        if incomplete:
            check_refused(refused, truth, refused.stdout)
        allowed = invoke(*args, "--allow-incomplete")
        assert allowed.exit_code == (1 if incomplete else 0), allowed.output
        assert allowed.stdout == refused.stdout or incomplete  # the flag changes nothing for a complete bundle
        check_common(allowed.stdout, truth)
        check_rows(allowed.stdout, truth)


@given(bundles())
@settings(max_examples=8, deadline=None, suppress_health_check=list(HealthCheck))
def test_json_states_coverage_and_refuses_incomplete_rows(tmp_path_factory, case):
    doc, truth = case
    path = tmp_path_factory.mktemp("bundle") / "results.json"
    path.write_text(json.dumps(doc))
    incomplete = bool(incomplete_cells(truth))
    refused = invoke("evaluate", "--from", str(path), "--format", "json")
    if incomplete:
        check_refused(refused, truth, refused.stdout)
        assert refused.stdout == ""
    res = invoke("evaluate", "--from", str(path), "--format", "json", "--allow-incomplete")
    assert res.exit_code == (1 if incomplete else 0)
    out = json.loads(res.stdout)
    assert validate("evaluation", out, limit=3) == []
    assert out["complete"] is not incomplete
    assert out["instances"] == describe_indices(truth["indices"], truth["split"])
    for entry in out["summary"]:
        planned, ok = truth["cells"][(entry["controller"], entry["scenario"])]
        assert (entry["planned"], entry["complete"]) == (planned, ok == planned)
        assert entry["delivered"]["n"] == ok and (entry["delivered"]["half_width"] is None) == (ok < 2)


@given(bundles())
@settings(max_examples=3, deadline=None, suppress_health_check=list(HealthCheck))
def test_the_figure_states_n_and_refuses_incomplete_rows(tmp_path_factory, case):
    pytest.importorskip("matplotlib")
    doc, truth = case
    folder = tmp_path_factory.mktemp("figure")
    (folder / "results.json").write_text(json.dumps(doc))
    target = folder / "families.svg"
    incomplete = bool(incomplete_cells(truth))
    refused = invoke("report", str(folder / "results.json"), "--to", "svg", "-o", str(target))
    if incomplete:
        check_refused(refused, truth, "")
        assert not target.exists()
    res = invoke("report", str(folder / "results.json"), "--to", "svg", "-o", str(target), "--allow-incomplete")
    assert res.exit_code == (1 if incomplete else 0)
    svg = target.read_text()
    check_common(svg.replace("&#8211;", "–"), truth)
    for label in truth["labels"]:
        cells = [truth["cells"][(label, s)] for s in truth["scenarios"]]
        assert re.search(rf"{re.escape(label if label not in ('greedy', 'random') else '')}.*, n = ", svg)
        if any(ok < planned for planned, ok in cells):
            assert re.search(rf"{re.escape(label)}[^<]*incomplete", svg) or label in ("greedy", "random")


def test_one_ok_episode_of_ten_is_never_zero_plus_minus_zero(tmp_path):
    """The reported case: 1 of 10 policy episodes ok rendered as "0.00 ± 0.00" "over 10 instances"."""
    indices = list(range(1000, 1010))
    eps = [{"scenario": "coalition-easy", "controller": "mine", "index": k,
            "status": "ok" if k == 1000 else "error", "metrics": dict(METRIC_TEMPLATE) if k == 1000 else None,
            "illegal_actions": 0 if k == 1000 else None, "actions_sha256": None, "wall_time": 0.1,
            "error": None if k == 1000 else {"code": "timeout", "message": "m", "tick": 0, "agent": None,
                                              "detail": None}} for k in indices]
    doc = {**header([{"label": "mine", "kind": "python", "target": "x", "version": None, "file_sha256": None}],
                    [{"scenario": "coalition-easy", "index": k, "id": str(k), "fingerprint": "f", "execution_seed": k}
                     for k in indices], split="final-test", workers=1, options={}),
           "complete": True, "episodes": eps}
    path = tmp_path / "r.json"
    path.write_text(json.dumps(doc))
    for args in (("report", str(path)), ("report", str(path), "--to", "latex"), ("evaluate", "--from", str(path))):
        res = invoke(*args)
        assert res.exit_code == 1 and "± 0.00" not in res.stdout and "0.00 ± 0.00" not in res.stdout
        assert "mine on coalition-easy: 1 of 10 planned episodes ok (9 errors)" in res.stderr
        shown = invoke(*args, "--allow-incomplete")
        mine = table_lines(shown.stdout, "mine")
        assert shown.exit_code == 1 and mine and not any("±" in line or r"\pm" in line for line in mine)
        assert all("(1 of 10)" in line for line in mine) and "10 of 50 final-test instances" in shown.stdout


@pytest.mark.parametrize("mutant", ["hides_incomplete", "plus_minus_zero"])
def test_the_checks_catch_a_renderer_that_misleads(monkeypatch, tmp_path_factory, mutant):
    """The generator's checks prove themselves: a renderer that takes every row as complete, or that
    prints "± 0" over one episode, fails them."""
    from agspec.policy import coverage as coverage_module
    from agspec.policy import stats

    if mutant == "hides_incomplete":
        monkeypatch.setattr(coverage_module.Coverage, "complete", property(lambda self: True))
    else:
        original = stats.summary_cell
        monkeypatch.setattr("agspec.policy.tables.summary_cell", lambda *a: {
            **original(*a), "half_width": original(*a)["half_width"] or 0.0})
    with pytest.raises(AssertionError):
        if mutant == "hides_incomplete":
            test_every_table_renderer_states_n_and_refuses_incomplete_rows(tmp_path_factory)
        else:
            test_one_ok_episode_of_ten_is_never_zero_plus_minus_zero(Path(tempfile.mkdtemp()))
