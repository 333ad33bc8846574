"""The quick and the extended tier (tests/tiers.py): the list names real tests, and a sampled matrix
keeps every row and every column in the quick tier."""

from __future__ import annotations

from pathlib import Path

from hypothesis import given
from hypothesis import strategies as st

import tiers

ROOT = Path(__file__).resolve().parents[1]


def test_every_listed_test_exists():
    problems = [f"tests/extended.txt:{e.line}: {why}" for e in tiers.entries()
                if (why := tiers.missing(e, ROOT)) is not None]
    assert not problems, "\n".join(problems)


def test_no_case_of_a_sampled_matrix_is_listed():
    listed = [e.test for e in tiers.entries() if e.test.split("[", 1)[0] in tiers.SAMPLED]
    assert not listed, f"the cover decides these cases' tier: {listed}"


def test_the_sampled_matrices_are_known():
    users = {f"tests/{p.name}" for p in (ROOT / "tests").glob("test_*.py")
             if p.name != "test_tiers.py" and "sample_params(" in p.read_text(encoding="utf-8")}
    assert users == {s.split("::", 1)[0] for s in tiers.SAMPLED}


def test_a_renamed_test_is_reported(tmp_path):
    listed = tmp_path / "extended.txt"
    listed.write_text("# a comment\n  3.5  tests/test_tiers.py::test_no_such_test\n"
                      "  2.0  tests/test_tiers.py::test_every_listed_test_exists\n", encoding="utf-8")
    found = [tiers.missing(e, ROOT) for e in tiers.entries(listed)]
    assert found == ["tests/test_tiers.py has no test test_no_such_test", None]


def test_a_function_takes_its_cases():
    listed = frozenset({"tests/test_a.py::test_f", "tests/test_a.py::test_g[2]"})
    assert tiers.extended("tests/test_a.py::test_f[x-1]", listed)
    assert tiers.extended("tests/test_a.py::test_g[2]", listed)
    assert not tiers.extended("tests/test_a.py::test_g[3]", listed)
    assert not tiers.extended("tests/test_a.py::test_ff", listed)


@given(st.lists(st.tuples(st.integers(0, 6), st.integers(0, 9)), min_size=1, max_size=60, unique=True))
def test_the_covering_sample_keeps_every_row_and_column(table):
    keep = tiers.covering(table)
    assert {table[i][0] for i in keep} == {r for r, _ in table}
    assert {table[i][1] for i in keep} == {c for _, c in table}
    assert len(keep) <= len({r for r, _ in table}) + len({c for _, c in table})
