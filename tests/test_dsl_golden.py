"""Golden diagnostics for malformed DSL and JSON inputs (F-DIAGNOSTICS).

Each ``tests/golden/dsl/*.ag`` file states what it must produce in header lines
``# expect: AGxxx line:col``; the test asserts exactly that list (codes and positions, in
order).  JSON inputs (no comments) list theirs in ``JSON_EXPECT``.  The rendered output
(message, source line, caret, hint) is compared with ``<name>.out`` beside the input.

Regenerate the ``.out`` files after an intended change of wording, and review the diff:

    AGSPEC_REGEN_GOLDEN=1 pytest tests/test_dsl_golden.py
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import pytest

from agspec.load import Resolver, check_document, load_document

GOLDEN = Path(__file__).parent / "golden" / "dsl"
INPUTS = sorted(p for p in GOLDEN.iterdir() if p.suffix in (".ag", ".json"))
EXPECT = re.compile(r"^# expect: (AG\d{3}) (\d+):(\d+)$", re.M)
JSON_EXPECT = {
    "json-malformed.json": [("AG003", 5, 1)],
    "json-unknown-field.json": [("AG204", 21, 24)],
    "json-unknown-kind.json": [("AG004", 1, 31)],
}


def _diagnose(path: Path):
    # relative file names keep the golden output independent of the checkout location
    cwd = os.getcwd()
    os.chdir(GOLDEN)
    try:
        doc = load_document(path.name)
        diags = check_document(doc, Resolver(), semantic=False)
    finally:
        os.chdir(cwd)
    return doc, diags


def _expected(path: Path) -> list[tuple[str, int, int]]:
    if path.suffix == ".json":
        return JSON_EXPECT[path.name]
    return [(c, int(line), int(col)) for c, line, col in EXPECT.findall(path.read_text(encoding="utf-8"))]


def test_at_least_15_distinct_malformed_inputs():
    codes = {code for p in INPUTS for code, _l, _c in _expected(p)}
    assert len(INPUTS) >= 15 and len(codes) >= 15, (len(INPUTS), sorted(codes))


@pytest.mark.parametrize("path", INPUTS, ids=[p.name for p in INPUTS])
def test_codes_and_positions_are_exact(path: Path):
    expected = _expected(path)
    assert expected, f"{path.name} declares no expectation"
    _doc, diags = _diagnose(path)
    assert [(d.code, d.line, d.col) for d in diags] == expected


@pytest.mark.parametrize("path", INPUTS, ids=[p.name for p in INPUTS])
def test_rendered_output_matches_golden(path: Path):
    doc, diags = _diagnose(path)
    rendered = "\n".join(d.render(doc.text) for d in diags) + "\n"
    golden = path.with_suffix(path.suffix + ".out")
    if os.environ.get("AGSPEC_REGEN_GOLDEN"):
        golden.write_text(rendered, encoding="utf-8")
    assert golden.exists(), f"missing {golden.name}; run with AGSPEC_REGEN_GOLDEN=1"
    assert rendered == golden.read_text(encoding="utf-8")
    assert "__ANON" not in rendered and "Traceback" not in rendered
