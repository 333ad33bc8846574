"""The replay page's scene stays legible at every tick of dense traces: no label covers another.

The generator: dense traces on every topology (moore: coalition-medium and concurrency-hard;
von_neumann: coalition-medium on a von Neumann grid; line: flow-hard on line grids; D-TOPOLOGY,
RES-TOPOLOGY-LINE) plus a `--diff` page (two panes, rings of differing robots), every tick of each,
every pane. What counts, in the page's own pixels (getBoundingClientRect, transitions off):

- a *label* is a visible `<text>` of the scene with text of its own (robot ids, roles, phases,
  blocked causes, support and operation labels, shelf and output texts), or an item tag (the tag's
  rectangle stands for the tag and its text);
- a *ring* is a drawn outline that marks a robot or a pending support: the incoming-handoff circle,
  the blocked and differs outlines around a cell, a single-member support circle; its painted band
  is its geometry ± half its stroke width (rounded corners taken as square, the stricter reading);
- two labels *overlap* when their boxes share more than EPS pixels in both axes; a label *crosses*
  a ring when its box meets the ring's band by more than EPS (a label wholly inside or wholly
  outside the band is fine). Lines (arms, leaders, activity and support lines) and the selected
  robot's reach disk are not rings.

No label may overlap another label or cross a ring. The figures (labels x ticks x traces) are
printed with `-s`.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from replay_pages import (Page, browser, failing_report, record_reference, render,  # noqa: F401 (fixtures)
                          write_trace)

ROOT = Path(__file__).resolve().parents[1]
EPS = 0.5

# (name, official scenario, topology it is rewritten to or None, ticks)
DENSE = [
    ("coalition-medium", "coalition-medium", None, 400),
    ("concurrency-hard", "concurrency-hard", None, 250),
    ("coalition-medium-von_neumann", "coalition-medium", "von_neumann", 400),
    ("concurrency-easy-von_neumann", "concurrency-easy", "von_neumann", 250),
    ("flow-hard-line", "flow-hard", "line", 400),
    ("flow-medium-line", "flow-medium", "line", 250),
]

COLLECT = """([t0, t1]) => {
  const visible = (n) => { for (let e = n; e && e.nodeType === 1; e = e.parentNode) {
      const cs = getComputedStyle(e); if (cs.display === "none" || cs.visibility === "hidden") return false; }
    return true; };
  const box = (n) => { const r = n.getBoundingClientRect(); return [r.left, r.top, r.right, r.bottom]; };
  const name = (n) => { const r = n.closest("[data-robot]");
    return (n.getAttribute("class") || n.parentNode.getAttribute("class") || n.tagName) + (r ? "@" + r.dataset.robot : ""); };
  const RINGS = ".robot circle.incoming, .robot.blocked .blocked-ring, .robot.diff .diff-ring, circle.proposal";
  const out = [];
  for (let t = t0; t <= t1; t++) {
    window.agspecViewer.go(t);
    const panes = [];
    document.querySelectorAll("#stage svg").forEach((svg) => {
      const k = svg.getScreenCTM().a, labels = [], rings = [];
      svg.querySelectorAll("text").forEach((n) => {
        if (n.closest(".item")) return;
        const own = Array.from(n.childNodes).filter((c) => c.nodeType === 3).map((c) => c.data).join("").trim();
        if (own && visible(n)) labels.push([name(n) + " '" + own + "'", box(n)]);
      });
      svg.querySelectorAll(".item").forEach((n) => {
        if (visible(n)) labels.push(["item " + n.dataset.item + "@" + n.dataset.holder, box(n.querySelector("rect"))]);
      });
      svg.querySelectorAll(RINGS).forEach((n) => {
        if (visible(n)) rings.push([name(n), n.tagName, box(n), parseFloat(getComputedStyle(n).strokeWidth) * k]);
      });
      panes.push([labels, rings]);
    });
    out.push(panes);
  }
  return out;
}"""


def overlap(a, b) -> bool:
    return min(a[2], b[2]) - max(a[0], b[0]) > EPS and min(a[3], b[3]) - max(a[1], b[1]) > EPS


def crosses(label, shape: str, ring, width: float) -> bool:
    """The label's box meets the ring's painted band (geometry ± width/2) by more than EPS."""
    h = width / 2
    if shape == "circle":
        cx, cy, r = (ring[0] + ring[2]) / 2, (ring[1] + ring[3]) / 2, (ring[2] - ring[0]) / 2
        nx, ny = min(max(cx, label[0]), label[2]), min(max(cy, label[1]), label[3])
        near = math.hypot(nx - cx, ny - cy)
        far = max(math.hypot(x - cx, y - cy) for x in (label[0], label[2]) for y in (label[1], label[3]))
        return near < r + h - EPS and far > r - h + EPS
    outer = (ring[0] - h, ring[1] - h, ring[2] + h, ring[3] + h)
    inner = (ring[0] + h + EPS, ring[1] + h + EPS, ring[2] - h - EPS, ring[3] - h - EPS)
    inside = label[0] >= inner[0] and label[1] >= inner[1] and label[2] <= inner[2] and label[3] <= inner[3]
    return overlap(label, outer) and not inside


def faults(labels, rings) -> list[str]:
    out = []
    for i, (na, a) in enumerate(labels):
        out += [f"{na} overlaps {nb}" for nb, b in labels[i + 1:] if overlap(a, b)]
        out += [f"{na} crosses {nr}" for nr, shape, r, w in rings if crosses(a, shape, r, w)]
    return out


def variant(scenario: str, topology: str | None, where: Path) -> str:
    """An official scenario on another grid topology (its includes resolved from the catalogue)."""
    if topology is None:
        return scenario
    text = (ROOT / "catalogue" / "scenarios" / f"{scenario}.ag").read_text(encoding="utf-8")
    text = text.replace('use "../', f'use "{ROOT / "catalogue"}/').replace("moore radius 1", f"{topology} radius 1")
    assert f"{topology} radius 1" in text
    path = where / f"{scenario}-{topology}.ag"
    path.write_text(text.replace(f"scenario {scenario} ", f"scenario {scenario}-{topology} "), encoding="utf-8")
    return str(path)


def check_page(browser, page_path: Path, totals: dict) -> list[str]:
    page = Page(browser, page_path, reduced_motion=True)
    found = []
    try:
        T = page.page.evaluate("window.agspecViewer.T()")
        for t0 in range(0, T + 1, 50):
            for dt, panes in enumerate(page.page.evaluate(COLLECT, [t0, min(T, t0 + 49)])):
                for p, (labels, rings) in enumerate(panes):
                    totals["labels"] += len(labels)
                    totals["rings"] += len(rings)
                    found += [f"{page_path.name} t={t0 + dt} pane {p}: {f}" for f in faults(labels, rings)]
            totals["ticks"] += min(T, t0 + 49) - t0 + 1
        assert page.errors == []
    finally:
        page.close()
    totals["traces"] += 1
    return found


def test_no_label_overlaps_at_any_tick_of_dense_traces(browser, failing_report: Path, tmp_path: Path, monkeypatch):
    totals = {"labels": 0, "rings": 0, "ticks": 0, "traces": 0}
    found: list[str] = []
    for name, scenario, topology, ticks in DENSE:
        records = record_reference(variant(scenario, topology, tmp_path), ticks)
        trace = write_trace(records, tmp_path / f"{name}.jsonl")
        code, out = render(str(trace), "-o", str(tmp_path / f"{name}.html"))
        assert code == 0, out
        found += check_page(browser, tmp_path / f"{name}.html", totals)
    monkeypatch.chdir(failing_report.parent)  # the report names its reproducer relative to conform's cwd
    assert render("--diff", str(failing_report), "--replay", "-o", str(tmp_path / "diff.html"))[0] == 0
    found += check_page(browser, tmp_path / "diff.html", totals)
    print(f"\nlayout: {totals['labels']} labels and {totals['rings']} rings over {totals['ticks']} ticks of "
          f"{totals['traces']} pages: {len(found)} overlaps")
    assert not found, f"{len(found)} overlaps, first ones:\n" + "\n".join(found[:25])


@pytest.mark.parametrize("a, b, hit", [
    ((0, 0, 10, 10), (10, 0, 20, 10), False),  # touching edges
    ((0, 0, 10, 10), (9, 9, 20, 20), True),
    ((0, 0, 10, 10), (2, 2, 8, 8), True),
])
def test_overlap_definition(a, b, hit):
    assert overlap(a, b) is hit


@pytest.mark.parametrize("label, hit", [
    ((-3, -3, 3, 3), False),      # inside the circle
    ((-12, -2, -8, 2), True),     # on its band
    ((20, 20, 30, 30), False),    # outside
    ((-20, -1, 20, 1), True),     # across it
])
def test_ring_definition(label, hit):
    assert crosses(label, "circle", (-10, -10, 10, 10), 2) is hit
    assert crosses(label, "rect", (-10, -10, 10, 10), 2) is hit
