"""agspec.formats.limits (F-LIMITS): each limit refuses at the located offending token, names the limit
and its variable; the variables raise the limits; large JSON documents are located lazily
(F-LIMITS-POSITIONS)."""

from __future__ import annotations

import json

import pytest

from agspec.formats.limits import InputError, Limits, iter_json_lines, parse_json, parse_yaml
from agspec.load import POSITIONS_MAX_CHARS, check_document, load_document


def test_each_json_limit_is_located_and_says_how_to_raise_it():
    small = Limits(max_depth=3, max_number_chars=5, max_string_chars=4)
    cases = [('{"a": [[[1]]]}', "max_depth", (1, 9)), ('{"a": 1234567}', "max_number_chars", (1, 7)),
             ('{"a": "xxxxx"}', "max_string_chars", (1, 7))]
    for text, limit, where in cases:
        with pytest.raises(InputError) as info:
            parse_json(text, "f.json", small)
        err = info.value
        assert (err.code, err.limit, (err.line, err.col)) == ("AG006", limit, where)
        assert Limits.ENV[limit] in err.hint


@pytest.mark.parametrize("text, code, where", [
    ('{"a": 1,\n "a": 2}', "AG206", (2, 2)), ('[1, NaN]', "AG003", (1, 5)), ('[1e999]', "AG003", (1, 2)),
])
def test_duplicate_keys_and_non_finite_numbers_are_refused_where_they_are(text, code, where):
    with pytest.raises(InputError) as info:
        parse_json(text, "f.json", Limits())
    assert (info.value.code, (info.value.line, info.value.col)) == (code, where)


def test_the_variables_raise_and_validate_the_limits():
    limits = Limits.from_env({"AGSPEC_MAX_DEPTH": "200", "AGSPEC_MAX_BYTES": "2G"})
    assert limits.max_depth == 200 and limits.max_bytes == 2 * 1024**3
    assert parse_json("[" * 100 + "]" * 100, None, limits) is not None
    with pytest.raises(InputError) as info:
        Limits.from_env({"AGSPEC_MAX_DEPTH": "lots"})
    assert info.value.exit_code == 2


def test_yaml_alias_bombs_recursion_and_duplicates_are_refused_before_construction():
    bomb = "a: &a [1, 1, 1, 1]\n" + "".join(f"{c}: &{c} [*{p}, *{p}, *{p}, *{p}]\n" for p, c in zip("abcdefg", "bcdefgh"))
    for text, code in ((bomb, "AG006"), ("a: &a [*a]\n", "AG008"), ("a: 1\na: 2\n", "AG206"), ("a: .inf\n", "AG008")):
        with pytest.raises(InputError) as info:
            parse_yaml(text, "x.yaml", Limits(max_yaml_nodes=10_000))
        assert info.value.code == code, text
    assert parse_yaml("c-1: {outcome: fail}\n", "x.yaml") == {"c-1": {"outcome": "fail"}}


def test_an_overlong_json_lines_record_is_skipped_and_reported(tmp_path):
    path = tmp_path / "t.jsonl"
    path.write_text('{"a": 1}\n{"b": "' + "x" * 200 + '"}\n{"c": 3}\n', encoding="utf-8")
    out = list(iter_json_lines(path, Limits(max_record_bytes=100)))
    assert [line for line, _ in out] == [1, 2, 3] and out[0][1] == {"a": 1} and out[2][1] == {"c": 3}
    assert isinstance(out[1][1], InputError) and out[1][1].limit == "max_record_bytes" and out[1][1].line == 2


def test_a_large_json_document_is_located_only_when_it_has_an_error(tmp_path):
    """F-LIMITS-POSITIONS: no source map at load time above the threshold, yet errors keep line:col."""
    doc = {"ir_version": "agspec-ir/1", "kind": "recipe", "id": "big", "doc": "x" * (POSITIONS_MAX_CHARS + 10),
           "value": 1.0, "resources": {}, "xor": [], "raw": ["A"],
           "operations": [{"id": "a", "type": "t", "after": [], "inputs": ["A"], "outputs": ["FINAL"],
                           "arity": [1, 1], "roles": [], "resources": [], "weight": 1.0, "duration": 0}]}
    path = tmp_path / "big.json"
    path.write_text(json.dumps(doc, indent=1), encoding="utf-8")
    loaded = load_document(path)
    assert loaded.srcmap == {}
    (diag,) = [d for d in check_document(loaded) if d.severity == "error"]
    assert diag.code == "AG350" and diag.line is not None and '"duration": 0' in loaded.text.splitlines()[diag.line - 1]
