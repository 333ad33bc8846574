"""`agspec render`: the compact replay encoding, the CLI, and the page in a real browser.

Unit part: the keyframe + diff encoding reproduces every state and observation of a trace exactly;
a 48-robot 400-tick page stays under 5 MB; bad input gets a located message and its exit code
(F-EXIT-CODES); a real failing conformance report (a seeded mutant) renders side by side; a trace
recorded from a subprocess simulator over the protocol equals `agspec run`'s.

Browser part (headless Chromium through Playwright, skipped with a reason when either is missing):
a page per official scenario, stepped to a tick where a coalition is active; the DOM must show
exactly that coalition's members and roles and the delivered count of that tick, without console
or page errors; scrubbing to the end and back shows the footer's and the initial counts.
"""

from __future__ import annotations

import json
import shlex
import sys
from pathlib import Path

import pytest

from agspec.viewer.encode import apply_diff, decode_states, delta_decode, diff, encode, trace_data
from replay_pages import (Page, browser, embedded, failing_report, record_reference, render,  # noqa: F401 (fixtures)
                          write_trace)

ROOT = Path(__file__).resolve().parents[1]
SIM = ROOT / "tests" / "mutants" / "sim.py"
OFFICIAL = [f"{f}-{lvl}" for f in ("flow", "coalition", "concurrency") for lvl in ("easy", "medium", "hard")]


# ----------------------------------------------------------------------------------------- helpers
def canon(value) -> str:
    return json.dumps(value, sort_keys=True)


def states_of(records: list[dict]) -> list[dict]:
    return [records[0]["state"]] + [r["state"] for r in records if r["type"] == "tick"]


def coalitions(state: dict) -> list[dict]:
    return [a for a in state["activities"] if a["kind"] == "operation" and len(a["members"]) >= 2]


# ----------------------------------------------------------------------------------------- encoding
def test_diff_operations_are_exact():
    """Deletes, truncation, appends, id-replaced list elements; 1 vs 1.0 vs True and -0.0 vs 0.0 differ."""
    cases = [
        ({"a": 1, "b": 2}, {"a": 1}),
        ({"l": [1, 2, 3]}, {"l": [1]}),
        ({"l": [1]}, {"l": [1, 2, {"x": [3]}]}),
        ({"acts": [{"id": "p", "v": 1}, {"id": "q", "v": 2}]}, {"acts": [{"id": "q", "v": 2}]}),
        ({"x": 1}, {"x": 1.0}),
        ({"x": 1}, {"x": True}),
        ({"x": 0.0}, {"x": -0.0}),
        ({"x": None}, {"x": {"deep": [None]}}),
    ]
    for old, new in cases:
        ops = diff(old, new)
        assert ops, (old, new)
        assert canon(apply_diff(json.loads(json.dumps(old)), ops)) == canon(new)
    assert diff({"a": [1, {"b": 2.5}]}, {"a": [1, {"b": 2.5}]}) == []


def test_encoding_round_trip_equals_every_state_and_observation():
    records = record_reference("coalition-medium", 40, observations=True)
    data = trace_data(records)
    doc = encode(data, keyframe=7)  # an odd keyframe interval: most ticks are rebuilt from diffs
    assert doc["T"] == 40 and len(doc["states"]["keys"]) == 6
    decoded = decode_states(doc)
    assert [canon(s) for s in decoded] == [canon(s) for s in states_of(records)]
    obs = [r["observations"] for r in records if r["type"] == "tick"]
    assert [canon(delta_decode(doc["observations"], t)) for t in range(40)] == [canon(o) for o in obs]
    # the document survives its own JSON text (what the page embeds)
    again = json.loads(json.dumps(doc))
    assert [canon(s) for s in decode_states(again)] == [canon(s) for s in decoded]


