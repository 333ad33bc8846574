"""Guards that keep the spec and the code in one piece (checks in tests/spec_guard.py).

Each guard runs on the repository and, to prove it can fail, on a copy with a planted drift:
an undefined ID cited in code, a rule no code cites, a reordered tick step, a step that names other
rules, a docstring that names an issue or a missing file.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

import spec_guard as G

ROOT = Path(__file__).resolve().parents[1]
# planted IDs, spelled apart so that the guard does not see this file citing them
TELEPORT, HOVER = "R-" + "TELEPORT", "R-" + "HOVER"

# M- IDs no test cites yet, each with the reason; the guard fails on any other uncited ID, and on
# an entry here that has become cited (so the list only shrinks).
UNTESTED = {
    "M-GEOMETRY-REJECTIONS": "no official instance rejects a realization; needs a purpose-built instance",
    "M-SWITCHES": "candidate switches are zero under every reference controller",
    "M-REALIZED-CONCURRENCY": "K_t is sampled after starts inside the tick; no trace record exposes it",
}


@pytest.fixture
def copy_root(tmp_path: Path) -> Path:
    """The parts of the repository the guards read, copied so that a test can plant a drift."""
    for part in ("spec", "agspec", "tests", "conformance/cases"):
        shutil.copytree(ROOT / part, tmp_path / part, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    return tmp_path


def _edit(path: Path, old: str, new: str) -> None:
    text = path.read_text(encoding="utf-8")
    assert old in text, old
    path.write_text(text.replace(old, new, 1), encoding="utf-8")


# --------------------------------------------------------------------------- IDs: spec <-> code and tests


def test_every_cited_id_is_defined_in_the_spec():
    assert G.undefined_citations(ROOT) == []


def test_planted_undefined_citation_is_reported(copy_root):
    _edit(copy_root / "agspec" / "interp" / "rules.py", '"""', f'"""{TELEPORT}: robots jump. ')
    assert any(line.startswith(f"{TELEPORT} (agspec/interp/rules.py") for line in G.undefined_citations(copy_root))


def test_every_id_the_docs_cite_is_defined_in_the_spec():
    """A page that paraphrases the spec cites the ID it paraphrases, e.g. "(S-MIX)"; that ID exists."""
    assert G.undefined_doc_citations(ROOT) == []


def test_planted_undefined_doc_citation_is_reported(tmp_path: Path):
    shutil.copytree(ROOT / "spec", tmp_path / "spec")
    shutil.copytree(ROOT / "docs", tmp_path / "docs")
    _edit(tmp_path / "docs" / "write-a-scenario.md", "(S-MIX)", "(S-" + "MIXTURE)")
    assert any(line.startswith("S-" + "MIXTURE (docs/write-a-scenario.md:") for line in G.undefined_doc_citations(tmp_path))


def test_every_rule_invariant_and_metric_is_implemented_and_tested():
    missing = [m for m in G.uncited(ROOT) if not (m.endswith("no test cites it") and m.split(":")[0] in UNTESTED)]
    assert missing == []
    cited_now = [ident for ident in UNTESTED if f"{ident}: no test cites it" not in G.uncited(ROOT)]
    assert cited_now == [], "now tested: remove from UNTESTED"


def test_planted_uncited_rule_is_reported(copy_root):
    spec = copy_root / "spec" / "05-transition.md"
    _edit(spec, "### R-READY — readiness", f"### {HOVER} — hovering\n\nRobots may hover.\n\n### R-READY — readiness")
    assert {f"{HOVER}: no code cites it", f"{HOVER}: no test cites it"} <= set(G.uncited(copy_root))


# --------------------------------------------------------------------------- R-TICK-ORDER


def test_tick_order_in_the_spec_is_the_order_the_interpreter_runs():
    assert [n for n, _ in G.spec_tick_order(ROOT)] == list(range(1, 16))
    assert G.tick_order_drift(ROOT) == []


def test_planted_reordered_tick_step_is_reported(copy_root):
    tick = copy_root / "agspec" / "interp" / "tick.py"
    text = tick.read_text(encoding="utf-8")
    picks = "        # step 3: R-PICK\n"
    handoffs = "        # step 4: R-HANDOFF\n"
    assert picks in text and handoffs in text
    tick.write_text(text.replace(picks, "@@").replace(handoffs, picks).replace("@@", handoffs), encoding="utf-8")
    assert any(d.startswith("step numbers") for d in G.tick_order_drift(copy_root))


def test_planted_step_naming_another_rule_is_reported(copy_root):
    _edit(copy_root / "spec" / "05-transition.md", "6. **Deliveries** (R-DELIVERY)", "6. **Deliveries** (R-PICK)")
    assert G.tick_order_drift(copy_root) == ["step 6: spec names ['R-PICK'], tick.py names ['R-DELIVERY']"]


# --------------------------------------------------------------------------- docstrings and comments


def test_no_docstring_names_an_issue_or_a_missing_file():
    assert G.stale_references(ROOT) == []


def test_planted_issue_number_and_missing_file_are_reported(copy_root):
    _edit(copy_root / "agspec" / "conform" / "lockstep" / "driver.py", '"""The one lockstep driver',
          '"""(issue 12; see docs/lockstep.md) The one lockstep driver')
    found = G.stale_references(copy_root)
    assert any("agspec/conform/lockstep/driver.py:1: names an issue" in f for f in found)
    assert any("names a missing file docs/lockstep.md" in f for f in found)
