"""`agspec explain ID` (F-EXPLAIN): every ID agspec prints can be looked up in the spec."""

from __future__ import annotations

import json
import re

import pytest
from click.testing import CliRunner

from agspec.cli.main import cli
from agspec.cli.run_cmds import RUN_ROWS
from agspec.formats.schemas import validator
from agspec.resources import spec_dir
from agspec.spec_index import spec_entries, spec_entry

INDEXED = sorted(set(re.findall(r"^\|\s*([A-Z][A-Z0-9]*(?:-[A-Z0-9]+)+)\s*\|", (spec_dir() / "README.md").read_text(),
                                re.M)))
CODES = sorted(set(re.findall(r"^\|\s*(AG\d{3})\s*\|", (spec_dir() / "09-formats.md").read_text(), re.M)))


def _explain(*args: str):
    return CliRunner().invoke(cli, ["explain", *args])


def test_every_id_of_the_index_and_every_code_has_an_entry():  # F-EXPLAIN
    missing = [i for i in INDEXED + CODES if spec_entry(i) is None]
    assert not missing
    assert len(INDEXED) > 200 and len(CODES) > 100


@pytest.mark.parametrize("ident, words", [
    ("RES-TOPOLOGY-LINE", "same row"),          # an inline resolution: its paragraph
    ("M-THROUGHPUT", "|D_T| / T"),              # a heading: its body
    ("AG305", "no predecessor produces"),      # a code: both F-CODES tables merged
    ("ag305", "RC-MATERIAL"),
    ("F-CODES", "AG0xx I/O and usage"),         # a level-2 heading
])
def test_an_entry_is_the_text_that_declares_the_id(ident, words):  # F-EXPLAIN
    result = _explain(ident, "--format", "json")
    assert result.exit_code == 0, result.output
    doc = json.loads(result.output)
    validator("explain").validate(doc)
    [entry] = doc["entries"]
    assert entry["id"] == ident.upper() and words in entry["text"]


def test_a_heading_entry_stops_at_the_next_heading():  # F-EXPLAIN
    entry = spec_entry("R-PICK")
    assert "R-HANDOFF" not in entry.text.split("\n")[0] and "### " not in entry.text


def test_every_measure_of_the_run_table_is_explained():  # F-EXPLAIN: the table's ID column
    for _key, label, _fmt, ident in RUN_ROWS:
        assert spec_entry(ident) is not None, (label, ident)


def test_a_prefix_lists_entries_and_an_unknown_id_suggests_close_ones():  # F-EXPLAIN
    listing = _explain("INV-", "--format", "json")
    assert listing.exit_code == 0
    ids = [e["id"] for e in json.loads(listing.output)["listings"][0]["entries"]]
    assert len(ids) == 11 + ids.count("INV-TRACE") and "INV-CONSERVATION" in ids
    unknown = _explain("M-" + "THRUPUT")  # a misspelling (built so the spec guard does not read it as a citation)
    assert unknown.exit_code == 1 and "M-THROUGHPUT" in unknown.output
    nothing = _explain("NOPE-XYZ-QQQ")
    assert nothing.exit_code == 1 and "agspec explain M-" in nothing.output


def test_resolution_titles_stop_before_their_tag():  # F-EXPLAIN
    titles = {e.id: e.title for e in spec_entries() if e.kind == "resolution"}
    assert len(titles) >= 80
    assert all(t and "[" not in t and not t.endswith("*") for t in titles.values()), titles
