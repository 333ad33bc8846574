"""A trained row never passes for the paper's (spec/13-policy.md F-POLICY-BUDGET, RES-BUDGET-MARKED;
spec/16-training.md T-RECORD, T-CHECKPOINT-ROW).

The class: results bundles of trained policies (checkpoint identities) whose runs are below, at or
above the paper's 1,536,000 training steps and were evaluated with the masked argmax or sampled
actions (or by a bundle that predates the recorded action), beside the published rows; and training
run directories of such budgets.  ``trained_bundles()`` generates any such bundle with the truth
about it; every renderer — ``report --to markdown|latex|svg``, ``evaluate --from`` (the terminal's
table), the held-out row and the training curves — is checked: each rendering of a row below the
budget carries the mark † (LaTeX ``$^{\\dagger}$``) and its budget in words; a row at the paper's
budget carries no mark; each states the evaluation action.  The expected names are computed here,
independently of ``agspec.policy.trained``, and the last tests plant mutants the checks must catch.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

pytest.importorskip("scipy.stats", reason="the eval extra is not installed: pip install 'agspec[eval]'")

from agspec.cli.main import cli  # noqa: E402
from agspec.formats.schemas import validate  # noqa: E402
from agspec.policy.bundle import header  # noqa: E402
from agspec.train.config import PAPER_BUDGET  # noqa: E402

from test_policy_reports import METRIC_TEMPLATE  # noqa: E402

NAMES = {"ippo": "IPPO", "mappo": "MAPPO", "qmix": "QMIX"}
SCENARIOS = ("flow-easy", "coalition-easy")
STEPS = (4_000, 16_000, PAPER_BUDGET - 1_600, PAPER_BUDGET, PAPER_BUDGET + 16_000)
NO_SHRINK = (Phase.explicit, Phase.reuse, Phase.generate)  # figures are slow to shrink over
ACTION_WORDS = {"greedy": "masked argmax", "sample": "sampled actions"}


def expected_name(label: str, algorithm: str, steps: int) -> str:
    method = NAMES[algorithm] + ("†" if steps < PAPER_BUDGET else "")
    return method if label in (NAMES[algorithm], method) else f"{label} ({method})"


@st.composite
def trained_bundles(draw) -> tuple[dict, dict]:
    """(bundle, truth): 1–3 trained policies on final-test instances, beside Greedy; truth maps each
    label to its algorithm, scenario, steps, action and expected name."""
    indices = sorted(draw(st.lists(st.integers(1000, 1049), min_size=1, max_size=3, unique=True)))
    labels = draw(st.lists(st.sampled_from(["IPPO", "MAPPO", "run-a", "run-b"]), min_size=1, max_size=3,
                           unique=True))
    policies = [{"label": "greedy", "kind": "controller", "target": "greedy", "version": None, "file_sha256": None}]
    truth, episodes, scenarios = {}, [], set()
    for seed, label in enumerate(labels):
        algorithm = label.lower() if label in ("IPPO", "MAPPO") else draw(st.sampled_from(sorted(NAMES)))
        scenario = draw(st.sampled_from(SCENARIOS))
        steps = draw(st.sampled_from(STEPS))
        action = draw(st.sampled_from(["greedy", "sample", None]))  # None: a bundle before `action`
        training = {"algorithm": algorithm, "scenario": scenario, "seed": seed, "steps": steps,
                    "config_sha256": "0" * 64}
        if action is not None:
            training["action"] = action
        policies.append({"label": label, "kind": "checkpoint", "target": f"/runs/{label}", "version": None,
                         "file_sha256": "1" * 64, "training": training})
        truth[label] = {"algorithm": algorithm, "scenario": scenario, "steps": steps, "action": action or "greedy",
                        "name": expected_name(label, algorithm, steps)}
        scenarios.add(scenario)
    for scenario in sorted(scenarios):
        for label in ["greedy", *(lab for lab in labels if truth[lab]["scenario"] == scenario)]:
            for k in indices:
                episodes.append({"scenario": scenario, "controller": label, "index": k, "status": "ok",
                                 "metrics": dict(METRIC_TEMPLATE, delivered=draw(st.integers(0, 30))),
                                 "illegal_actions": 0, "actions_sha256": None, "wall_time": 0.01, "error": None})
    instances = [{"scenario": s, "index": k, "id": f"{s}-{k}", "fingerprint": f"fp-{s}-{k}", "execution_seed": k}
                 for s in sorted(scenarios) for k in indices]
    planned = {(p["label"], s): frozenset(indices) for p in policies for s in sorted(scenarios)
               if p["kind"] == "controller" or truth[p["label"]]["scenario"] == s}
    doc = {**header(policies, instances, split="final-test", workers=1, options={}, planned=planned),
           "complete": True, "wall_time": 1.0, "nondeterminism": [], "episodes": episodes}
    if any(p["kind"] == "checkpoint" and "action" not in p["training"] for p in policies):
        for p in doc["policies"]:  # an older bundle: header() records the action, a bundle before it did not
            if p["kind"] == "checkpoint" and truth[p["label"]]["action"] == "greedy" and draw(st.booleans()):
                p["training"].pop("action", None)
    return doc, truth


def invoke(*args: str):
    return CliRunner().invoke(cli, list(args), catch_exceptions=False)


def budget_words(steps: int) -> str:
    if steps < PAPER_BUDGET:
        return f"{steps:,} of the paper's {PAPER_BUDGET:,} training steps"
    return f"{steps:,} training steps"


def check_rows(text: str, truth: dict, sep: str, dagger: str = "†") -> None:
    """Each trained row's line starts with its expected name (marked iff below the budget); no other
    line of a row at or above the budget carries the mark."""
    for label, t in truth.items():
        name = t["name"].replace("†", dagger)
        if sep == "&":
            name = name.replace("_", r"\_")
        lines = [line for line in text.splitlines() if re.match(rf"\s*[|│]?\s*{re.escape(name)}\s*[|│&]", line)]
        assert lines, f"no row named {name!r} for {label} ({t['steps']} steps)"
        if t["steps"] >= PAPER_BUDGET:
            assert not any(dagger in line for line in lines), lines


def check_notes(text: str, truth: dict, dagger: str = "†") -> None:
    """Under the table or figure: each row's budget in words and its evaluation action."""
    flat = re.sub(r"\s+", " ", text)
    for t in truth.values():
        name = t["name"].replace("†", dagger)
        assert f"{name} — {budget_words(t['steps'])}".replace("—", "---" if dagger != "†" else "—") in flat, name
        assert ACTION_WORDS[t["action"]] in flat
    if any(t["steps"] < PAPER_BUDGET for t in truth.values()):
        assert "below the paper's budget" in flat


