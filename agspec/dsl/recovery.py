"""Syntax-error recovery of the DSL parser and its messages (spec F-DSL, F-DIAGNOSTICS).

``_Recovery`` is the LALR ``on_error`` callback of one :func:`agspec.dsl.parse.parse` call: it
records one :class:`~agspec.formats.diagnostics.Diagnostic` per error (AG1xx) and repairs the input so
that parsing goes on.  It uses three repairs, tried in order:

1. a missing ``}`` is inserted when that makes the offending keyword acceptable (AG107);
2. up to two missing tokens (a value after a keyword, ``x`` in ``5 x 6`` ...) are inserted
   when that makes the offending token acceptable (AG106 / AG102);
3. otherwise the offending token and the rest of its line are skipped (a whole block, if
   the line opens one) and parsing resumes at the next line (AG102 / AG104).

At most one error is reported per line, so one mistake gives one message; at most
``MAX_ERRORS`` per file.

Syntax error codes (F-DIAGNOSTICS, spec/09-formats.md):

* AG101 unexpected character
* AG102 unexpected token
* AG103 unexpected end of file (unclosed block, empty file)
* AG104 unknown or misplaced field
* AG105 unterminated string
* AG106 missing value after a keyword
* AG107 missing ``}`` before the next item
* AG108 more than one document in a file
* AG109 ``use`` after the document
"""

from __future__ import annotations

from typing import Any, Iterable

from lark import Token, Tree
from lark.exceptions import UnexpectedCharacters, UnexpectedInput, UnexpectedToken

from agspec.dsl.grammar import keywords
from agspec.formats.diagnostics import Diagnostic, Span
from agspec.suggest import Edit, Fix, closest

MAX_ERRORS = 20


# --------------------------------------------------------------------------- human words

_PUNCT = {
    "LBRACE": "`{`",
    "RBRACE": "`}`",
    "LPAR": "`(`",
    "RPAR": "`)`",
    "COMMA": "`,`",
    "ARROW": "`->`",
    "DOTDOT": "`..`",
    "EQUALS": "`=`",
    "PIPE": "`|`",
}

# (context noun, description, terminals); block-level groups come first.
_GROUPS: tuple[tuple[str, str, frozenset[str]], ...] = (
    (
        "operation field",
        "an operation field such as `inputs`, `team` or `duration`",
        frozenset({"TYPE", "AFTER", "INPUTS", "TEAM", "ROLES", "USES", "DURATION", "WEIGHT"}),
    ),
    (
        "recipe item",
        "a recipe item such as `raw`, `operation` or `xor`",
        frozenset({"VALUE", "RAW", "RESOURCE", "OPERATION", "XOR"}),
    ),
    (
        "scenario field",
        "a scenario field such as `grid`, `recipes` or `release`",
        frozenset({"FAMILY", "LEVEL", "GRID", "RECIPES", "PROFILE", "RELEASE", "WIP", "EVALUATION",
                   "SHELVES", "COORDINATION", "PRODUCTS", "RESOURCE", "SUITE"}),
    ),
    (
        "profile setting",
        "a profile setting such as `spacing`, `rho_conf` or `durations`",
        frozenset({"SPACING", "REACH", "REFERENCE_REACH", "REFERENCE_TIME", "RHO_CONF", "CLEARANCE",
                   "ROLE_TARGET_OFFSET", "RETREAT_FRACTION", "SPEED", "JOINT_SPEED", "PAYLOAD",
                   "ROBOT_MODEL", "TOOLS", "DURATIONS", "MOTION_PLANNING", "TRAJECTORY_CONFLICTS"}),
    ),
    (
        "document",
        "a document (`recipe`, `profile` or `scenario`)",
        frozenset({"RECIPE", "PROFILE", "SCENARIO"}),
    ),
    ("shelf setting", "a shelf setting (`capacity`, `replenish`, `extra_access`)",
     frozenset({"CAPACITY", "REPLENISH", "EXTRA_ACCESS"})),
    ("coordination setting",
     "a coordination setting (`support_timeout`, `switch_lock`, `support_visible`, `bilateral_handoff`)",
     frozenset({"SUPPORT_TIMEOUT", "SWITCH_LOCK", "SUPPORT_VISIBLE", "BILATERAL_HANDOFF"})),
    ("product setting", "a product setting (`mass`, `due_slack`, `jitter`)",
     frozenset({"MASS", "DUE_SLACK", "JITTER"})),
    ("duration", "a logistics duration (`pick`, `handoff`, `deliver`)",
     frozenset({"PICK", "HANDOFF", "DELIVER"})),
    ("topology", "a topology (`moore`, `von_neumann` or `line`)",
     frozenset({"MOORE", "VON_NEUMANN", "LINE"})),
    ("boolean", "`on` or `off`", frozenset({"ON", "OFF", "TRUE", "FALSE"})),
    ("number", "a number", frozenset({"INT", "DECIMAL"})),
    ("name", "a name", frozenset({"NAME", "STRING"})),
)
_BLOCK_GROUPS = 5  # the first five groups describe what may start an item of a block
_VALUE_TERMINALS = frozenset({"NAME", "STRING", "INT", "DECIMAL", "ON", "OFF", "TRUE", "FALSE"})
# keywords that start a field or setting: never inserted by error repair
_FIELD_STARTS = frozenset().union(*(terms for _n, _w, terms in _GROUPS[:9])) | {"DOC", "VARIANT", "USE"}


