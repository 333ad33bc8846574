"""Bounded reading of every untrusted input (spec F-LIMITS, F-EXIT-CODES).

agspec reads files other people wrote: DSL and IR documents, instance files, traces, reports,
expectation files. Everything here enforces the documented limits *before* the expensive work and
raises one error type, :class:`InputError`, that carries the code, the location, the limit that was
hit and how to raise it:

* the file type is checked before opening, so a FIFO or a device never blocks (AG002);
* the size is checked before reading (AG006, ``AGSPEC_MAX_BYTES``);
* the bytes are decoded as UTF-8 with a located error (AG007);
* JSON is parsed with nesting-depth, number-length and string-length limits, duplicate keys are
  rejected (AG206), and so are ``NaN``, ``Infinity`` and numbers that overflow to them (AG003);
* YAML is safe-loaded from a composed node graph that is checked first: expanded node count (alias
  bombs), depth, scalar lengths, duplicate keys and recursive aliases.

The locator that turns a violation into ``line:col`` runs only on the error path.
"""

from __future__ import annotations

import json
import math
import os
import re
import stat
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Any, Iterator, Mapping

import yaml

from agspec.formats.diagnostics import Diagnostic

# Exit categories of F-EXIT-CODES (mirrored from agspec.cli.common, which sits above this layer).
EXIT_INVALID = 1
EXIT_USAGE = 2
# Codes of faults that are usage or I/O errors (exit 2): the file is missing or cannot be read as a
# regular file. Every other code is about the content: invalid input (exit 1).
IO_CODES = frozenset({"AG001", "AG002"})

_SUFFIX = {"": 1, "K": 1024, "M": 1024**2, "G": 1024**3}


@dataclass(frozen=True)
class Limits:
    """The F-LIMITS limits; each can be raised with its environment variable (``Limits.ENV``)."""

    max_bytes: int = 256 * 1024**2  # one file (a document, a trace, a report)
    max_record_bytes: int = 32 * 1024**2  # one JSON Lines record (a trace or report line)
    max_depth: int = 64  # nesting of arrays/objects (JSON) or collections (YAML)
    max_number_chars: int = 64  # characters of one number literal
    max_string_chars: int = 1024**2  # characters of one string
    max_name_chars: int = 256  # characters of one DSL name or number
    max_yaml_nodes: int = 100_000  # YAML nodes after alias expansion
    max_nodes: int = 1_000_000  # values of one JSON document or JSON Lines record (bounded time)
    max_records: int = 1_000_000  # records of one JSON Lines file
    max_dsl_tokens: int = 100_000  # tokens of one DSL document

    ENV = {
        "max_bytes": "AGSPEC_MAX_BYTES",
        "max_record_bytes": "AGSPEC_MAX_RECORD_BYTES",
        "max_depth": "AGSPEC_MAX_DEPTH",
        "max_number_chars": "AGSPEC_MAX_NUMBER_CHARS",
        "max_string_chars": "AGSPEC_MAX_STRING_CHARS",
        "max_name_chars": "AGSPEC_MAX_NAME_CHARS",
        "max_yaml_nodes": "AGSPEC_MAX_YAML_NODES",
        "max_nodes": "AGSPEC_MAX_NODES",
        "max_records": "AGSPEC_MAX_RECORDS",
        "max_dsl_tokens": "AGSPEC_MAX_DSL_TOKENS",
    }

    @classmethod
    def from_env(cls, environ: Mapping[str, str] | None = None) -> "Limits":
        """The defaults, raised (or lowered) by the ``AGSPEC_MAX_*`` variables (F-LIMITS)."""
        environ = os.environ if environ is None else environ
        changes: dict[str, int] = {}
        for f in fields(cls):
            var = cls.ENV[f.name]
            text = environ.get(var)
            if text is None or not text.strip():
                continue
            m = re.fullmatch(r"\s*([0-9]{1,15})\s*([KMG]?)i?B?\s*", text, re.IGNORECASE)
            if not m or int(m.group(1)) < 1:
                raise InputError("AG006", f"{var}={text!r} is not a positive integer (optionally with K, M or G)",
                                 exit_code=EXIT_USAGE, hint=f"for example {var}={getattr(cls, f.name) * 2}")
            changes[f.name] = int(m.group(1)) * _SUFFIX[m.group(2).upper()]
        return replace(cls(), **changes) if changes else cls()