def test_kstar_series_is_the_reference_capacity_while_states_match():
    """K*(s_t) per tick (M-CAPACITY): its mean over the epochs is the footer's capacity_mean; a
    tampered state ends the series there (the page then shows the episode mean instead)."""
    records = record_reference("coalition-medium", 120)
    doc = encode(trace_data(records))
    ks = doc["kstar"]
    assert len(ks) == 121 and max(ks) >= 2
    assert sum(ks[:120]) / 120 == pytest.approx(records[-1]["metrics"]["capacity_mean"])
    tampered = json.loads(json.dumps(records))
    ticks = [r for r in tampered if r["type"] == "tick"]
    ticks[49]["state"]["robots"]["0,0"]["busy_until"] += 7  # the record of tick 49 holds s_50
    assert encode(trace_data(tampered))["kstar"] == ks[:50]
    foreign = json.loads(json.dumps(records))
    del foreign[0]["instance"]["realization"]  # not an instance the reference can load
    assert encode(trace_data([foreign[0]]))["kstar"] == []


def test_48_robots_400_ticks_stay_under_5_mb(tmp_path: Path):
    trace = write_trace(record_reference("concurrency-hard", 400), tmp_path / "ch.jsonl")
    code, out = render(str(trace), "-o", str(tmp_path / "ch.html"))
    assert code == 0, out
    size = (tmp_path / "ch.html").stat().st_size
    doc = embedded(tmp_path / "ch.html")["replay"]
    assert doc["T"] == 400 and len(doc["states"]["keys"][0]["robots"]) == 48
    assert size < 5_000_000, size
    assert size < trace.stat().st_size / 4  # the delta encoding is what keeps it small


# ----------------------------------------------------------------------------------------- bad input
@pytest.mark.parametrize("content, code, needle", [
    (None, 2, "file not found"),
    ('{"type": "header"\n', 1, "AG003"),
    ('{"type":"tick","t":0}\n', 1, "AG601"),
    ("", 1, "AG606"),
    ('{"type":"header","instance":{"id":"x"},"state":{"t":0,"robots":{}}}\n', 1, "/instance"),
])
def test_bad_trace_gets_a_located_message_and_exit_code(tmp_path: Path, content, code, needle):
    path = tmp_path / "t.jsonl"
    if content is not None:
        path.write_text(content, encoding="utf-8")
    got, out = render(str(path), "-o", str(tmp_path / "o.html"))
    assert got == code, out
    assert needle in out and "Traceback" not in out
    assert not (tmp_path / "o.html").exists()


def test_usage_errors(tmp_path: Path):
    trace = write_trace(record_reference("flow-easy", 3), tmp_path / "t.jsonl")
    assert render()[0] == 2
    assert render(str(trace), "--diff", str(trace))[0] == 2
    code, out = render("--diff", str(trace))  # a trace is not a report
    assert code == 1 and "not a conformance report" in out
    code, out = render("--impl", "reference")
    assert code == 2 and "--scenario" in out


def test_truncated_trace_still_renders_with_a_warning(tmp_path: Path):
    records = record_reference("flow-easy", 10)
    path = write_trace(records[:6], tmp_path / "t.jsonl")  # header + 5 ticks, no footer
    code, out = render(str(path), "-o", str(tmp_path / "t.html"))
    assert code == 0 and "AG604" in out
    assert embedded(tmp_path / "t.html")["replay"]["T"] == 5


# ----------------------------------------------------------------------------------------- subprocess adapter
def test_trace_recorded_from_a_subprocess_simulator(tmp_path: Path):
    spec = shlex.join([sys.executable, str(SIM)])
    code, out = render("--impl", spec, "--scenario", "coalition-easy", "--horizon", "30", "--trace",
                       str(tmp_path / "sub.jsonl"), "-o", str(tmp_path / "sub.html"))
    assert code == 0, out
    sub = [json.loads(line) for line in (tmp_path / "sub.jsonl").read_text().splitlines()]
    assert sub[0]["implementation"]["name"] == "agspec-mutant-sim"
    assert [canon(s) for s in states_of(sub)] == [canon(s) for s in states_of(record_reference("coalition-easy", 30))]
    from agspec.trace.read import read_trace

    assert read_trace(tmp_path / "sub.jsonl")[1] == []
    assert embedded(tmp_path / "sub.html")["replay"]["observations"] is not None


def test_a_crashing_simulator_exits_3_and_still_shows_its_ticks(tmp_path: Path):
    spec = shlex.join([sys.executable, str(SIM), "--mutant", "crash"])
    code, out = render("--impl", spec, "--scenario", "flow-easy", "--horizon", "10", "--timeout", "2",
                       "-o", str(tmp_path / "c.html"))
    assert code == 3, out
    assert "crash" in out
    assert embedded(tmp_path / "c.html")["replay"]["T"] == 3  # the mutant dies on the step of epoch 3