def describe_expected(expected: Iterable[str]) -> str:
    """Human words for a set of expected terminals, most specific first.

    e.g. "a topology (`moore`, ...), `radius`, a scenario field such as `grid` ... or `}`".
    """
    rest = set(expected) - {"DOC"}  # `doc` is allowed everywhere; naming it adds only noise
    specific: list[str] = []
    blocks: list[str] = []
    for index, (_noun, words, terms) in enumerate(_GROUPS):
        if index < _BLOCK_GROUPS:
            # a block's items are named as a group only when all of them may come next
            if terms <= rest:
                blocks.append(words)
                rest -= terms
        elif terms & rest:
            specific.append(words)
            rest -= terms
    kw = keywords()
    tail: list[str] = []
    for term in sorted(rest):
        if term == "$END":
            tail.append("end of file")
        elif term in _PUNCT:
            tail.append(_PUNCT[term])
        elif term in kw:
            specific.append(f"`{kw[term]}`")
        else:
            specific.append(term.lower())
    parts = specific + blocks + tail
    if not parts:
        return "something else"
    if len(parts) > 6:
        parts = parts[:6] + ["..."]
    return parts[0] if len(parts) == 1 else ", ".join(parts[:-1]) + " or " + parts[-1]


def describe_token(tok: Token) -> str:
    if tok.type == "$END":
        return "end of file"
    if tok.type in _PUNCT:
        return _PUNCT[tok.type]
    if tok.type in keywords() and tok.type != "X":
        return f"keyword `{tok}`"
    if tok.type in ("INT", "DECIMAL"):
        return f"number `{tok}`"
    if tok.type == "STRING":
        return f"string {tok}"
    return f"`{tok}`"


def _context(expected: set[str]) -> tuple[str, frozenset[str]] | None:
    """The block whose items may come next (its noun and keywords), if any."""
    for noun, _words, terms in _GROUPS[:_BLOCK_GROUPS]:
        if terms <= expected:
            return noun, terms
    return None


# --------------------------------------------------------------------------- recovery


def _span_of(tok: Token) -> Span:
    end_line = tok.end_line if tok.end_line is not None else tok.line
    end_col = tok.end_column if tok.end_column is not None else tok.column + max(1, len(tok))
    return (tok.line, tok.column, end_line, end_col)


def _skip_extent(text: str, pos: int) -> int:
    """End of the rest of the line after ``pos``; a block opened on it is skipped whole.

    Stops before an unmatched ``}`` so that the enclosing block still closes.  Used only
    for error recovery (panic mode); the grammar does the real lexing.
    """
    depth = 0
    i = pos
    n = len(text)
    while i < n:
        ch = text[i]
        if ch == '"':
            i += 1
            while i < n and text[i] not in '"\n':
                i += 2 if text[i] == "\\" else 1
            i += 1
            continue
        if ch == "#":
            while i < n and text[i] != "\n":
                i += 1
            continue
        if ch == "\n" and depth == 0:
            return i
        if ch == "{":
            depth += 1
        elif ch == "}":
            if depth == 0:
                return i
            depth -= 1
            if depth == 0:
                return i + 1
        i += 1
    return n


