"""The conformance suite itself: it loads, lints clean, covers every rule and
invariant heading of the spec, passes on the reference interpreter, has stable content ids, and
reports malformed cases at file:line."""

from __future__ import annotations

import dataclasses
import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from jsonschema import Draft202012Validator

from agspec.conform.cases import (
    Case,
    SuiteError,
    check_expectations,
    coverage,
    first_difference,
    lint_suite,
    load_case_file,
    load_suite,
    resolve_pointer,
    trace_records,
)
from agspec.interp.snapshot import global_state
from agspec.ir.fingerprint import fingerprint
from agspec.interp.tick import Simulator
from agspec.resources import conformance_dir, schemas_dir
from agspec.spec_index import spec_ids

ROOT = conformance_dir()


@pytest.fixture(scope="module")
def suite() -> list[Case]:
    return load_suite()


def _collect() -> list[Case]:
    try:
        return load_suite()
    except SuiteError:  # reported by test_suite_loads_and_lints_clean
        return []


CASES = _collect()


def _run_local(case: Case) -> list[str]:
    """A tiny local driver: the reference Simulator plus check_expectations, nothing else."""
    sim = Simulator(case.instance)
    sim.reset(case.execution_seed)
    ctl = None
    if case.driver and "controller" in case.driver:
        from agspec.controllers import make_controller

        seed = case.driver.get("seed", case.execution_seed)
        ctl = make_controller(case.driver["controller"], seed)
        ctl.reset(seed)
    obs_ticks = {e["after_tick"] for e in case.expectations if "observations" in e}
    failures: list[str] = []
    for t in range(case.ticks):
        actions = ctl.act(sim.observe(), sim) if ctl else case.actions[t]
        result = sim.step(actions)
        obs = sim.observe() if t in obs_ticks else None
        failures += check_expectations(case, t, global_state(sim.state), result.events, observations=obs, done=sim.done)
    return failures


# ------------------------------------------------------------------------------------------ the suite


def test_case_schema_is_valid_draft_2020_12():
    schema = json.loads((schemas_dir() / "case.schema.json").read_text(encoding="utf-8"))
    Draft202012Validator.check_schema(schema)


def test_suite_loads_and_lints_clean(suite):
    assert len(suite) >= 40
    assert lint_suite(suite) == []


def test_case_ids_are_unique_content_fingerprints(suite):
    ids = [c.id for c in suite]
    assert len(set(ids)) == len(ids)
    assert all(re.fullmatch(r"c-[0-9a-f]{12}", i) for i in ids)
    assert all(c.fingerprint.startswith("sha256:" + c.id[2:]) for c in suite)


def test_every_rule_and_invariant_heading_is_covered(suite):
    cov = coverage(suite)
    assert cov["uncovered"] == []
    universe = spec_ids(("R-", "INV-"))
    assert set(cov["rules"]) | set(cov["invariants"]) == set(universe)
    # the transition chapter and the invariants chapter are in the universe
    for ident in ("R-HANDOFF", "R-XOR-CLOSURE", "R-HELD-MATERIAL", "INV-TRACE", "INV-ACCOUNTING"):
        assert ident in universe
    assert all(cov["rules"][i] for i in cov["rules"]) and all(cov["invariants"][i] for i in cov["invariants"])


def test_mechanism_controls_are_present(suite):
    tags = {t for c in suite for t in c.tags}
    assert {"paper-case", "cmax", "coalition-2", "coalition-3", "coalition-4", "xor", "join", "serial",
            "bilateral", "expiry", "switching", "wip", "replenish", "coercion", "trace"} <= tags
    assert sum(1 for c in suite if c.driver and "trace" in c.driver) >= 3


@pytest.mark.parametrize("case", CASES, ids=[f"{c.id}-{c.source.stem}" for c in CASES])
def test_case_passes_on_the_reference(case):
    assert _run_local(case) == [], f"{case.location} {case.title}"


