"""Source positions of large JSON documents, found without a positional parse (F-LIMITS-POSITIONS).

A diagnostic of a large document needs the place of a few JSON Pointers; a positional parse of the
whole text costs about 200 times its size in memory and minutes for a million values.
:func:`pointer_offsets` walks the text's tokens once, keeping only the open containers, and stops when
it has found every pointer asked for.
"""

from __future__ import annotations

import json
from typing import Any, Iterable

from agspec.formats.limits import TOKEN, position


def _escape(token: str) -> str:
    return token.replace("~", "~0").replace("/", "~1")


def pointer_offsets(text: str, wanted: Iterable[str]) -> dict[str, int]:
    """The offset in a JSON text of each wanted JSON Pointer: its member's key, or the value itself in
    an array or at the root.  One walk over the tokens that stops when all are found, in memory
    bounded by the nesting depth (F-LIMITS-POSITIONS: the source map of a large document)."""
    want = set(wanted)
    found: dict[str, int] = {}
    if not want:
        return found
    stack: list[list[Any]] = []  # per open container: [is_object, pointer, index or key, key offset, expect key]
    for m in TOKEN.finditer(text):
        tok = m.group()
        first = tok[0]
        top = stack[-1] if stack else None
        if top is not None and top[0] and top[4] and first == '"':
            try:
                top[2] = json.loads(tok)
            except ValueError:
                top[2] = tok[1:-1]
            top[3], top[4] = m.start(), False
            continue
        if first == ":":
            continue
        if first == ",":
            if top is not None:
                if top[0]:
                    top[4] = True
                else:
                    top[2] += 1
            continue
        if first in "]}":
            if stack:
                stack.pop()
            continue
        if top is None:
            ptr, at = "", m.start()
        elif top[0]:
            ptr, at = f"{top[1]}/{_escape(str(top[2]))}", top[3]
        else:
            ptr, at = f"{top[1]}/{top[2]}", m.start()
        if ptr in want and ptr not in found:
            found[ptr] = at
            if len(found) == len(want):
                return found
        if first in "[{":
            stack.append([first == "{", ptr, 0, m.start(), first == "{"])
    return found


def offset_position(text: str, offset: int) -> tuple[int, int]:
    """1-based line and column of a character offset."""
    return position(text, offset)


__all__ = ["pointer_offsets", "offset_position"]
