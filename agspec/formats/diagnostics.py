"""Diagnostics: stable error codes with locations, rendered Rust/Elm style.

Two layers:

* :class:`Issue` is produced by checks that work on IR (plain JSON).  It points into the IR
  with a JSON Pointer and knows nothing about files.
* :class:`Diagnostic` is an Issue placed in a file (line/col), ready to show a person or to
  emit as JSON.  ``locate`` turns the first into the second with a source map.

Code ranges (spec/09-formats.md): AG0xx I/O and usage, AG1xx DSL syntax, AG2xx schema,
AG3xx recipe semantics, AG4xx profile/scenario semantics and realizability, AG5xx instance IR.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Mapping, Sequence

from agspec.formats.pointer import join
from agspec.suggest import Change, Fix, render_change

# (line, col, end_line, end_col), all 1-based; end_col is exclusive.
Span = tuple[int, int, int, int]


@dataclass(frozen=True)
class Issue:
    """A problem found in an IR document, located by JSON Pointer."""

    code: str
    message: str
    pointer: str = ""
    hint: str | None = None
    severity: str = "error"
    change: Change | None = None  # the hint as an IR edit, when it is one (F-FIX)


@dataclass(frozen=True)
class Diagnostic:
    """A problem located in a source file."""

    code: str
    message: str
    file: str | None = None
    line: int | None = None
    col: int | None = None
    end_line: int | None = None
    end_col: int | None = None
    hint: str | None = None
    severity: str = "error"
    pointer: str | None = None
    notes: tuple[str, ...] = field(default_factory=tuple)
    fix: Fix | None = None  # the hint as a text edit of ``file``, when it is one (F-FIX)

    def header(self) -> str:
        where = self.file or "<input>"
        if self.line is not None:
            where += f":{self.line}"
            if self.col is not None:
                where += f":{self.col}"
        return f"{where}: {self.severity}[{self.code}]: {self.message}"

    def render(self, source: str | None = None) -> str:
        """Render as text; with the source text, show the offending line and a caret."""
        out = [self.header()]
        if source is not None and self.line is not None:
            text = _source_line(source, self.line)
            if text is not None:
                num = str(self.line)
                pad = " " * len(num)
                col = max(1, self.col or 1)
                if self.end_line in (None, self.line) and self.end_col and self.end_col > col:
                    width = self.end_col - col
                else:
                    width = max(1, len(text.rstrip()) - col + 1)
                width = max(1, min(width, max(1, len(text) - col + 1)))
                if len(text) > SHOWN_CHARS:  # a long line (a minified document): a window around the column
                    start = max(0, col - 1 - SHOWN_CHARS // 3)
                    shown = text[start:start + SHOWN_CHARS]
                    text = ("…" if start else "") + shown + ("…" if start + SHOWN_CHARS < len(text) else "")
                    col = col - start + (1 if start else 0)
                    width = max(1, min(width, len(shown) - (col - (2 if start else 1))))
                out.append(f" {pad} |")
                out.append(f" {num} | {text}")
                out.append(f" {pad} | {' ' * (col - 1)}{'^' * width}")
        for note in self.notes:
            out.append(f"  = note: {note}")
        if self.hint:
            out.append(f"  = hint: {self.hint}")
        return "\n".join(out)

    def to_json(self) -> dict:
        data = asdict(self)
        data["notes"] = list(self.notes)
        data["fix"] = self.fix.to_json() if self.fix is not None else None
        return {k: v for k, v in data.items() if v is not None and v != []}


SHOWN_CHARS = 160  # characters of a source line shown with a diagnostic


def _source_line(source: str, line: int) -> str | None:
    """Line ``line`` (1-based, lines end at newline) of ``source``, without splitting the whole text."""
    if line < 1:
        return None
    start = 0
    for _ in range(line - 1):
        start = source.find("\n", start) + 1
        if start == 0:
            return None
    end = source.find("\n", start)
    text = source[start:] if end < 0 else source[start:end]
    if end < 0 and not text and line > 1:
        return None
    return text.rstrip("\r")


def locate(issue: Issue, file: str | None, srcmap: Mapping[str, Span] | None, text: str | None = None,
           dsl: bool = False) -> Diagnostic:
    """Place an IR issue in its file, using the closest mapped ancestor of its pointer; with the file's
    ``text``, its IR change becomes a text edit where it can be placed exactly (F-FIX)."""
    span = None
    if srcmap:
        pointer = issue.pointer
        while True:
            if pointer in srcmap:
                span = srcmap[pointer]
                break
            if not pointer:
                break
            pointer = pointer.rsplit("/", 1)[0]
    line = col = end_line = end_col = None
    if span is not None:
        line, col, end_line, end_col = span
    return Diagnostic(
        code=issue.code,
        message=issue.message,
        file=file,
        line=line,
        col=col,
        end_line=end_line,
        end_col=end_col,
        hint=issue.hint,
        severity=issue.severity,
        pointer=issue.pointer,
        fix=render_change(issue.change, text, srcmap or {}, dsl) if issue.change is not None else None,
    )


def json_pointer(*parts: object) -> str:
    """Build an RFC 6901 JSON Pointer from path parts."""
    return join(*parts)


def has_errors(diags: Sequence[Diagnostic | Issue]) -> bool:
    return any(d.severity == "error" for d in diags)
