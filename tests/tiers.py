"""The two tiers of the test suite (README, "Tests").

The quick tier is what the README's `pytest -q` runs, within minutes on a 2-core machine: every test
that took less than the threshold on the reference machine, and a covering sample of each matrix the
generators span (every row and every column at least once).  The extended tier (`pytest -m extended`;
`.ci/run` runs it right after the quick tier, so nothing lands untested) is the rest: the matrices'
other cases, the documentation's pages run end to end, the mutation score, the long generator runs.

Which tests are extended is data, not taste: ``tests/extended.txt`` lists them with the seconds each
took, and ``benchmarks/suite_time.py`` measures the suite and writes that file again from a run's
durations (a test over the threshold moves out of the quick tier).
"""

from __future__ import annotations

import ast
from dataclasses import dataclass
from pathlib import Path
from typing import Hashable, Iterable, Sequence

import pytest

LIST = Path(__file__).with_name("extended.txt")
# the matrices the quick tier samples (:func:`sample_params`): the cover decides which of their cases
# are quick, so none of them is listed, however long (a listed case could take a row out of the cover)
SAMPLED = frozenset({"tests/test_output_failures.py::test_output_failure"})


@dataclass(frozen=True)
class Entry:
    seconds: float
    test: str  # a node id; without "[...]" it takes every case of the function
    line: int


def entries(path: Path = LIST) -> list[Entry]:
    """The listed tests; a line is ``SECONDS  NODEID`` and ``#`` starts a comment."""
    out = []
    for number, raw in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        text = raw.split("#", 1)[0].strip() if not raw.lstrip().startswith("#") else ""
        if not text:
            continue
        seconds, _, test = text.partition(" ")
        out.append(Entry(float(seconds), test.strip(), number))
    return out


def extended(nodeid: str, listed: frozenset[str]) -> bool:
    """Whether a collected test is in the extended tier: its node id, or its function, is listed."""
    return nodeid in listed or nodeid.split("[", 1)[0] in listed


def mark(items: Iterable[pytest.Item], listed: frozenset[str]) -> None:
    for item in items:
        if extended(item.nodeid, listed):
            item.add_marker(pytest.mark.extended)


def missing(entry: Entry, root: Path) -> str | None:
    """Why a listed test names nothing (a renamed or deleted test must leave the list), or None."""
    path, _, rest = entry.test.partition("::")
    file = root / path
    if not file.is_file():
        return f"{path} does not exist"
    name = rest.split("[", 1)[0]
    tree = ast.parse(file.read_text(encoding="utf-8"))
    functions = {n.name for n in ast.walk(tree) if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))}
    return None if name in functions else f"{path} has no test {name}"


def covering(table: Sequence[tuple[Hashable, Hashable]]) -> set[int]:
    """Indices of a covering sample of a two-way matrix: every row and every column at least once.

    Rows are taken in order; each takes the first of its columns not yet covered (else its first),
    so a matrix of R rows keeps about R cases instead of R x C, and no column is left out.
    """
    keep: set[int] = set()
    columns_done: set[Hashable] = set()
    by_row: dict[Hashable, list[int]] = {}
    for index, (row, _) in enumerate(table):
        by_row.setdefault(row, []).append(index)
    for row, indices in by_row.items():
        fresh = [i for i in indices if table[i][1] not in columns_done]
        pick = (fresh or indices)[0]
        keep.add(pick)
        columns_done.add(table[pick][1])
    for index, (_, column) in enumerate(table):  # a column no row reached yet
        if column not in columns_done:
            keep.add(index)
            columns_done.add(column)
    return keep


def sample_params(table: Sequence[tuple], ids: Sequence[str], key=lambda case: case) -> list:
    """``pytest.param`` cases of a matrix: the covering sample in the quick tier, the rest extended."""
    keys = [key(case) for case in table]
    keep = covering(keys)
    return [pytest.param(*case, id=ident, marks=() if i in keep else pytest.mark.extended)
            for i, (case, ident) in enumerate(zip(table, ids))]