class InputError(Exception):
    """An input agspec refuses: code (F-CODES), location, the limit hit, and how to raise it."""

    def __init__(self, code: str, message: str, *, file: str | None = None, line: int | None = None,
                 col: int | None = None, pointer: str | None = None, limit: str | None = None,
                 hint: str | None = None, exit_code: int = EXIT_INVALID) -> None:
        super().__init__(message)
        self.code, self.message, self.file = code, message, file
        self.line, self.col, self.pointer = line, col, pointer
        self.limit, self.hint, self.exit_code = limit, hint, exit_code

    def located(self, file: str | None = None, line_offset: int = 0) -> "InputError":
        """The same error placed in ``file`` (and shifted by ``line_offset`` lines, for JSON Lines)."""
        line = self.line + line_offset if self.line is not None else (line_offset or None)
        return InputError(self.code, self.message, file=file if file is not None else self.file, line=line,
                          col=self.col, pointer=self.pointer, limit=self.limit, hint=self.hint,
                          exit_code=self.exit_code)

    def diagnostic(self) -> Diagnostic:
        end = self.col + 1 if self.col is not None else None
        return Diagnostic(code=self.code, message=self.message, file=self.file, line=self.line, col=self.col,
                          end_line=self.line if self.line is not None else None, end_col=end, hint=self.hint,
                          pointer=self.pointer)

    def __str__(self) -> str:
        text = self.diagnostic().header()
        return f"{text} ({self.hint})" if self.hint else text


def _limit_error(limit: str, message: str, limits: Limits, **where: Any) -> InputError:
    var = Limits.ENV[limit]
    return InputError("AG006", message, limit=limit,
                      hint=f"limit {limit} = {getattr(limits, limit)}; raise it with {var}=N (F-LIMITS)", **where)


# --------------------------------------------------------------------------- files


def check_file(path: str | Path, limits: Limits | None = None) -> int:
    """The size of ``path`` if it is a regular file within ``max_bytes``; else InputError (F-LIMITS).

    ``os.stat`` never blocks, unlike ``open`` on a FIFO, so special files are refused before reading.
    """
    limits = limits or Limits.from_env()
    file = str(path)
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise InputError("AG001", f"file not found: {file}", file=file, hint="check the path",
                         exit_code=EXIT_USAGE) from None
    except OSError as exc:
        raise InputError("AG002", f"cannot read {file}: {exc.strerror or exc}", file=file,
                         exit_code=EXIT_USAGE) from None
    if stat.S_ISDIR(st.st_mode):
        raise InputError("AG002", f"cannot read {file}: it is a directory", file=file, exit_code=EXIT_USAGE)
    if not stat.S_ISREG(st.st_mode):
        raise InputError("AG002", f"cannot read {file}: not a regular file (a FIFO, socket or device)", file=file,
                         hint="agspec reads regular files only, so that reading is bounded", exit_code=EXIT_USAGE)
    if st.st_size > limits.max_bytes:
        raise _limit_error("max_bytes", f"{file} has {st.st_size} bytes, more than the limit {limits.max_bytes}",
                           limits, file=file)
    return st.st_size


def read_bytes(path: str | Path, limits: Limits | None = None) -> bytes:
    """The bytes of a regular file within the size limit (a file that grows while read is cut off)."""
    limits = limits or Limits.from_env()
    check_file(path, limits)
    try:
        with open(path, "rb") as fh:
            data = fh.read(limits.max_bytes + 1)
    except OSError as exc:
        raise InputError("AG002", f"cannot read {path}: {exc.strerror or exc}", file=str(path),
                         exit_code=EXIT_USAGE) from None
    if len(data) > limits.max_bytes:
        raise _limit_error("max_bytes", f"{path} has more than {limits.max_bytes} bytes", limits, file=str(path))
    return data


def decode(data: bytes, file: str | None = None) -> str:
    """UTF-8 text (a leading BOM dropped); AG007 at the line and column of the first bad byte."""
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        col = exc.start - (data.rfind(b"\n", 0, exc.start) + 1) + 1
        raise InputError("AG007", f"not UTF-8 text (byte 0x{data[exc.start]:02x})", file=file, line=line, col=col,
                         hint="save the file as UTF-8") from None
    return text.removeprefix("\ufeff")


