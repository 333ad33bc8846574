"""Garbled DSL never raises: every input ends in an IR or in located Diagnostics (F-DIAGNOSTICS).

Catalogue files are mutated with random insertions, deletions and replacements of characters
and tokens; loading, building, schema and semantic checks and rendering must all succeed.
"""

from __future__ import annotations

import re

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from agspec.load import Resolver, check_document, load_dsl
from agspec.resources import catalogue_dir

TEXTS = [p.read_text(encoding="utf-8") for p in sorted(catalogue_dir().glob("*/*.ag"))]
TOKENS = ["{", "}", "(", ")", ",", "->", "..", "=", "|", "#", '"', "\n", " ", "x", "5", "2.5", "-1", "0",
          "operation", "recipe", "scenario", "profile", "team", "duration", "inputs", "use", "variant",
          "grid", "roles", "xor", "on", "\\", "@", "×", "é", "\t", "\x00", "\ufeff", "A->B", "1..4"]
CODE = re.compile(r"^AG\d{3}$")


@st.composite
def garbled(draw) -> str:
    text = draw(st.sampled_from(TEXTS))
    for _ in range(draw(st.integers(1, 6))):
        i = draw(st.integers(0, len(text)))
        op = draw(st.sampled_from(["insert-text", "insert-token", "delete", "replace", "duplicate-line"]))
        if op == "insert-text":
            text = text[:i] + draw(st.text(max_size=4)) + text[i:]
        elif op == "insert-token":
            text = text[:i] + draw(st.sampled_from(TOKENS)) + text[i:]
        elif op == "delete":
            j = draw(st.integers(i, min(len(text), i + 25)))
            text = text[:i] + text[j:]
        elif op == "replace":
            j = draw(st.integers(i, min(len(text), i + 8)))
            text = text[:i] + draw(st.sampled_from(TOKENS)) + text[j:]
        else:
            lines = text.split("\n")
            k = draw(st.integers(0, len(lines) - 1))
            text = "\n".join(lines[: k + 1] + [lines[k]] + lines[k + 1:])
    return text


@settings(max_examples=400, deadline=None, suppress_health_check=list(HealthCheck))
@given(garbled())
def test_garbled_dsl_yields_only_diagnostics(text: str):
    doc = load_dsl(text, "garbled.ag")
    diags = check_document(doc, Resolver())
    n_lines = text.count("\n") + 1
    for d in diags:
        assert CODE.match(d.code), d
        assert d.code != "AG000", d  # an internal error would be a bug in agspec
        assert d.line is None or 1 <= d.line <= n_lines, d
        rendered = d.render(text)
        assert "__ANON" not in rendered
    if not any(d.severity == "error" for d in diags):
        assert doc.ir is not None


@settings(max_examples=150, deadline=None, suppress_health_check=list(HealthCheck))
@given(st.text(max_size=200))
def test_arbitrary_text_yields_only_diagnostics(text: str):
    doc = load_dsl(text, "random.ag")
    for d in check_document(doc, Resolver()):
        assert CODE.match(d.code) and d.code != "AG000", d
        d.render(text)