@given(trained_bundles())
@settings(max_examples=10, deadline=None, suppress_health_check=list(HealthCheck))
def test_every_table_marks_a_row_below_the_papers_budget(tmp_path_factory, case):
    check_tables(tmp_path_factory, case)


def check_tables(tmp_path_factory, case) -> None:
    doc, truth = case
    assert validate("results", doc, limit=3) == []  # F-POLICY-BUNDLE: steps and action in the schema
    path = tmp_path_factory.mktemp("bundle") / "results.json"
    path.write_text(json.dumps(doc))
    md = invoke("report", str(path), "--to", "markdown")
    assert md.exit_code == 0, md.output
    main_md = md.stdout.split("Trained checkpoints")[0]
    check_rows(main_md, truth, "|")
    check_notes(main_md, truth)
    assert "IPPO (published)" in main_md or "MAPPO (published)" in main_md  # beside the published rows
    rich = invoke("evaluate", "--from", str(path))
    assert rich.exit_code == 0, rich.output
    check_rows(rich.stdout, truth, "│")
    check_notes(rich.stdout, truth)
    tex = invoke("report", str(path), "--to", "latex")
    assert tex.exit_code == 0, tex.output
    main_tex = tex.stdout.split(r"\end{table}")[0]
    check_rows(main_tex, truth, "&", r"$^{\dagger}$")
    check_notes(main_tex, truth, r"$^{\dagger}$")
    check_heldout(md.stdout, tex.stdout, truth)


def check_heldout(md: str, tex: str, truth: dict) -> None:
    """T-CHECKPOINT-ROW: a method's row is marked iff one of its runs is below the budget; it shows steps."""
    groups: dict[tuple[str, str], list[dict]] = {}
    for t in truth.values():
        groups.setdefault((t["algorithm"], t["scenario"]), []).append(t)
    for (algorithm, scenario), members in groups.items():
        low = any(m["steps"] < PAPER_BUDGET for m in members)
        name = NAMES[algorithm] + ("†" if low else "")
        steps = sorted({m["steps"] for m in members})
        shown = f"{steps[0]:,}" if len(steps) == 1 else f"{steps[0]:,}–{steps[-1]:,}"
        assert f"| {name} | {scenario} | {shown} |" in md, (name, scenario)
        tex_name = NAMES[algorithm] + (r"$^{\dagger}$" if low else "")
        assert f"{tex_name} & {scenario} & {shown.replace('–', '--')} &" in tex


@given(trained_bundles())
@settings(max_examples=3, deadline=None, suppress_health_check=list(HealthCheck), phases=NO_SHRINK)
def test_the_family_figure_marks_a_series_below_the_papers_budget(tmp_path_factory, case):
    pytest.importorskip("matplotlib")
    doc, truth = case
    folder = tmp_path_factory.mktemp("figure")
    (folder / "results.json").write_text(json.dumps(doc))
    target = folder / "families.svg"
    res = invoke("report", str(folder / "results.json"), "--to", "svg", "-o", str(target))
    assert res.exit_code == 0, res.output
    svg = target.read_text()
    for t in truth.values():
        # a legend entry starts with the name (not inside another entry's "run (MAPPO†)")
        entry = re.findall(rf"(?<![\w(]){re.escape(t['name'].rstrip('†'))}†?(?:\))?, n = ", svg)
        assert entry, t["name"]
        assert all(("†" in e) == (t["steps"] < PAPER_BUDGET) for e in entry), entry
    check_notes(svg.replace("&#8212;", "—"), truth)


