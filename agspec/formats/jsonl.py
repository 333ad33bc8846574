"""JSON Lines, the container of every record stream agspec exchanges (F-TRACE, F-REPORT).

One canonical line (:func:`dumps`: sorted keys, no spaces, UTF-8, shortest float repr, no NaN), one
streaming reader (:func:`iter_lines`: one :class:`Line` per non-blank line, a line that is not UTF-8
or not JSON, or breaks a limit, is reported, never raised) and one writer that flushes every line, so that a crash loses
nothing already written.

Reading is bounded (F-LIMITS, :mod:`agspec.formats.limits`): a path is checked for its type and size
before it is opened, each line is read at most ``max_record_bytes`` at a time and parsed within the
depth, number, string, duplicate-key and non-finite limits.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any, Callable, Iterable, Iterator, Mapping

from agspec.formats import limits as _limits
from agspec.formats.diagnostics import Diagnostic
from agspec.formats.output import Stream

try:  # the optional extra `fast`: the reference server's reply lines encoded about ten times faster
    import orjson
except ImportError:  # pragma: no cover - exercised by tests that hide it
    orjson = None


def dumps(record: Mapping[str, Any], default: Callable[[Any], Any] | None = None) -> str:
    """One canonical JSON line: sorted keys, no spaces, UTF-8, shortest float repr."""
    return json.dumps(record, sort_keys=True, separators=(",", ":"), ensure_ascii=False, allow_nan=False,
                      default=default)


def compact_bytes(value: Any) -> bytes:
    """One compact JSON text, UTF-8, in the value's own key order — the protocol's line encoding
    (F-PROTOCOL) of values agspec built itself and knows finite (the reference server's replies).
    With the ``fast`` extra it is orjson's; the JSON value is the same, only float spellings may
    differ (``1e-06`` / ``1e-6``), and a value orjson does not take (an integer beyond 64 bits)
    falls back to ``json``."""
    if orjson is not None:
        try:
            return orjson.dumps(value)
        except TypeError:
            pass
    return json.dumps(value, separators=(",", ":"), ensure_ascii=False, allow_nan=False).encode("utf-8")


MAX_DEPTH = 64  # F-PROTOCOL-ERRORS: no exchanged JSON value nests deeper (a state is < 10 levels)


class NonFinite(ValueError):
    """A JSON text with NaN / Infinity / -Infinity, which RFC 8259 does not allow (F-PROTOCOL-ERRORS)."""


class TooDeep(ValueError):
    """A JSON value nested deeper than :data:`MAX_DEPTH` (F-PROTOCOL-ERRORS)."""


def _no_constant(name: str) -> Any:
    raise NonFinite(f"non-finite number {name} (JSON has no NaN or Infinity)")


def depth(value: Any, limit: int = MAX_DEPTH) -> int:
    """Nesting depth of a decoded JSON value, level by level (no recursion); stops counting past ``limit``.

    One list of the containers of each level: a reply of a few hundred kilobytes is a handful of
    levels of thousands of containers, so the per-level comprehensions do the work at C speed."""
    level = [value] if type(value) is dict or type(value) is list else []
    d = 0
    while level:
        d += 1
        if d > limit:
            return d
        below: list[Any] = []
        for node in level:
            below += [x for x in (node.values() if type(node) is dict else node)
                      if type(x) is dict or type(x) is list]
        level = below
    return d


def loads(text: str | bytes) -> Any:
    """Decode one JSON text strictly: the one decoder for replies, traces, reproducers and expectations.

    Raises ``json.JSONDecodeError`` (not JSON), :class:`NonFinite` (NaN, Infinity) or :class:`TooDeep`
    (nested deeper than :data:`MAX_DEPTH`; also when the decoder itself runs out of stack).
    """
    try:
        value = json.loads(text, parse_constant=_no_constant)
    except RecursionError:
        raise TooDeep(f"nested deeper than {MAX_DEPTH} levels") from None
    if depth(value) > MAX_DEPTH:
        raise TooDeep(f"nested deeper than {MAX_DEPTH} levels")
    return value


@dataclass(frozen=True)
class Line:
    """One non-blank line: its parsed value, or why it has none (``code`` AG007 not UTF-8, AG003 not
    JSON, or the F-LIMITS code of the limit it breaks; ``hint`` says how to raise that limit)."""

    lineno: int
    value: Any = None
    code: str | None = None
    error: str | None = None
    col: int | None = None
    hint: str | None = None

    @property
    def ok(self) -> bool:
        return self.code is None

    def diagnostic(self, file: str | None) -> Diagnostic:
        """The problem of a line that is not ``ok``, located in ``file``."""
        return Diagnostic(str(self.code), str(self.error), file=file, line=self.lineno, col=self.col, hint=self.hint)

    def describe(self, file: str | None) -> str:
        """``file:line:col: error[code]: message (how to raise the limit)``, like a limits error."""
        text = self.diagnostic(file).header()
        return f"{text} ({self.hint})" if self.hint else text


def _line(lineno: int, value: Any) -> Line:
    if isinstance(value, _limits.InputError):
        return Line(lineno, code=value.code, error=value.message, col=value.col, hint=value.hint)
    return Line(lineno, value)


def iter_lines(source: str | Path | Iterable[str | bytes]) -> Iterator[Line]:
    """The non-blank lines of a file (a path, read in binary and streamed) or of an iterable of lines.

    A path that is missing, not a regular file or over the size limit raises
    :class:`agspec.formats.limits.InputError` (its ``exit_code`` says usage or invalid input); the
    caller reports it.
    """
    if isinstance(source, (str, Path)):
        for lineno, value in _limits.iter_json_lines(source):
            yield _line(lineno, value)
        return
    bounds = _limits.Limits.from_env()
    for lineno, raw in enumerate(source, start=1):
        if not raw.strip():
            continue
        try:  # lines already in memory: their size was bounded when they were read
            text = _limits.decode(raw) if isinstance(raw, bytes) else raw
            yield Line(lineno, _limits.parse_json(text, None, bounds))
        except _limits.InputError as exc:
            yield _line(lineno, exc)


def read_values(source: str | Path | Iterable[str | bytes]) -> list[Any]:
    """The values of the leading well-formed lines; the first malformed line ends the stream (a
    truncated write), which the structure checks then report."""
    out = []
    for line in iter_lines(source):
        if not line.ok:
            break
        out.append(line.value)
    return out


class LineWriter:
    """Writes records one canonical line at a time, flushing each; ``None`` writes nothing."""

    def __init__(self, target: str | Path | IO[str] | None, default: Callable[[Any], Any] | None = None):
        self._default = default
        self._owned = False
        self._fh: IO[str] | None = None
        if target is None:
            return
        if hasattr(target, "write"):
            self._fh = target  # type: ignore[assignment]
        else:
            self._fh = Stream(target)  # F-OUTPUT-FAILURES: an OSError names the file
            self._owned = True

    def write(self, record: Mapping[str, Any]) -> None:
        if self._fh is None:
            return
        self._fh.write(dumps(record, self._default) + "\n")
        self._fh.flush()

    def close(self) -> None:
        if self._owned and self._fh is not None:
            self._fh.close()
        self._fh = None

    def __enter__(self) -> "LineWriter":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


__all__ = ["dumps", "Line", "iter_lines", "read_values", "LineWriter"]