def test_trace_cases_replay_every_recorded_state(suite):
    for case in (c for c in suite if c.driver and "trace" in c.driver):
        header, ticks = trace_records(case)
        assert case.ticks == len(ticks)
        assert fingerprint(header["instance"]) == fingerprint(case.instance)
        per_tick = [e for e in case.expectations if e.get("_index") == "trace"]
        assert len(per_tick) == len(ticks)
        assert all("" in e["state"] for e in per_tick)


# ------------------------------------------------------------------------------------------ ids


def _copy_case(tmp_path: Path, name: str, edit) -> Path:
    src = ROOT / "cases" / "picks.yaml"
    text = edit(src.read_text(encoding="utf-8"))
    dst = tmp_path / "elsewhere" / name
    dst.parent.mkdir(parents=True)
    dst.write_text(text, encoding="utf-8")
    return dst


def test_ids_survive_renaming_titles_tags_rules_and_moving_files(tmp_path):
    original = load_case_file(ROOT / "cases" / "picks.yaml", ROOT)

    def rename(text: str) -> str:
        text = re.sub(r'title: "', 'title: "renamed: ', text)
        text = text.replace("tags: [pick, tie]", "tags: [other]")
        text = text.replace("notes: >", "notes: >\n    An added sentence.")
        return text.replace("rules: [R-PICK, R-BLOCKING]\n", "rules: [R-PICK]\n")

    moved = load_case_file(_copy_case(tmp_path, "moved.yml", rename), ROOT)
    assert [c.id for c in moved] == [c.id for c in original]
    assert moved[0].title.startswith("renamed: ")


def test_ids_change_with_defining_content(tmp_path):
    original = load_case_file(ROOT / "cases" / "picks.yaml", ROOT)
    changed = load_case_file(_copy_case(tmp_path, "x.yaml", lambda t: t.replace("/shelves/0/A: 5", "/shelves/0/A: 4", 1)), ROOT)
    assert changed[0].id != original[0].id
    assert [c.id for c in changed[1:]] == [c.id for c in original[1:]]


# ------------------------------------------------------------------------------------------ malformed


def _write(tmp_path: Path, text: str, name: str = "bad.yaml") -> Path:
    root = tmp_path / "suite"
    (root / "cases").mkdir(parents=True, exist_ok=True)
    (root / "instances").mkdir(exist_ok=True)
    shutil.copy(ROOT / "instances" / "insert4-2x2-flat.json", root / "instances" / "insert4-2x2-flat.json")
    path = root / "cases" / name
    path.write_text(text, encoding="utf-8")
    return path


GOOD = """\
- title: ok
  rules: [R-PICK]
  invariants: []
  instance: instances/insert4-2x2-flat.json
  script:
    - {"0,0": {pick: "pick:0:A:0"}}
  expectations:
    - after_tick: 0
      state: {"/robots/0,0/holding": "0:A"}
"""

MALFORMED = [
    # (replacement applied to GOOD, expected line, message fragment)
    (("  script:", "  script: [\n"), 7, "not valid YAML"),
    (("  rules: [R-PICK]\n", ""), 1, "rules"),
    (('"pick:0:A:0"', '"pick:0:B:0"'), 6, "pick option 'pick:0:B:0' is not offered"),
    (('{"0,0": {pick', '{"7,7": {pick'), 6, "no robot 7,7"),
    (("{pick: ", "{juggle: "), 6, "case schema"),
    (('  script:\n    - {"0,0": {pick: "pick:0:A:0"}}\n  expectations:\n    - after_tick: 0',
      "  driver: {controller: greedy, ticks: 1}\n  expectations:\n    - after_tick: 3"), 7, "runs only 1 ticks"),
    (("instances/insert4-2x2-flat.json", "instances/missing.json"), 4, "missing.json"),
    (('"/robots/0,0/holding"', '"robots"'), 9, "/expectations/0/state/robots"),
    (("    - after_tick: 0\n", "    - after_tick: 0\n      events: [{cause: x}]\n"), 9, "'type' is a required property"),
    (('pick: "pick:0:A:0"', 'handoff: UP'), 6, "case schema"),
    (("  invariants: []\n", "  invariants: []\n  colour: red\n"), 1, "colour"),
]