def _dummy(term: str, at: Token) -> Token:
    values = {"INT": "1", "DECIMAL": "1.0", "NAME": "_", "STRING": '""'}
    value = values.get(term) or keywords().get(term) or _PUNCT.get(term, "`?`").strip("`")
    return Token.new_borrow_pos(term, value, at)


def _accepts(ip: Any, tokens: list[Token]) -> bool:
    trial = ip.copy()
    try:
        for tok in tokens:
            trial.feed_token(tok)
    except UnexpectedInput:
        return False
    return True


def _insertion(ip: Any, tok: Token, expected: set[str]) -> list[Token] | None:
    """Up to two tokens whose insertion before ``tok`` makes it acceptable."""
    expected = expected - _FIELD_STARTS - {"$END"}
    order = sorted(expected, key=lambda t: (t not in _VALUE_TERMINALS, t != "INT", t))
    for first in order:
        if _accepts(ip, [_dummy(first, tok), tok]):
            return [_dummy(first, tok)]
    for first in order:
        trial = ip.copy()
        try:
            trial.feed_token(_dummy(first, tok))
        except UnexpectedInput:
            continue
        for second in sorted(trial.accepts() - _FIELD_STARTS - {"$END"}):
            if _accepts(trial, [_dummy(second, tok), tok]):
                return [_dummy(first, tok), _dummy(second, tok)]
    return None


def _last_shifted(ip: Any) -> Token | None:
    stack = getattr(ip.parser_state, "value_stack", [])
    for item in reversed(stack):
        if isinstance(item, Token):
            return item
        if isinstance(item, Tree):
            toks = list(item.scan_values(lambda v: isinstance(v, Token)))
            if toks:
                return toks[-1]
    return None


def _unclosed_brace(ip: Any) -> Token | None:
    stack = getattr(ip.parser_state, "value_stack", [])
    for item in reversed(stack):
        if isinstance(item, Token) and item.type == "LBRACE":
            return item
    return None