def read_text(path: str | Path, limits: Limits | None = None) -> str:
    """UTF-8 text of a regular file within the limits."""
    return decode(read_bytes(path, limits), str(path))


# --------------------------------------------------------------------------- JSON


class _Violation(Exception):
    """Raised inside the json hooks; turned into a located InputError by the caller."""

    def __init__(self, kind: str, detail: str = "") -> None:
        super().__init__(kind)
        self.kind, self.detail = kind, detail


def _decoder(limits: Limits) -> json.JSONDecoder:
    def pairs(items: list[tuple[str, Any]]) -> dict[str, Any]:
        out = dict(items)
        if len(out) != len(items):
            seen: set[str] = set()
            for key, _ in items:
                if key in seen:
                    raise _Violation("duplicate", key)
                seen.add(key)
        return out

    def number(text: str, convert: Any) -> Any:
        if len(text) > limits.max_number_chars:
            raise _Violation("number")
        value = convert(text)
        if isinstance(value, float) and not math.isfinite(value):
            raise _Violation("overflow", text)
        return value

    def constant(name: str) -> Any:
        raise _Violation("constant", name)

    return json.JSONDecoder(object_pairs_hook=pairs, parse_int=lambda t: number(t, int),
                            parse_float=lambda t: number(t, float), parse_constant=constant)


# One token of JSON text, for the error-path locator: a string, a number, a bracket, a colon or a comma.
TOKEN = re.compile(r'"(?:[^"\\]|\\.)*"|-?[0-9][0-9.eE+-]*|[\[\]{}:,]')


def position(text: str, offset: int) -> tuple[int, int]:
    line = text.count("\n", 0, offset) + 1
    return line, offset - (text.rfind("\n", 0, offset) + 1) + 1


def _locate(text: str, kind: str, limits: Limits, detail: str = "") -> int | None:
    """Offset of the first token that breaks ``kind`` (walks the tokens once; error path only)."""
    stack: list[set[str] | None] = []  # per open container: the keys seen (objects) or None (arrays)
    expect_key = False
    for m in TOKEN.finditer(text):
        tok = m.group()
        first = tok[0]
        if first in "[{":
            stack.append(set() if first == "{" else None)
            expect_key = first == "{"
            if kind == "depth" and len(stack) > limits.max_depth:
                return m.start()
        elif first in "]}":
            if stack:
                stack.pop()
            expect_key = False
        elif first == ",":
            expect_key = bool(stack) and stack[-1] is not None
        elif first == ":":
            expect_key = False
        elif first == '"':
            if expect_key and stack and stack[-1] is not None:
                try:
                    key = json.loads(tok)
                except ValueError:
                    key = tok
                if kind == "duplicate" and key in stack[-1]:
                    return m.start()
                stack[-1].add(key)
            if kind == "string" and len(tok) - 2 > limits.max_string_chars:
                return m.start()
            expect_key = False
        else:
            if kind == "number" and len(tok) > limits.max_number_chars:
                return m.start()
            if kind == "overflow" and tok == detail:
                return m.start()
    for name in ("NaN", "Infinity", "-Infinity"):
        if kind == "constant" and detail == name:
            found = re.search(r"(?<![\w\"])" + re.escape(name), text)
            return found.start() if found else None
    return None


# A JSON string literal (the unrolled form: one step per run of plain characters), removed before the
# structural characters are counted (count_values).
_STRING = re.compile(r'"[^"\\]*(?:\\.[^"\\]*)*"')


def _structural(text: str) -> int:
    return text.count(",") + text.count("[") + text.count("{") + 1


def count_values(text: str, bound: int | None = None) -> int:
    """An upper bound on the number of values in a JSON text (F-LIMITS ``max_nodes``): every value
    after the first of an array or object follows a comma, and every container opens with a bracket,
    so values <= commas + brackets + 1 outside strings.  The characters are counted at C speed over the
    whole text first; only when that exceeds ``bound`` are the strings (whose commas do not count)
    taken out first."""
    found = _structural(text)
    if (bound is not None and found <= bound) or '"' not in text:
        return found
    return _structural(_STRING.sub("", text))