@pytest.mark.parametrize("edit,line,fragment", MALFORMED)
def test_malformed_case_is_a_located_suite_error(tmp_path, edit, line, fragment):
    path = _write(tmp_path, GOOD.replace(*edit))
    with pytest.raises(SuiteError) as info:
        load_suite(path.parent.parent)
    err = info.value
    assert err.file.endswith("bad.yaml")
    assert err.line == line, str(err)
    assert fragment in str(err)
    assert re.match(r"^\S*bad\.yaml:\d+: ", str(err))


def test_good_case_in_a_scratch_suite_loads(tmp_path):
    path = _write(tmp_path, GOOD)
    (case,) = load_suite(path.parent.parent)
    assert case.actions == ({"0,0": 2},)
    assert _run_local(case) == []


def test_every_problem_of_a_suite_is_reported(tmp_path):
    _write(tmp_path, GOOD.replace('"0,0": {pick', '"9,9": {pick'), "a.yaml")
    path = _write(tmp_path, GOOD.replace("rules: [R-PICK]", "rules: []"), "b.yaml")
    with pytest.raises(SuiteError) as info:
        load_suite(path.parent.parent)
    assert [p.file.rsplit("/", 1)[-1] for p in info.value.problems] == ["a.yaml", "b.yaml"]


# ------------------------------------------------------------------------------------------ lint


def test_lint_flags_unknown_ids_duplicates_masked_actions_and_bad_pointers(tmp_path):
    teleport = "R-" + "TELEPORT"  # not a spec ID (spelled apart so the spec guard does not see a citation)
    text = GOOD.replace("rules: [R-PICK]", f"rules: [R-PICK, {teleport}]")
    text = text.replace('"/robots/0,0/holding": "0:A"', '"/robots/0,0/holding": "0:A", "/robots/0,0/hat": 1')
    text += text.replace("title: ok", "title: same content again")
    text += GOOD.replace('{"0,0": {pick: "pick:0:A:0"}}', '{"0,0": 1}').replace("title: ok", "title: masked")
    path = _write(tmp_path, text)
    problems = lint_suite(load_suite(path.parent.parent))
    joined = "\n".join(problems)
    assert f"{teleport} is not a rule or invariant heading" in joined
    assert "duplicate case id" in joined
    assert "/robots/0,0/hat does not exist" in joined
    assert "action 1 is masked" in joined and "R-ACTION-VALIDATION" in joined
    assert all(re.match(r"^\S*bad\.yaml:\d+: ", p) for p in problems)


# ------------------------------------------------------------------------------------------ expectations


def test_check_expectations_reports_pointer_expected_and_actual(suite):
    case = next(c for c in suite if c.title.startswith("two products pick the same token"))
    exps = list(case.expectations)
    k = next(i for i, e in enumerate(exps) if e["after_tick"] == 1)
    exps[k] = dict(exps[k], state={**exps[k]["state"], "/shelves/0/A": 4},
                   events=exps[k]["events"] + [{"type": "blocked", "cause": "geometry"}],
                   no_events=[{"type": "pick_started"}], absent=["/activities/0"])
    broken = dataclasses.replace(case, expectations=tuple(exps))
    messages = _run_local(broken)
    assert any("state /shelves/0/A: expected 4, got 5" in m for m in messages)
    assert any('no event matches {"cause": "geometry", "type": "blocked"}' in m for m in messages)
    assert any("unexpected event" in m and "pick_started" in m for m in messages)
    assert any("/activities/0: expected absent" in m for m in messages)
    assert all(m.startswith("conformance/cases/picks.yaml:") or "picks.yaml:" in m for m in messages)