def fake_run(root: Path, name: str, algorithm: str, scenario: str, seed: int, budget: int) -> Path:
    d = root / name
    d.mkdir()
    summary = {"schema": "agspec-training-run/1", "status": "complete", "algorithm": algorithm, "scenario": scenario,
               "seed": seed, "budget": budget, "steps": budget}
    (d / "run.json").write_text(json.dumps(summary))
    rows = [{"kind": "header", "schema": "agspec-training-record/1", "budget": budget}]
    for k in range(1, 4):
        rows.append({"kind": "progress", "steps": budget * k // 3, "milestone_return": 1.0 * k, "admissions": 1.0,
                     "delivered": 2.0 * k, "entropy": 1.0 / k, "explained_variance": 0.1 * k})
    rows.append({"kind": "validation", "phase": "block-4", "action": "greedy", "steps": budget,
                 "indices": [200, 201, 202, 203, 204], "delivered": [0, 0, 1, 0, 0], "delivered_mean": 0.2,
                 "completion_rate_mean": 0.0, "elapsed_s": 1.0})
    (d / "record.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    return d


@given(runs=st.lists(st.tuples(st.sampled_from(sorted(NAMES)), st.sampled_from(SCENARIOS), st.sampled_from(STEPS)),
                     min_size=1, max_size=3))
@settings(max_examples=4, deadline=None, suppress_health_check=list(HealthCheck), phases=NO_SHRINK)
def test_training_curves_say_what_they_show_and_mark_short_runs(tmp_path_factory, runs):  # T-RECORD
    pytest.importorskip("matplotlib")
    root = tmp_path_factory.mktemp("runs")
    dirs = [str(fake_run(root, f"r{k}", a, s, k, b)) for k, (a, s, b) in enumerate(runs)]
    target = root / "curves.svg"
    res = invoke("report", *dirs, "--to", "svg", "-o", str(target))
    assert res.exit_code == 0, res.output
    svg = re.sub(r"\s+", " ", target.read_text().replace("&#8211;", "–").replace("&#8212;", "—"))
    assert "sampled actions" in svg and "training realizations" in svg and "masked argmax" in svg
    assert "validation instances 200–204" in svg and "per training episode" in svg
    groups: dict[tuple[str, str], list[int]] = {}
    for a, s, b in runs:
        groups.setdefault((a, s), []).append(b)
    for (a, s), budgets in groups.items():
        name = NAMES[a] + ("†" if min(budgets) < PAPER_BUDGET else "")
        assert f"{name} on {s} (n={len(budgets)}) — " in svg
        if len(set(budgets)) == 1:
            assert f"{name} on {s} (n={len(budgets)}) — {budget_words(budgets[0])}" in svg
    if any(s.startswith("flow") for _a, s, _b in runs):
        assert "not drawn for Flow" in svg
    if all(b >= PAPER_BUDGET for _a, _s, b in runs):
        assert "†" not in svg


def test_an_identity_records_its_evaluation_action():  # F-POLICY-BUNDLE, F-POLICY-BUDGET
    base = {"kind": "checkpoint", "version": None, "file_sha256": "1" * 64,
            "training": {"algorithm": "ippo", "scenario": "flow-easy", "seed": 0, "steps": 4000,
                         "config_sha256": "0" * 64}}
    head = header([{**base, "label": "a", "target": "/r/a"}, {**base, "label": "b", "target": "/r/b#sample"}],
                  [], split="final-test", workers=1, options={})
    assert [p["training"]["action"] for p in head["policies"]] == ["greedy", "sample"]
    assert validate("results", {**head, "episodes": []}, limit=3) == []
    bad = json.loads(json.dumps(head))
    bad["policies"][0]["training"]["action"] = "argmax"
    assert validate("results", {**bad, "episodes": []}, limit=3)


def test_the_papers_budget_is_the_configurations():  # F-POLICY-BUDGET: published.json and tab:marlconfig agree
    from agspec.policy.trained import paper_steps

    assert paper_steps() == PAPER_BUDGET == 1_536_000


@pytest.mark.parametrize("mutant", ["never_below", "always_below", "rows_without_training", "latex_unmarked"])
def test_the_checks_catch_a_renderer_that_hides_the_budget(monkeypatch, tmp_path_factory, mutant):
    """The checks prove themselves: a renderer that never marks, marks every row, forgets the runs of the
    policies, or drops the mark in LaTeX fails them."""
    from agspec.policy import tables, trained

    if mutant == "never_below":
        monkeypatch.setattr(trained, "below", lambda t: False)
    elif mutant == "always_below":
        monkeypatch.setattr(trained, "below", lambda t: True)
    elif mutant == "rows_without_training":
        monkeypatch.setattr(trained, "trainings", lambda policies: {})
    else:
        original = tables.tex
        monkeypatch.setattr(tables, "tex", lambda text: original(text).replace("†", ""))
    @given(trained_bundles())
    @settings(max_examples=20, deadline=None, suppress_health_check=list(HealthCheck), database=None, phases=NO_SHRINK)
    def check(case):
        check_tables(tmp_path_factory, case)

    with pytest.raises(AssertionError):
        check()
