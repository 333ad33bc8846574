"""Parser and builder behaviour: positions, names, keywords, source maps (F-DSL, F-DIAGNOSTICS)."""

from __future__ import annotations

from agspec.formats.diagnostics import Issue, locate
from agspec.dsl.build import build, compile_text
from agspec.dsl.parse import _parser, describe_expected, parse

RECIPE = """\
recipe r {
    raw A, B
    operation join {
        type assemble
        inputs A, B -> FINAL
        team 2..4
        roles holder_A(A), holder_B(B), helper
        duration 4
        weight 1.5
    }
}
"""


def test_every_terminal_is_named():  # no __ANON_n can ever reach a message
    assert not [t.name for t in _parser().terminals if t.name.startswith("__")]


def test_source_map_points_at_sorted_nodes():
    _src, built = compile_text(RECIPE, "r.ag")
    m = built.srcmap
    assert m["/operations/0/inputs/1"] == (5, 19, 5, 20)  # B
    assert m["/operations/0/outputs/0"] == (5, 24, 5, 29)  # FINAL
    assert m["/operations/0/arity/1"] == (6, 17, 6, 18)
    assert m["/operations/0/roles/2/name"] == (7, 41, 7, 47)
    assert m["/operations/0/roles/1/binds"] == (7, 37, 7, 38)
    assert m["/operations/0/duration"] == (8, 18, 8, 19)
    assert m[""] == (1, 1, 1, 9)


def test_locate_uses_closest_mapped_ancestor():  # F-DIAGNOSTICS: issue pointer -> line:col
    _src, built = compile_text(RECIPE, "r.ag")
    d = locate(Issue("AG333", "x", "/operations/0/roles/2/name/oops"), "r.ag", built.srcmap)
    assert (d.line, d.col) == (7, 41)
    d = locate(Issue("AG333", "x", "/operations/0/after"), "r.ag", built.srcmap)  # default: the op header
    assert (d.line, d.col) == (3, 5)


def test_keywords_are_names_where_a_name_is_expected():
    ir = compile_text("""recipe type { raw inputs
        operation duration { type weight inputs inputs -> x team 1 duration 1 } }""")[1].ir
    assert ir["id"] == "type" and ir["raw"] == ["inputs"]
    assert ir["operations"][0]["id"] == "duration" and ir["operations"][0]["type"] == "weight"
    assert ir["operations"][0]["outputs"] == ["x"]


def test_names_with_dashes_dots_digits_and_quotes():
    src = parse('profile abstract-v1 { variant spacing-0.75 { spacing 0.75 } variant "odd name" { } }')
    assert src.ok
    ir = build(src).ir
    assert ir["id"] == "abstract-v1" and set(ir["variants"]) == {"spacing-0.75", "odd name"}


def test_arrow_without_spaces_and_grid_without_spaces():
    ir = compile_text("recipe r { raw A operation a { type t inputs A->B team 1 duration 1 } }")[1].ir
    assert ir["operations"][0]["inputs"] == ["A"] and ir["operations"][0]["outputs"] == ["B"]
    scen = compile_text("scenario s { grid 4x5 line radius 2 }")[1].ir
    assert scen["grid"] == {"rows": 4, "cols": 5, "topology": "line", "radius": 2}


def test_comments_and_strings():
    src = parse('# head\nrecipe r { doc "a # not a comment \\u00e9" # real\n raw A }')
    assert src.ok and len(src.comments) == 2
    assert build(src).ir["doc"] == "a # not a comment é"


def test_several_syntax_errors_in_one_run():
    text = "recipe r {\n  raw A @\n  operation { type t }\n  value\n  resource x capacity many\n}\n"
    codes = [(d.code, d.line) for d in parse(text).diagnostics]
    assert codes == [("AG101", 2), ("AG106", 3), ("AG106", 4), ("AG102", 5)]


def test_no_document_after_syntax_errors_and_never_an_exception():
    src = parse("recipe r { raw }")
    assert src.document is None and not src.ok
    assert build(src).ir is None and build(src).diagnostics == src.diagnostics


def test_expected_terminals_in_human_words():
    words = describe_expected({"TYPE", "AFTER", "INPUTS", "TEAM", "ROLES", "USES", "DURATION", "WEIGHT",
                               "DOC", "RBRACE"})
    assert words == "an operation field such as `inputs`, `team` or `duration` or `}`"
    assert describe_expected({"INT", "DECIMAL"}) == "a number"


def test_build_reports_duplicates_and_keeps_the_first():
    text = ("recipe r { raw A raw B\n operation a { type t inputs A -> F team 1 duration 1 }\n"
            " operation a { type u inputs A -> F team 1 duration 2 } }")
    built = compile_text(text)[1]
    assert [(d.code, d.line) for d in built.diagnostics] == [("AG206", 1), ("AG301", 3)]
    assert built.ir["raw"] == ["A"] and [op["type"] for op in built.ir["operations"]] == ["t"]