def test_events_are_matched_one_to_one():
    case = load_case_file(ROOT / "cases" / "picks.yaml", ROOT)[1]
    twice = dataclasses.replace(case, expectations=({"after_tick": 0, "events": [{"type": "release"}, {"type": "release"}]},))
    assert check_expectations(twice, 0, {}, [{"type": "release", "product": 1}])
    assert not check_expectations(twice, 0, {}, [{"type": "release", "product": 1}, {"type": "release", "product": 2}])


def test_done_and_observation_assertions_are_optional_capabilities(suite):
    case = next(c for c in suite if "cmax" in c.tags)
    last = max(e["after_tick"] for e in case.expectations if "done" in e)
    assert check_expectations(case, last, {"t": 0}, [], done=False)  # wrong done is reported
    skipped = [m for m in check_expectations(case, last, {"t": case.ticks, "products": [{"delivered_at": case.ticks}],
                                                          "delivered": 1}, [], done=None)]
    assert not any("done" in m for m in skipped)
    obs_case = next(c for c in suite if c.needs_observations)
    t = next(e["after_tick"] for e in obs_case.expectations if "observations" in e)
    assert not any("observation" in m for m in check_expectations(obs_case, t, {}, [], observations=None))


def test_whole_state_comparison_names_the_first_differing_field():
    expected = {"robots": {"0,0": {"holding": "0:A", "busy_until": 3}}, "items": {"0:A": "0,0"}}
    actual = json.loads(json.dumps(expected))
    actual["robots"]["0,0"]["busy_until"] = 4
    assert first_difference(expected, actual) == ("/robots/0,0/busy_until", 3, 4)
    assert first_difference([1, 2], [1, 2, 3])[0] == "/2"
    assert first_difference({"a": 1}, {"a": 1.0}) is None
    assert first_difference({"a": True}, {"a": 1}) is not None
    assert resolve_pointer({"a/b": {"~": 1}}, "/a~1b/~0") == 1


# ------------------------------------------------------------------------------------------ generated files


def test_instances_are_reproducible_from_the_generator():
    tool = ROOT / "tools" / "make_instances.py"
    proc = subprocess.run([sys.executable, str(tool), "--check"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr


def test_traces_are_small_and_complete():
    files = sorted((ROOT / "traces").glob("*.jsonl"))
    assert len(files) >= 3
    assert sum(f.stat().st_size for f in files) < 3 * 1024 * 1024
    for f in files:
        lines = f.read_text(encoding="utf-8").splitlines()
        head, foot = json.loads(lines[0]), json.loads(lines[-1])
        assert head["type"] == "header" and foot["type"] == "footer" and foot["complete"]
        assert foot["ticks"] == len(lines) - 2


def test_alias_bomb_in_a_case_file_is_refused_before_it_is_built(tmp_path):
    # F-LIMITS: the case loader composes YAML for its line map; an alias bomb must be refused on the
    # node graph (a billion-laughs document expands to 9**9 nodes), never constructed
    lines = ["a0: &a0 [x, x, x, x, x, x, x, x, x]"]
    lines += [f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 9)}]" for i in range(1, 9)]
    path = _write(tmp_path, "\n".join(lines) + "\n")
    with pytest.raises(SuiteError) as info:
        load_suite(path.parent.parent)
    assert "max_yaml_nodes" in str(info.value) or "YAML nodes" in str(info.value)
    assert str(info.value).startswith(str(path)) or "bad.yaml" in str(info.value)


def test_reference_traces_are_what_agspec_run_writes_today():
    """conformance/traces/*.jsonl are regenerated by conformance/tools/make_traces.py; a change of the
    trace format (a new header field) or of the interpreter must regenerate them too."""
    tool = Path(__file__).resolve().parents[1] / "conformance" / "tools" / "make_traces.py"
    proc = subprocess.run([sys.executable, str(tool), "--check"], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