def _check_count(text: str, file: str | None, limits: Limits) -> None:
    """F-LIMITS ``max_nodes``, before any parsing: a value takes at least two characters but the last,
    so a text of at most 2 * max_nodes characters cannot exceed it and is not scanned at all."""
    if len(text) <= 2 * limits.max_nodes:
        return
    found = count_values(text, limits.max_nodes)
    if found > limits.max_nodes:
        raise _limit_error("max_nodes", f"about {found} JSON values, more than the limit {limits.max_nodes}", limits,
                           file=file, line=1, col=1)


def parse_json(text: str, file: str | None = None, limits: Limits | None = None) -> Any:
    """The value of a JSON text within the limits (F-LIMITS); InputError at the offending token."""
    limits = limits or Limits.from_env()
    _check_count(text, file, limits)

    def located(kind: str, message: str, limit: str | None = None, detail: str = "",
                code: str = "AG003", hint: str | None = None) -> InputError:
        offset = _locate(text, kind, limits, detail)
        line, col = position(text, offset) if offset is not None else (None, None)
        if limit is not None:
            return _limit_error(limit, message, limits, file=file, line=line, col=col)
        return InputError(code, message, file=file, line=line, col=col, hint=hint)

    try:
        value = _decoder(limits).decode(text)
    except _Violation as v:
        if v.kind == "duplicate":
            raise located("duplicate", f"duplicate key `{v.detail}`", code="AG206",
                          hint="JSON readers disagree on duplicate keys; keep one") from None
        if v.kind == "number":
            raise located("number", f"a number longer than {limits.max_number_chars} characters",
                          "max_number_chars") from None
        if v.kind == "overflow":
            raise located("overflow", f"number {v.detail[:40]} is too large for a 64-bit float",
                          detail=v.detail) from None
        raise located("constant", f"{v.detail} is not valid JSON", detail=v.detail,
                      hint="JSON has no NaN or Infinity; write a finite number or null") from None
    except json.JSONDecodeError as exc:
        raise InputError("AG003", f"not valid JSON: {exc.msg}", file=file, line=exc.lineno, col=exc.colno) from None
    except RecursionError:
        raise located("depth", f"nesting deeper than {limits.max_depth} levels", "max_depth") from None
    problem = _check_value(value, limits)
    if problem is not None:
        kind, message, limit = problem
        raise located(kind, message, limit)
    return value


def _check_value(value: Any, limits: Limits) -> tuple[str, str, str] | None:
    """Depth and string length of a parsed value (iterative: never recurses on hostile depth)."""
    stack: list[tuple[Any, int]] = [(value, 0)]
    while stack:
        node, depth = stack.pop()
        if isinstance(node, dict):
            children: Any = node.values()
            if any(len(k) > limits.max_string_chars for k in node):
                return "string", f"a string longer than {limits.max_string_chars} characters", "max_string_chars"
        elif isinstance(node, list):
            children = node
        else:
            if isinstance(node, str) and len(node) > limits.max_string_chars:
                return "string", f"a string longer than {limits.max_string_chars} characters", "max_string_chars"
            continue
        if depth + 1 > limits.max_depth:
            return "depth", f"nesting deeper than {limits.max_depth} levels", "max_depth"
        stack.extend((child, depth + 1) for child in children)
    return None


def load_json(path: str | Path, limits: Limits | None = None) -> Any:
    """A JSON file read and parsed within the limits."""
    limits = limits or Limits.from_env()
    return parse_json(read_text(path, limits), str(path), limits)


