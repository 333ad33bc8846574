"""Viewer: the page opens at the tick named in its URL (`#t=120`) and keeps the URL at the shown tick;
item labels never overlap, even where the end-effectors of a coalition converge on one site
(headless Chromium, skipped with a reason like tests/test_render.py when it is missing)."""

from __future__ import annotations

from pathlib import Path

import pytest

from test_render import Page, browser, record_reference, render, states_of, write_trace  # noqa: F401 - fixture

OVERLAPS = """() => {
  const boxes = [...document.querySelectorAll('#replay .item rect')].map((n) => n.getBoundingClientRect());
  let hits = 0;
  for (let i = 0; i < boxes.length; i++) for (let j = i + 1; j < boxes.length; j++) {
    const a = boxes[i], b = boxes[j];
    if (a.left < b.right - 0.5 && b.left < a.right - 0.5 && a.top < b.bottom - 0.5 && b.top < a.bottom - 0.5) hits++;
  }
  return [boxes.length, hits];
}"""


def _page(tmp_path: Path, scenario: str, ticks: int) -> tuple[Path, list[dict]]:
    records = record_reference(scenario, ticks)
    trace = write_trace(records, tmp_path / f"{scenario}.jsonl")
    out = tmp_path / f"{scenario}.html"
    assert render(str(trace), "-o", str(out))[0] == 0
    return out, states_of(records)


def test_the_page_opens_at_the_tick_in_the_url_and_follows_it(browser, tmp_path):  # noqa: F811
    out, states = _page(tmp_path, "coalition-medium", 60)
    page = Page.__new__(Page)
    page.errors = []
    page.page = browser.new_page(viewport={"width": 1500, "height": 1000})
    page.page.goto(out.resolve().as_uri() + "#t=42")
    page.page.wait_for_function("window.agspecViewer !== undefined")
    try:
        assert page.text("#tick") == "42"
        assert page.page.evaluate("window.agspecViewer.stateAt(42)") == states[42]
        page.scrub(17)
        assert page.page.evaluate("location.hash") == "#t=17"
        page.page.evaluate("location.hash = '#t=5'")
        page.page.wait_for_function("document.getElementById('tick').textContent.trim() === '5'")
    finally:
        page.close()


def test_item_labels_do_not_overlap_on_a_dense_grid(browser, tmp_path):  # noqa: F811
    out, states = _page(tmp_path, "coalition-medium", 40)  # labels collided at t=18 before
    page = Page(browser, out)
    page.page.add_style_tag(content="* { transition: none !important; }")
    try:
        crowded = 0
        for t in range(0, 41):
            page.scrub(t)
            count, hits = page.page.evaluate(OVERLAPS)
            assert hits == 0, f"{hits} overlapping item labels at t={t}"
            crowded += count >= 2
        assert crowded, "no tick with two items: the check exercised nothing"
    finally:
        page.close()


LABELS_VS_CELLS = """() => {
  const cells = [...document.querySelectorAll('#replay .robot .cell')].map((n) => n.getBoundingClientRect());
  const items = [...document.querySelectorAll('#replay .item')];
  let covering = 0, cut = 0;
  for (const node of items) {
    const a = node.querySelector('rect').getBoundingClientRect();
    if (cells.some((b) => a.left < b.right - 0.5 && b.left < a.right - 0.5 && a.top < b.bottom - 0.5 && b.top < a.bottom - 0.5)) covering++;
    const text = node.querySelector('text');
    if (text.textContent !== node.getAttribute('data-item') || text.getBBox().width > a.width) cut++;
  }
  return [items.length, covering, cut];
}"""


@pytest.mark.parametrize("scenario", ["coalition-medium", "flow-hard"])  # flow-hard: ids like 12:P3 by t=40
def test_item_labels_cover_no_robot_and_show_the_whole_item(browser, tmp_path, scenario):  # noqa: F811
    out, states = _page(tmp_path, scenario, 40)
    page = Page(browser, out)
    page.page.add_style_tag(content="* { transition: none !important; }")
    try:
        seen = 0
        for t in range(0, 41, 2):
            page.scrub(t)
            count, covering, cut = page.page.evaluate(LABELS_VS_CELLS)
            assert covering == 0, f"{covering} item labels cover a robot at t={t}"
            assert cut == 0, f"{cut} item labels cut at t={t}"
            seen += count
        assert seen, "no item was drawn: the check exercised nothing"
    finally:
        page.close()


def test_phase_labels_count_ticks_of_the_phase(browser, tmp_path):  # noqa: F811, G-DURATION
    out, states = _page(tmp_path, "coalition-medium", 40)
    page = Page(browser, out)
    try:
        checked = 0
        for t in range(0, 41):
            for act in states[t]["activities"]:
                p = t - act["start"]
                A, P = act["approach"], act["process"]
                phase, k, n = (("approach", p, A) if p <= A and not (A == 0 and p == 0) else
                               ("process", p - A, P) if p <= A + P else ("retreat", p - A - P, act["retreat"]))
                if A == 0 and p == 0:
                    phase, k, n = ("process", 0, P) if P > 0 else ("retreat", 0, act["retreat"])
                page.scrub(t)
                robot = act["members"][0]
                text = page.page.evaluate(f"document.querySelector('#replay [data-robot=\"{robot}\"] .phase').firstChild.textContent")
                assert text == f"{phase} {k}/{n}", (t, act["id"], text)
                checked += 1
                break
        assert checked > 10
    finally:
        page.close()