# ----------------------------------------------------------------------------------------- --diff
def _failure(report: Path) -> dict:
    records = [json.loads(line) for line in report.read_text(encoding="utf-8").splitlines() if line.strip()]
    return next(r["failure"] for r in records if r.get("type") == "case")


@pytest.mark.parametrize("mode", [[], ["--replay"]])
def test_diff_of_a_real_failing_report(failing_report: Path, tmp_path: Path, monkeypatch, mode):
    monkeypatch.chdir(failing_report.parent)  # the report names its reproducer relative to conform's cwd
    code, out = render("--diff", str(failing_report), *mode, "-o", str(tmp_path / "d.html"))
    assert code == 0, out
    failure = _failure(failing_report)
    data = embedded(tmp_path / "d.html")
    focus = failure["tick"] + 1
    assert data["mode"] == "diff" and data["focus"] == focus
    assert failure["path"] in data["differences"][str(focus)]
    robot = failure["pointer"].split("/")[2]
    expected = decode_states(data["expected"])[focus]
    actual = decode_states(data["actual"])[focus]
    assert expected["robots"][robot]["holding"] == failure["expected"]
    assert actual["robots"][robot]["holding"] == failure["actual"]
    if mode:  # the mutant's own states: every differing pointer the report names is found again
        for ptr in failure.get("more") or []:
            assert "/state" + ptr in data["differences"][str(focus)]


def test_diff_of_a_report_without_divergence(tmp_path: Path):
    report = tmp_path / "r.jsonl"
    report.write_text(json.dumps({"type": "header", "format": "agspec-conform-report/1"}) + "\n"
                      + json.dumps({"type": "case", "id": "c-1", "outcome": "pass"}) + "\n", encoding="utf-8")
    code, out = render("--diff", str(report), "-o", str(tmp_path / "d.html"))
    assert code == 1 and "no divergence" in out


def test_docs_example_is_small_and_current():
    page = ROOT / "docs" / "examples" / "replay-coalition-medium.html"
    assert page.stat().st_size < 1_500_000
    doc = embedded(page)["replay"]
    assert doc["layout"]["scenario"] == "coalition-medium" and doc["T"] == 120 and doc["observations"]


# ----------------------------------------------------------------------------------------- browser
def _target_tick(states: list[dict]) -> int | None:
    return next((t for t, s in enumerate(states) if coalitions(s)), None)


@pytest.mark.parametrize("scenario", OFFICIAL)
def test_browser_shows_the_active_coalition_and_counters(browser, scenario: str, tmp_path: Path):
    ticks = 60 if scenario.startswith("flow") else 120
    records = record_reference(scenario, ticks)
    states = states_of(records)
    trace = write_trace(records, tmp_path / f"{scenario}.jsonl")
    code, out = render(str(trace), "-o", str(tmp_path / f"{scenario}.html"))
    assert code == 0, out
    t = _target_tick(states)
    if scenario.startswith(("coalition", "concurrency")):
        assert t is not None, f"no coalition of >= 2 robots in {ticks} ticks of {scenario}"
    else:
        t = ticks // 2  # flow recipes have no coalitions: the counters only
    page = Page(browser, tmp_path / f"{scenario}.html")
    try:
        page.scrub(t + 1)
        page.page.click("#step-back")  # the buttons, not only the scrubber
        assert page.text("#tick") == str(t)
        page.page.screenshot(path=str(tmp_path / f"{scenario}-{t}.png"))
        st = states[t]
        assert page.text("#delivered") == str(st["delivered"])
        assert page.text("#wip") == str(st["wip"])
        shown: dict[str, set[str]] = {}
        for robot, coalition, role in page.page.eval_on_selector_all(
                "[data-robot]", "els => els.map(e => [e.dataset.robot, e.dataset.coalition, e.dataset.role])"):
            if coalition:
                shown.setdefault(coalition, set()).add(robot)
                act = next(a for a in st["activities"] if a["id"] == coalition)
                assert role == act["roles"][robot], (robot, role)
        truth = {a["id"]: set(a["members"]) for a in st["activities"] if a["kind"] == "operation"}
        assert shown == truth
        assert all(shown[a["id"]] == set(a["members"]) for a in coalitions(st))
        assert page.text("#coalitions") == str(len(coalitions(st)))
        assert not page.page.is_visible("#counters-caption")  # one side only: nothing to tell apart
        kstar = embedded(tmp_path / f"{scenario}.html")["replay"]["kstar"]
        assert page.text("#kstar-label") == "K*" and page.text("#kstar") == str(kstar[t])
        # the page rebuilds the same state as the trace (JS decoder = Python decoder); JS numbers come
        # back without their int/float distinction, so compare values, not texts
        assert page.page.evaluate(f"window.agspecViewer.stateAt({t})") == st
        assert page.errors == []
    finally:
        page.close()


