"""Parse `.ag` text into an AST with source positions (spec F-DSL, F-DIAGNOSTICS).

``parse(text, file)`` never raises on user input.  It returns a :class:`SourceFile` whose
``document`` is ``None`` when the text has syntax errors; ``diagnostics`` then holds one
:class:`~agspec.formats.diagnostics.Diagnostic` per error (AG1xx), several per run where recovery
is possible.  The recovery, its messages and the AG1xx codes are in :mod:`agspec.dsl.recovery`;
the LALR parser is built in :mod:`agspec.dsl.grammar`.

The AST is deliberately generic: a document is a list of :class:`Field` nodes, each with
its keyword, positional ``args``, list ``items`` and nested ``body``; ``build.py`` gives them
meaning.  Field shapes (``key``: contents):

* ``doc``: args=(string,) — ``value``/``type``/``duration``/``weight``/``family``/``level``/
  ``wip``/``robot_model``/``release``/numeric profile settings/``motion_planning``/
  ``trajectory_conflicts``: args=(atom,)
* ``raw``/``after``/``uses``/``recipes``/``tools``: items=(names...)
* ``inputs``: items=(inputs...), args=(outputs...)
* ``team``: args=(min, max or None)
* ``roles``: items=(Role...)
* ``resource``: name, args=(capacity or None,)
* ``xor``: name, items=(alternatives...)
* ``operation``/``variant``: name, body=(fields...)
* ``durations``/``shelves``/``coordination``/``products``: body=(settings...); ``mass``:
  args=(min, max)
* ``grid``: args=(rows, cols, topology or None, radius or None)
* ``profile`` (in a scenario): args=(id, variant or None)
* ``evaluation``: args=(mode keyword, size or horizon, timeout or None)
* ``suite``: args=(official keyword, prefix or None, generation or None, execution or None)
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any

from lark import Token, Transformer, v_args
from lark.exceptions import UnexpectedInput

from agspec.dsl.grammar import _parser, keywords
from agspec.dsl.recovery import MAX_ERRORS, _Recovery, _span_of, describe_expected
from agspec.formats.diagnostics import Diagnostic, Span

# keywords and describe_expected are offered here too: the parser's public words
__all__ = ["Atom", "DocumentNode", "Field", "MAX_ERRORS", "Role", "SourceFile", "Use", "describe_expected",
           "keywords", "parse"]


# --------------------------------------------------------------------------- AST


@dataclass(frozen=True)
class Atom:
    """A leaf: a name, string, number, boolean or keyword, with its exact source text."""

    value: Any
    text: str
    kind: str  # "name" | "string" | "int" | "decimal" | "bool" | "keyword"
    span: Span


@dataclass(frozen=True)
class Role:
    name: Atom
    binds: Atom | None
    span: Span


@dataclass(frozen=True)
class Field:
    """One field, setting or named block of a document (see the module docstring)."""

    key: str
    span: Span
    key_span: Span
    name: Atom | None = None
    args: tuple[Any, ...] = ()
    items: tuple[Any, ...] = ()
    body: tuple["Field", ...] = ()


@dataclass(frozen=True)
class Use:
    path: Atom
    span: Span


@dataclass(frozen=True)
class DocumentNode:
    kind: str  # "recipe" | "profile" | "scenario"
    name: Atom
    body: tuple[Field, ...]
    span: Span
    header_span: Span  # from the kind keyword to the end of the name


@dataclass(frozen=True)
class SourceFile:
    """The parse result: the AST (``document`` is None after syntax errors) and diagnostics."""

    file: str | None
    text: str
    uses: tuple[Use, ...] = ()
    document: DocumentNode | None = None
    comments: tuple[Atom, ...] = ()
    diagnostics: tuple[Diagnostic, ...] = field(default_factory=tuple)

    @property
    def ok(self) -> bool:
        return self.document is not None and not any(d.severity == "error" for d in self.diagnostics)


# --------------------------------------------------------------------------- tree -> AST


def _meta_span(meta: Any) -> Span:
    return (meta.line, meta.column, meta.end_line, meta.end_column)


def _join(a: Span, b: Span) -> Span:
    return (a[0], a[1], b[2], b[3])


def _atom(tok: Token, kind: str, value: Any) -> Atom:
    return Atom(value=value, text=str(tok), kind=kind, span=_span_of(tok))


def _keyword(tok: Token) -> Atom:
    return _atom(tok, "keyword", str(tok))


_BOOLS = {"ON": True, "TRUE": True, "OFF": False, "FALSE": False}


@v_args(meta=True)
class _ToAST(Transformer):
    """lark tree -> AST (Field nodes)."""

    # leaves ---------------------------------------------------------------
    def name(self, meta: Any, children: list[Token]) -> Atom:
        tok = children[0]
        if tok.type == "STRING":
            return _atom(tok, "string", json.loads(str(tok)))
        return _atom(tok, "name", str(tok))

    def number(self, meta: Any, children: list[Token]) -> Atom:
        tok = children[0]
        if tok.type == "INT":
            return _atom(tok, "int", int(str(tok)))
        return _atom(tok, "decimal", float(str(tok)))

    def boolean(self, meta: Any, children: list[Token]) -> Atom:
        tok = children[0]
        return _atom(tok, "bool", _BOOLS[tok.type])

    def topology(self, meta: Any, children: list[Token]) -> Atom:
        tok = children[0]
        return _atom(tok, "name", str(tok))

    def name_list(self, meta: Any, children: list[Any]) -> tuple[Atom, ...]:
        return tuple(c for c in children if isinstance(c, Atom))

    # helpers --------------------------------------------------------------
    @staticmethod
    def _field(meta: Any, children: list[Any], **kw: Any) -> Field:
        head = children[0]
        return Field(key=str(head), span=_meta_span(meta), key_span=_span_of(head), **kw)

    # generic single-value fields -----------------------------------------
    def _single(self, meta: Any, children: list[Any]) -> Field:
        return self._field(meta, children, args=(children[1],))

    value = type = duration = weight = family = level = wip = robot_model = _single

    def doc(self, meta: Any, children: list[Any]) -> Field:
        tok = children[1]
        return self._field(meta, children, args=(_atom(tok, "string", json.loads(str(tok))),))

    def release(self, meta: Any, children: list[Any]) -> Field:
        return self._field(meta, children, args=(children[2],))

    def _list(self, meta: Any, children: list[Any]) -> Field:
        items = children[1] if len(children) > 1 and children[1] is not None else ()
        return self._field(meta, children, items=tuple(items))

    raw = after = uses = recipes = tools = _list

    def inputs(self, meta: Any, children: list[Any]) -> Field:
        ins = children[1] or ()
        outs = children[3] or ()
        return self._field(meta, children, items=tuple(ins), args=tuple(outs))

    def team(self, meta: Any, children: list[Any]) -> Field:
        return self._field(meta, children, args=(children[1], children[3]))

    def role(self, meta: Any, children: list[Any]) -> Role:
        return Role(name=children[0], binds=children[2], span=_meta_span(meta))

    def roles(self, meta: Any, children: list[Any]) -> Field:
        return self._field(meta, children, items=tuple(c for c in children if isinstance(c, Role)))

    def resource(self, meta: Any, children: list[Any]) -> Field:
        return self._field(meta, children, name=children[1], args=(children[3],))

    def xor(self, meta: Any, children: list[Any]) -> Field:
        alts = tuple(c for c in children[3:] if isinstance(c, Atom))
        return self._field(meta, children, name=children[1], items=alts)

    def _block(self, meta: Any, children: list[Any]) -> Field:
        body = tuple(c for c in children if isinstance(c, Field))
        return self._field(meta, children, name=children[1], body=body)

    operation = variant = _block

    # settings (keyword + value) -----------------------------------------
    def _setting(self, meta: Any, children: list[Any]) -> Field:
        return self._field(meta, children, args=tuple(c for c in children[1:] if isinstance(c, Atom)))

    number_setting = duration_setting = shelf_setting = coordination_setting = switch = _setting
    product_setting = _setting  # `mass` has two values

    def _group(self, meta: Any, children: list[Any]) -> Field:
        return self._field(meta, children, body=tuple(c for c in children[1:] if isinstance(c, Field)))

    durations = shelves = coordination = products = _group

    def grid(self, meta: Any, children: list[Any]) -> Field:
        rows, cols, topo, radius = children[1], children[3], children[4], children[6]
        return self._field(meta, children, args=(rows, cols, topo, radius))

    def profile_ref(self, meta: Any, children: list[Any]) -> Field:
        return self._field(meta, children, args=(children[1], children[3]))

    def continuing(self, meta: Any, children: list[Any]) -> tuple[Atom, Atom, None]:
        return (_keyword(children[0]), children[2], None)

    def batch(self, meta: Any, children: list[Any]) -> tuple[Atom, Atom, Atom | None]:
        return (_keyword(children[0]), children[1], children[3])

    def evaluation(self, meta: Any, children: list[Any]) -> Field:
        return self._field(meta, children, args=children[1])

    def suite(self, meta: Any, children: list[Any]) -> Field:
        official = children[1]
        official_atom = _atom(official, "bool", official.type == "OFFICIAL")
        prefix, gen, exe = children[3], children[6], children[8]
        return self._field(meta, children, args=(official_atom, prefix, gen, exe))

    # documents ------------------------------------------------------------
    def _document(self, meta: Any, children: list[Any]) -> DocumentNode:
        head, name = children[0], children[1]
        body = tuple(c for c in children[2:] if isinstance(c, Field))
        return DocumentNode(kind=str(head), name=name, body=body, span=_meta_span(meta),
                            header_span=_join(_span_of(head), name.span))

    recipe = profile = scenario = _document

    def use(self, meta: Any, children: list[Any]) -> Use:
        tok = children[1]
        return Use(path=_atom(tok, "string", json.loads(str(tok))), span=_meta_span(meta))

    def start(self, meta: Any, children: list[Any]) -> tuple[tuple[Use, ...], DocumentNode]:
        uses = tuple(c for c in children if isinstance(c, Use))
        doc = next(c for c in children if isinstance(c, DocumentNode))
        return uses, doc


# --------------------------------------------------------------------------- entry point


def _comments(text: str) -> tuple[Atom, ...]:
    """All `#` comments (for the formatter); strings are lexed properly so `#` inside is ignored."""
    out = []
    try:
        for tok in _parser().lex(text, dont_ignore=True):
            if tok.type == "COMMENT":
                out.append(_atom(tok, "string", str(tok)))
    except UnexpectedInput:
        return ()
    return tuple(out)


def parse(text: str, file: str | None = None) -> SourceFile:
    """Parse DSL text (F-DSL).  Never raises on user input; see the module docstring."""
    recovery = _Recovery(text, file)
    tree = None
    try:
        tree = _parser().parse(text, on_error=recovery)
    except UnexpectedInput as exc:
        if not recovery.diagnostics:  # pragma: no cover - recovery always reports first
            line, col = getattr(exc, "line", 1) or 1, getattr(exc, "column", 1) or 1
            recovery.report("AG102", "syntax error", (line, col, line, col + 1))
    diags = list(recovery.diagnostics)
    if recovery.stopped and len(diags) >= MAX_ERRORS:
        last = diags[-1]
        diags[-1] = Diagnostic(**{**last.__dict__, "notes": last.notes + ("too many errors; stopped",)})
    if diags or tree is None:
        return SourceFile(file=file, text=text, diagnostics=tuple(diags))
    uses, document = _ToAST().transform(tree)
    return SourceFile(file=file, text=text, uses=uses, document=document, comments=_comments(text))