def iter_json_lines(path: str | Path, limits: Limits | None = None) -> Iterator[tuple[int, Any]]:
    """``(line number, value or InputError)`` for each non-blank line of a JSON Lines file.

    The file is checked first (type, size) and read line by line; a line longer than
    ``max_record_bytes`` is reported without being held in memory whole.
    """
    limits = limits or Limits.from_env()
    file = str(path)
    check_file(path, limits)
    try:
        fh = open(path, "rb")
    except OSError as exc:
        raise InputError("AG002", f"cannot read {file}: {exc.strerror or exc}", file=file,
                         exit_code=EXIT_USAGE) from None
    with fh:
        lineno = records = 0
        while True:
            raw = fh.readline(limits.max_record_bytes + 1)
            if not raw:
                return
            lineno += 1
            if raw.strip():
                records += 1
                if records > limits.max_records:  # F-LIMITS: the rest of the file is not read
                    yield lineno, _limit_error("max_records", f"more than {limits.max_records} records", limits,
                                               file=file, line=lineno, col=1)
                    return
            if len(raw) > limits.max_record_bytes and not raw.endswith(b"\n"):
                while raw and not raw.endswith(b"\n"):  # skip the rest of the overlong line
                    raw = fh.readline(limits.max_record_bytes + 1)
                yield lineno, _limit_error("max_record_bytes", f"a record longer than {limits.max_record_bytes} "
                                           "bytes", limits, file=file, line=lineno, col=1)
                continue
            try:
                text = decode(raw, file)
                if not text.strip():
                    continue
                yield lineno, parse_json(text, file, limits)
            except InputError as exc:
                yield lineno, exc.located(file, lineno - 1)


# --------------------------------------------------------------------------- YAML


def parse_yaml(text: str, file: str | None = None, limits: Limits | None = None) -> Any:
    """The value of a YAML text (safe types only) within the limits (F-LIMITS).

    The document is composed into nodes first (:func:`compose_yaml`: the node graph is checked,
    aliases expanded in the count, so an alias bomb is refused before any object is built), then
    constructed.
    """
    node = compose_yaml(text, file, limits)
    if node is None:
        return None
    try:
        value = yaml.SafeLoader(text).construct_document(node)
    except (yaml.YAMLError, ValueError, OverflowError) as exc:
        mark = getattr(exc, "problem_mark", None)
        raise InputError("AG008", f"not valid YAML: {getattr(exc, 'problem', None) or exc}", file=file,
                         line=mark.line + 1 if mark else None, col=mark.column + 1 if mark else None) from None
    bad = _non_finite(value)
    if bad is not None:
        raise InputError("AG008", f"{bad} is not allowed: agspec files hold finite numbers", file=file)
    return value


def compose_yaml(text: str, file: str | None = None, limits: Limits | None = None) -> yaml.Node | None:
    """The node graph of a YAML text within the limits (F-LIMITS), or None for an empty document: the
    one YAML reader of every agspec file (the nodes keep their lines for located messages).

    Events are counted before anything is composed; the graph is checked before anything is built.
    """
    limits = limits or Limits.from_env()
    _count_yaml_events(text, file, limits)
    try:
        node = yaml.compose(text, Loader=_YAML_LOADER)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        raise InputError("AG008", f"not valid YAML: {getattr(exc, 'problem', None) or exc}", file=file,
                         line=mark.line + 1 if mark else None, col=mark.column + 1 if mark else None) from None
    except RecursionError:
        raise _limit_error("max_depth", f"nesting deeper than {limits.max_depth} levels", limits, file=file) from None
    if node is not None:
        check_yaml_nodes(node, file, limits)
    return node


# LibYAML's parser where PyYAML has it (C speed), else the pure-Python one: same events, same nodes.
_YAML_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


def _count_yaml_events(text: str, file: str | None, limits: Limits) -> None:
    """F-LIMITS ``max_yaml_nodes`` before any node is composed: the parser's events are counted as
    they come and parsing stops past the limit, so a huge document costs no more than the limit.
    (Aliases are counted expanded afterwards, by :func:`check_yaml_nodes`.)"""
    if len(text) <= limits.max_yaml_nodes:  # an event takes at least one character
        return
    try:
        for count, event in enumerate(yaml.parse(text, Loader=_YAML_LOADER), 1):
            if count > 2 * limits.max_yaml_nodes + 4:  # a collection has a start and an end event
                mark = getattr(event, "start_mark", None)
                raise _limit_error("max_yaml_nodes", f"more than {limits.max_yaml_nodes} YAML nodes", limits,
                                   file=file, line=mark.line + 1 if mark else None,
                                   col=mark.column + 1 if mark else None)
    except yaml.YAMLError:
        return  # composing reports the syntax error at its place


