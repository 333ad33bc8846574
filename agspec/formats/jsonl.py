"""JSON Lines, the container of every record stream agspec exchanges (F-TRACE, F-REPORT).

One canonical line (:func:`dumps`: sorted keys, no spaces, UTF-8, shortest float repr, no NaN), one
streaming reader (:func:`iter_lines`: one :class:`Line` per non-blank line, a line that is not UTF-8
or not JSON is reported, never raised) and one writer that flushes every line, so that a crash loses
nothing already written.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any, Callable, Iterable, Iterator, Mapping


def dumps(record: Mapping[str, Any], default: Callable[[Any], Any] | None = None) -> str:
    """One canonical JSON line: sorted keys, no spaces, UTF-8, shortest float repr."""
    return json.dumps(record, sort_keys=True, separators=(",", ":"), ensure_ascii=False, allow_nan=False,
                      default=default)


@dataclass(frozen=True)
class Line:
    """One non-blank line: its parsed value, or why it has none (``code`` AG002 not UTF-8, AG003 not JSON)."""

    lineno: int
    value: Any = None
    code: str | None = None
    error: str | None = None
    col: int | None = None

    @property
    def ok(self) -> bool:
        return self.code is None


def _decode(lineno: int, raw: str | bytes) -> Line:
    if isinstance(raw, bytes):
        try:
            raw = raw.decode("utf-8")
        except UnicodeDecodeError as exc:
            return Line(lineno, code="AG002", error=f"line is not UTF-8 text (byte {raw[exc.start]:#04x})",
                        col=exc.start + 1)
    try:
        return Line(lineno, json.loads(raw))
    except json.JSONDecodeError as exc:
        return Line(lineno, code="AG003", error=f"not valid JSON: {exc.msg}", col=exc.colno)


def iter_lines(source: str | Path | Iterable[str | bytes]) -> Iterator[Line]:
    """The non-blank lines of a file (a path, read in binary and streamed) or of an iterable of lines.

    Opening a path may raise ``OSError``; the caller reports it.
    """
    if isinstance(source, (str, Path)):
        with open(source, "rb") as fh:
            yield from iter_lines(fh)
        return
    for lineno, raw in enumerate(source, start=1):
        if raw.strip():
            yield _decode(lineno, raw)


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
            self._fh = open(target, "w", encoding="utf-8")
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
