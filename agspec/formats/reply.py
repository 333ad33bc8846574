"""The one decoder of what a simulator sends (F-PROTOCOL-LINES, F-VALUES, F-PROTOCOL-ERRORS, F-LIMITS-REPLIES).

A reply is one line of a simulator's standard output, its bytes as read without the newline (an
in-process adapter's reply is encoded to such a line first).  :func:`decode_line` turns it into a
JSON value or raises :class:`LineError` with the F-PROTOCOL-ERRORS code that names the fault:

* ``bad_encoding`` — the bytes are not UTF-8, or a string holds a lone surrogate (``\\ud800``),
  which no UTF-8 text can carry (I-JSON, RFC 7493 §2.1);
* ``malformed_json`` — a blank line, or anything but one JSON text on the line;
* ``duplicate_key`` — an object names a member twice (readers disagree on which one counts);
* ``non_finite`` — ``NaN``, ``Infinity``, ``-Infinity``;
* ``out_of_range`` — an integer beyond ±(2^53 − 1), or a number beyond binary64 (``1e400``;
  RES-NUMBER-RANGE);
* ``too_deep`` — nesting the decoder cannot follow.  The nesting limit
  (:data:`~agspec.formats.jsonl.MAX_DEPTH`) is the caller's: the reply's shape
  (:mod:`agspec.formats.shape`) holds every member to it in the same walk that checks the types.

The cost is one C-speed JSON decode whose hooks see every object (duplicate keys) and every number
(the F-VALUES range); the surrogate check runs only on lines that hold a surrogate escape.  Every reply, whichever adapter brought it and whether or not a golden trace
matched it, is accepted or refused by this one function (RES-GOLDEN-IDENTITY).
"""

from __future__ import annotations

import json
import math
import re
from typing import Any

from agspec.formats.jsonl import MAX_DEPTH
from agspec.formats.shape import MAX_SAFE_INTEGER

# a surrogate escape: where a string may hold a lone one (the careful check runs)
_SURROGATE = re.compile(r"\\u[dD][89a-fA-F]")


class LineError(ValueError):
    """A reply line that is not one acceptable JSON value: ``code`` (F-PROTOCOL-ERRORS) and why."""

    def __init__(self, code: str, message: str):
        super().__init__(message)
        self.code, self.message = code, message


class _Refused(Exception):
    def __init__(self, code: str, message: str):
        self.code, self.message = code, message


def _pairs(items: list[tuple[str, Any]]) -> dict[str, Any]:
    out = dict(items)
    if len(out) != len(items):
        seen: set[str] = set()
        for key, _ in items:
            if key in seen:
                raise _Refused("duplicate_key", f"the member `{_show(key)}` appears twice in one object")
            seen.add(key)
    return out


def _integer(text: str) -> int:
    if len(text.lstrip("-")) > 16 or abs(int(text)) > MAX_SAFE_INTEGER:
        raise _Refused("out_of_range", f"the integer {_show(text)} is beyond ±(2^53 − 1) (F-VALUES)")
    return int(text)


def _float(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise _Refused("out_of_range", f"the number {_show(text)} is beyond binary64 (F-VALUES)")
    return value


def _constant(name: str) -> Any:
    raise _Refused("non_finite", f"{name} is not JSON (no NaN or Infinity)")


# every number through a hook: a reply holds a few hundred, so this costs less than any scan of the
# text for suspect numbers would
_DECODER = json.JSONDecoder(object_pairs_hook=_pairs, parse_constant=_constant, parse_int=_integer,
                            parse_float=_float)


def _show(text: str, limit: int = 40) -> str:
    return text if len(text) <= limit else text[:limit - 3] + "..."


def decode_line(data: bytes) -> Any:
    """The JSON value of one reply line (its bytes, without the newline); :class:`LineError` otherwise."""
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise LineError("bad_encoding", f"not UTF-8 (byte 0x{data[exc.start]:02x} at offset {exc.start})") from None
    if not text.strip(" \t\r"):
        raise LineError("malformed_json", "a blank line is not a reply (one JSON object per line)")
    try:
        value = _DECODER.decode(text)
    except _Refused as exc:
        raise LineError(exc.code, exc.message) from None
    except json.JSONDecodeError as exc:
        raise LineError("malformed_json", f"not one JSON text ({exc.msg} at column {exc.colno})") from None
    except RecursionError:
        raise LineError("too_deep", f"nested deeper than {MAX_DEPTH} levels") from None
    if "\\u" in text and _SURROGATE.search(text):
        try:  # a lone surrogate escape decodes to a str that no UTF-8 text can hold
            json.dumps(value, ensure_ascii=False).encode("utf-8")
        except UnicodeEncodeError:
            raise LineError("bad_encoding", "a string holds a lone surrogate (\\ud800-\\udfff), which is not "
                                            "Unicode text (I-JSON)") from None
        except RecursionError:
            raise LineError("too_deep", f"nested deeper than {MAX_DEPTH} levels") from None
    return value


def encode_in_process(value: Any) -> bytes:
    """An in-process adapter's reply as the line a process would send (compact JSON, UTF-8), so that it
    is decoded by :func:`decode_line` like any other; :class:`LineError` when it has no such line."""
    try:
        text = json.dumps(value, separators=(",", ":"), ensure_ascii=False, allow_nan=False)
    except RecursionError:
        raise LineError("too_deep", f"nested deeper than {MAX_DEPTH} levels") from None
    except ValueError as exc:  # NaN / Infinity
        raise LineError("non_finite", f"not plain JSON: {exc}") from None
    except TypeError as exc:
        raise LineError("malformed_json", f"not plain JSON: {exc}") from None
    try:
        return text.encode("utf-8")
    except UnicodeEncodeError:
        raise LineError("bad_encoding", "a string holds a lone surrogate, which is not Unicode text (I-JSON)") from None


__all__ = ["LineError", "decode_line", "encode_in_process"]