def check_yaml_nodes(root: yaml.Node, file: str | None, limits: Limits) -> None:
    """Expanded size, depth, scalar length, duplicate keys and alias cycles of a composed YAML graph."""
    def at(node: yaml.Node) -> dict[str, Any]:
        return {"file": file, "line": node.start_mark.line + 1, "col": node.start_mark.column + 1}

    sizes: dict[int, int] = {}  # expanded node count per (shared) node
    # iterative post-order walk; "active" detects an alias that contains itself
    active: set[int] = set()
    stack: list[tuple[yaml.Node, int, bool]] = [(root, 1, False)]
    while stack:
        node, depth, done = stack.pop()
        key = id(node)
        if done:
            active.discard(key)
            kids = _children(node)
            sizes[key] = 1 + sum(sizes[id(k)] for k in kids)
            if sizes[key] > limits.max_yaml_nodes:
                raise _limit_error("max_yaml_nodes", f"more than {limits.max_yaml_nodes} YAML nodes once aliases "
                                   "are expanded", limits, **at(node))
            continue
        if key in sizes:
            continue
        if key in active:
            raise InputError("AG008", "a YAML alias that contains itself", **at(node))
        if depth > limits.max_depth:
            raise _limit_error("max_depth", f"nesting deeper than {limits.max_depth} levels", limits, **at(node))
        if isinstance(node, yaml.ScalarNode):
            if len(node.value) > limits.max_string_chars:
                raise _limit_error("max_string_chars", f"a value longer than {limits.max_string_chars} characters",
                                   limits, **at(node))
            if node.tag.endswith((":int", ":float")) and len(node.value) > limits.max_number_chars:
                raise _limit_error("max_number_chars", f"a number longer than {limits.max_number_chars} characters",
                                   limits, **at(node))
            sizes[key] = 1
            continue
        if isinstance(node, yaml.MappingNode):
            seen: set[str] = set()
            for k, _ in node.value:
                if isinstance(k, yaml.ScalarNode):
                    if k.value in seen:
                        raise InputError("AG206", f"duplicate key `{k.value}`", hint="keep one", **at(k))
                    seen.add(k.value)
        active.add(key)
        stack.append((node, depth, True))
        stack.extend((k, depth + 1, False) for k in _children(node))


def _children(node: yaml.Node) -> list[yaml.Node]:
    if isinstance(node, yaml.MappingNode):
        return [n for pair in node.value for n in pair]
    if isinstance(node, yaml.SequenceNode):
        return list(node.value)
    return []


def _non_finite(value: Any) -> str | None:
    stack = [value]
    while stack:
        node = stack.pop()
        if isinstance(node, float) and not math.isfinite(node):
            return str(node)
        if isinstance(node, dict):
            stack.extend(node.values())
        elif isinstance(node, list):
            stack.extend(node)
    return None


# --------------------------------------------------------------------------- DSL text

_LONG_NAME = "[A-Za-z0-9_.-]{%d,}"


# One DSL token: a name or number, a string, a comment or one punctuation character.
_DSL_TOKEN = re.compile(r'#[^\n]*|"(?:[^"\\\n]|\\.)*"|[A-Za-z0-9_.-]+|[^\sA-Za-z0-9_.-]')


def check_dsl_text(text: str, file: str | None = None, limits: Limits | None = None) -> None:
    """DSL names and numbers within ``max_name_chars`` and the document within ``max_dsl_tokens``
    (checked before the parser sees the text)."""
    limits = limits or Limits.from_env()
    m = re.search(_LONG_NAME % (limits.max_name_chars + 1), text)
    if m is not None:
        line, col = position(text, m.start())
        raise _limit_error("max_name_chars", f"a name or number longer than {limits.max_name_chars} characters",
                           limits, file=file, line=line, col=col)
    # a token takes at least one character and most two (a name and a separator): short texts are not scanned
    if len(text) > limits.max_dsl_tokens:
        count = 0
        for count, tok in enumerate(_DSL_TOKEN.finditer(text), 1):
            if count > limits.max_dsl_tokens:
                line, col = position(text, tok.start())
                raise _limit_error("max_dsl_tokens", f"more than {limits.max_dsl_tokens} tokens in one document",
                                   limits, file=file, line=line, col=col)


__all__ = ["InputError", "Limits", "check_dsl_text", "check_file", "count_values", "decode", "iter_json_lines",
           "load_json", "parse_json", "TOKEN", "position", "parse_yaml", "read_bytes", "read_text"]