class _Recovery:
    """The ``on_error`` callback of one parse: records diagnostics and repairs the input."""

    def __init__(self, text: str, file: str | None) -> None:
        self.text = text
        self.file = file
        self.diagnostics: list[Diagnostic] = []
        self.lines_with_errors: set[int] = set()
        self.stopped = False

    def report(self, code: str, message: str, span: Span, hint: str | None = None,
               notes: tuple[str, ...] = (), fix: Fix | None = None) -> None:
        if span[0] in self.lines_with_errors:
            return
        self.lines_with_errors.add(span[0])
        self.diagnostics.append(Diagnostic(
            code=code, message=message, file=self.file, line=span[0], col=span[1],
            end_line=span[2], end_col=span[3], hint=hint, notes=notes, fix=fix,
        ))

    def __call__(self, e: UnexpectedInput) -> bool:
        if len(self.diagnostics) >= MAX_ERRORS:
            self.stopped = True
            return False
        if isinstance(e, UnexpectedCharacters):
            return self._characters(e)
        if isinstance(e, UnexpectedToken):
            return self._token(e)
        return False  # pragma: no cover - lark raises only the two kinds above

    def _skip(self, ip: Any, start: int) -> None:
        state = ip.lexer_thread.state
        end = _skip_extent(self.text, start)
        if end > state.line_ctr.char_pos:
            state.line_ctr.feed(self.text[state.line_ctr.char_pos:end])

    def _characters(self, e: UnexpectedCharacters) -> bool:
        ch = self.text[e.pos_in_stream] if e.pos_in_stream < len(self.text) else ""
        span = (e.line, e.column, e.line, e.column + 1)
        if ch == '"':
            self.report("AG105", "unterminated string", span,
                        hint="close the string with `\"` on the same line")
            self._skip(e.interactive_parser, e.pos_in_stream)
        else:
            shown = ch if ch.isprintable() else repr(ch)
            self.report("AG101", f"unexpected character `{shown}`", span,
                        hint="names use letters, digits, `_`, `-` and `.`; comments start with `#`")
        return True

    def _token(self, e: UnexpectedToken) -> bool:
        tok, ip = e.token, e.interactive_parser
        expected = set(ip.accepts())  # precise, unlike e.expected for root-lexer tokens
        kw = keywords()
        if tok.type == "$END":
            self._end_of_file(ip, expected, tok)
            return False
        span = _span_of(tok)
        if tok.type == "USE" and "USE" not in expected:
            self.report("AG109", "`use` statements must come before the document", span,
                        hint="move this line to the top of the file")
            self._skip(ip, tok.end_pos)
            return True
        if expected <= {"$END"}:
            self.report("AG108", f"unexpected {describe_token(tok)} after the end of the document",
                        span, hint="a file holds exactly one recipe, profile or scenario")
            self.stopped = True
            return False
        context = _context(expected)
        rbrace = _dummy("RBRACE", tok)
        if "RBRACE" in expected and tok.type in kw and _accepts(ip, [rbrace, tok]):
            opened = _unclosed_brace(ip)
            notes = (f"the block opened at {opened.line}:{opened.column} is not closed",) if opened else ()
            self.report("AG107", f"missing `}}` before {describe_token(tok)}", span,
                        hint="close the block with `}`", notes=notes)
            ip.feed_token(rbrace)
            ip.feed_token(tok)
            return True
        others = expected - (context[1] if context else frozenset()) - {"RBRACE", "DOC", "VARIANT"}
        prev = _last_shifted(ip)
        new_line = prev is not None and tok.line > (prev.end_line or prev.line)
        if context is not None and (not others or new_line) and (tok.type == "NAME" or tok.type in kw):
            noun, terms = context
            self._unknown_field(tok, noun, terms, expected, span,
                                continues=prev if "COMMA" in expected and new_line else None)
            self._skip(ip, tok.end_pos)
            return True
        repair = _insertion(ip, tok, expected)
        if repair is not None:
            missing = repair[0].type
            if missing in _VALUE_TERMINALS and prev is not None and prev.type in kw:
                self.report("AG106", f"missing value after `{prev}`: expected {describe_expected(expected)}",
                            _span_of(prev), hint=f"write the value after `{prev}` on the same line")
            else:
                after = f" after `{prev}`" if prev is not None else ""
                self.report("AG102", f"expected {describe_expected(expected)}{after}, "
                                     f"found {describe_token(tok)}", span)
            for dummy in repair:
                ip.feed_token(dummy)
            ip.feed_token(tok)
            return True
        after = f" after `{prev}`" if prev is not None else ""
        self.report("AG102", f"expected {describe_expected(expected)}{after}, found {describe_token(tok)}",
                    span)
        self._skip(ip, tok.end_pos)
        return True

    def _unknown_field(self, tok: Token, noun: str, terms: frozenset[str], expected: set[str],
                       span: Span, continues: Token | None = None) -> None:
        kw = keywords()
        words = sorted(kw[t] for t in expected if t in kw)
        close = [] if tok.type in kw else closest(tok, words)  # F-SUGGEST: a keyword is misplaced, not misspelt
        listed = ", ".join(f"`{kw[t]}`" for t in sorted(terms, key=lambda t: kw[t]))
        article = "an" if noun[0] in "aeiou" else "a"
        hint = f"did you mean `{close[0]}`?" if close else f"{article} {noun} is one of {listed}"
        fix = Fix(f"replace `{tok}` by `{close[0]}`", (Edit(*span, close[0]),)) if close else None  # F-FIX
        if continues is not None and not close:
            hint = f"if `{tok}` continues the list above, add `,` after `{continues}`"
        if tok.type in kw:
            self.report("AG104", f"`{tok}` is not allowed here: expected {describe_expected(expected)}",
                        span, hint=hint, fix=fix)
        else:
            self.report("AG104", f"unknown {noun} `{tok}`", span, hint=hint, fix=fix)

    def _end_of_file(self, ip: Any, expected: set[str], tok: Token) -> None:
        opened = _unclosed_brace(ip)
        if opened is not None:
            self.report("AG103", "unexpected end of file: this block is never closed", _span_of(opened),
                        hint="add the missing `}`")
            return
        line, col = _end_position(self.text)
        if all(ln.strip().startswith("#") or not ln.strip() for ln in self.text.splitlines()):
            message = "empty file: expected a document (`recipe`, `profile` or `scenario`)"
        else:
            message = f"unexpected end of file: expected {describe_expected(expected)}"
        self.report("AG103", message, (line, col, line, col + 1))


def _end_position(text: str) -> tuple[int, int]:
    """(line, col) just after the last non-blank character (1-based)."""
    body = text.rstrip()
    if not body:
        return 1, 1
    line = body.count("\n") + 1
    col = len(body) - (body.rfind("\n") + 1) + 1
    return line, col

