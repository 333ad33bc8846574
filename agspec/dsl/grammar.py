"""The LALR parser of the DSL grammar and its keyword terminals (spec F-DSL).

One parser is built per process from ``grammar.lark``; :mod:`agspec.dsl.parse` drives it and
:mod:`agspec.dsl.recovery` names its keywords in messages, :mod:`agspec.dsl.fmt` in quoting.
"""

from __future__ import annotations

from functools import lru_cache
from importlib import resources as _resources

from lark import Lark


@lru_cache(maxsize=1)
def grammar_text() -> str:
    return _resources.files("agspec.dsl").joinpath("grammar.lark").read_text(encoding="utf-8")


@lru_cache(maxsize=1)
def _parser() -> Lark:
    return Lark(
        grammar_text(),
        parser="lalr",
        lexer="contextual",
        propagate_positions=True,
        maybe_placeholders=True,
        cache=True,  # parser tables cached in the temp dir: a cold CLI start skips LALR construction
    )


@lru_cache(maxsize=1)
def keywords() -> dict[str, str]:
    """Keyword terminal name -> the word it spells (priority-2 terminals of the grammar)."""
    out = {}
    for term in _parser().terminals:
        if term.priority == 2:
            out[term.name] = "x" if term.name == "X" else term.name.lower()
    return out