def test_browser_scrub_to_the_end_and_back(browser, tmp_path: Path):
    records = record_reference("coalition-medium", 120, observations=True)
    states = states_of(records)
    trace = write_trace(records, tmp_path / "cm.jsonl")
    assert render(str(trace), "--keyframe", "10", "-o", str(tmp_path / "cm.html"))[0] == 0
    page = Page(browser, tmp_path / "cm.html")
    try:
        page.scrub(120)
        assert page.text("#tick") == "120"
        assert page.text("#delivered") == str(records[-1]["metrics"]["delivered"]) == str(states[-1]["delivered"])
        page.page.click("#step-fwd")  # clamped at the end
        assert page.text("#tick") == "120"
        page.scrub(0)
        assert page.text("#tick") == "0" and page.text("#delivered") == str(states[0]["delivered"])
        for t in (1, 9, 10, 11, 57, 119):  # around keyframes, forwards then backwards
            page.scrub(t)
            assert page.page.evaluate(f"window.agspecViewer.stateAt({t})") == states[t]
        page.scrub(30)
        page.page.click('[data-robot="2,0"]')  # the side panel: observation and mask of the robot
        assert page.text("#sel-name") == "2,0"
        legal = sum(records[31]["observations"]["2,0"]["mask"])
        assert page.page.locator("#robot-panel .mask span").count() == 114
        assert page.page.locator("#robot-panel .mask span.on").count() == legal
        page.page.click("#play")
        page.page.wait_for_function("window.agspecViewer.tick() > 31")
        page.page.click("#play")
        assert page.text("#play") == "Play"
        assert page.errors == []
    finally:
        page.close()


def test_browser_diff_page_highlights_the_differing_robots(browser, failing_report: Path, tmp_path: Path,
                                                           monkeypatch):
    monkeypatch.chdir(failing_report.parent)
    assert render("--diff", str(failing_report), "--replay", "-o", str(tmp_path / "d.html"))[0] == 0
    failure = _failure(failing_report)
    robots = {p.split("/")[2] for p in [failure["pointer"]] + list(failure.get("more") or [])}
    page = Page(browser, tmp_path / "d.html")
    try:
        assert page.text("#tick") == str(failure["tick"] + 1)
        for side in ("expected", "actual"):
            flagged = set(page.page.eval_on_selector_all(f"#{side} .robot.diff", "els => els.map(e => e.dataset.robot)"))
            assert flagged == robots, (side, flagged)
        assert failure["path"] in page.text("#diff-panel")
        # the header's counters say whose they are: observed, with the expected value under each
        caption = page.text("#counters-caption")
        assert "observed" in caption and "expected" in caption
        data, focus = embedded(tmp_path / "d.html"), failure["tick"] + 1
        expected, observed = decode_states(data["expected"])[focus], decode_states(data["actual"])[focus]
        for counter, field in (("released", "released"), ("delivered", "delivered"), ("wip", "wip"), ("lost", "lost_releases")):
            assert page.text(f"#{counter}") == str(observed[field])
            assert page.text(f"#{counter}-exp") == f"exp {expected[field]}"
        page.page.screenshot(path=str(tmp_path / "diff.png"))
        page.page.click("#step-back")
        assert page.page.locator("#actual .robot.diff").count() == 0  # the states agree one tick earlier
        assert page.errors == []
    finally:
        page.close()
