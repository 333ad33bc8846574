"""Mutations of valid protocol reply lines: the generator of what a hostile or careless simulator sends
(F-PROTOCOL-LINES, F-PROTOCOL-SHAPE, F-VALUES, RES-GOLDEN-IDENTITY).

:func:`mutate` takes one reply the reference sent (its value) and a seeded ``random.Random`` and
returns a :class:`Mutation`: the bytes a simulator writes instead (one line, several lines, or
none), whether they still denote the same reply under F-VALUES (``same``: the verdict must not
change), and, for the faults with one right answer, the F-PROTOCOL-ERRORS code the harness must
give.  Mutation classes (:data:`CLASSES`):

* ``types``      — a value replaced by one of another type (null, a list, a string, a deep nest, ...);
* ``numbers``    — a number re-spelt (``6`` as ``6.0``, ``6e0``, ``60E-1``: same) or broken (5000
  digits, ``1e400``, ``-1e999``, ``2^53``, ``007``, ``+1``, ``NaN``);
* ``values``     — a share of all the numbers of the reply re-spelt (same: F-VALUES);
* ``keys``       — a member doubled (the wrong value first or last), dropped, added (with a hostile
  value) or renamed;
* ``encoding``   — invalid UTF-8, a lone surrogate escape, an ASCII letter escaped as ``\\u00XX``
  (same), a raw control character, a byte order mark;
* ``whitespace`` — JSON whitespace between tokens or around the line (same), other whitespace
  (``\\x0b``, ``\\x0c``, NBSP);
* ``lines``      — blank lines before the reply, the reply split over two lines, two replies on
  one line, a line too many, a truncated or empty line, a debug print before it.

Shared by ``tests/test_reply_generator.py`` (bounded) and ``benchmarks/fuzz_replies.py`` (long).
"""

from __future__ import annotations

import copy
import json
import random
from dataclasses import dataclass
from typing import Any

CLASSES = ("types", "numbers", "values", "keys", "encoding", "whitespace", "lines")


@dataclass(frozen=True)
class Mutation:
    """The bytes sent instead of one reply line (``\\n`` separates lines; no final newline)."""

    klass: str
    label: str
    data: bytes
    same: bool = False  # the same reply under F-VALUES: the verdict must be the unmutated one
    code: str | None = None  # the one right F-PROTOCOL-ERRORS code, where there is one


class Raw:
    """Bytes written verbatim where a value goes."""

    def __init__(self, data: bytes):
        self.data = data


class Pairs:
    """An object written member by member (members may repeat)."""

    def __init__(self, pairs: list[tuple[Any, Any]]):
        self.pairs = pairs


def dump(value: Any, ws: Any = None) -> bytes:
    """Compact JSON bytes of ``value`` (Raw and Pairs written as they say); ``ws(rng)`` supplies the
    whitespace between tokens (None: none)."""
    out: list[bytes] = []
    gap = (lambda: ws()) if ws is not None else (lambda: b"")

    def key(k: Any) -> bytes:
        return k.data if isinstance(k, Raw) else json.dumps(k, ensure_ascii=False).encode("utf-8", "surrogatepass")

    def walk(v: Any) -> None:
        if isinstance(v, Raw):
            out.append(v.data)
        elif isinstance(v, (dict, Pairs)):
            items = list(v.items()) if isinstance(v, dict) else v.pairs
            out.append(b"{")
            for i, (k, x) in enumerate(items):
                if i:
                    out.append(gap() + b"," + gap())
                out.append(key(k) + gap() + b":" + gap())
                walk(x)
            out.append(b"}")
        elif isinstance(v, list):
            out.append(b"[")
            for i, x in enumerate(v):
                if i:
                    out.append(gap() + b"," + gap())
                walk(x)
            out.append(b"]")
        else:
            out.append(json.dumps(v, ensure_ascii=False).encode("utf-8", "surrogatepass"))

    walk(value)
    return b"".join(out)


def nodes(value: Any, rng: random.Random) -> list[tuple[tuple, Any]]:
    """The (path, node) pairs below one randomly chosen top-level member (so that small parts of a
    reply are hit as often as its large observations), the reply itself included."""
    out: list[tuple[tuple, Any]] = [((), value)]
    if isinstance(value, dict) and value:
        top = rng.choice(sorted(value))
        stack = [((top,), value[top])]
        while stack:
            path, node = stack.pop()
            out.append((path, node))
            if isinstance(node, dict):
                stack.extend((path + (k,), x) for k, x in node.items())
            elif isinstance(node, list):
                stack.extend((path + (i,), x) for i, x in enumerate(node))
    return out


def _set(value: Any, path: tuple, new: Any) -> Any:
    if not path:
        return new
    value = copy.deepcopy(value)
    cur = value
    for k in path[:-1]:
        cur = cur[k]
    cur[path[-1]] = new
    return value


def _pick(value: Any, rng: random.Random, want=None) -> tuple[tuple, Any]:
    cands = [(p, n) for p, n in nodes(value, rng) if want is None or want(n)]
    if not cands:
        cands = [(p, n) for p, n in nodes(value, random.Random(0)) if want is None or want(n)] or [((), value)]
    return rng.choice(cands)


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


DEEP = Raw(b"[" * 70 + b"]" * 70)


def _types(value: Any, rng: random.Random) -> Mutation:
    path, node = _pick(value, rng, lambda n: True)
    choices = [None, True, False, 0, -1, 7, 1.5, "x", "", [], {}, [None], {"type": None}, {"a": [1, {"b": "c"}]},
               DEEP, "x" * 5000, [1] * 200]
    new = rng.choice([c for c in choices if type(c) is not type(node)] or choices)
    shown = "deep nest" if new is DEEP else json.dumps(new)[:20]
    return Mutation("types", f"{'/'.join(map(str, path))} := {shown}", dump(_set(value, path, new)))


def _respell_int(n: int, rng: random.Random) -> bytes:
    forms = [f"{n}.0", f"{n}e0", f"{n}E+0", f"{n}.000", f"{n * 10}E-1"]
    if n == 0:
        forms += ["-0", "-0.0", "0e5", "0.0E-3"]
    else:
        forms.append(f"{n}0e-1")
    if 0 < abs(n) < 10**6:
        forms.append(f"{n / 10**len(str(abs(n)))!r}e{len(str(abs(n)))}")
    return rng.choice(forms).encode()


def _numbers(value: Any, rng: random.Random) -> Mutation:
    path, node = _pick(value, rng, _is_number)
    same = True
    if not _is_number(node) or not path:  # no number here: one more member holds one
        value, path, node, same = {**value, "zz_number": 0} if isinstance(value, dict) else value, ("zz_number",), 0, False
    if rng.random() < 0.5:  # the same number spelt another way
        if isinstance(node, int):
            text = _respell_int(node, rng)
        else:
            text = rng.choice([f"{node:.17e}", f"{node!r}0" if "." in repr(node) and "e" not in repr(node) else repr(node),
                               f"{node:.17E}"]).encode()
        return Mutation("numbers", f"{'/'.join(map(str, path))} spelt {text.decode()}", dump(_set(value, path, Raw(text))),
                        same=same)
    text, code = rng.choice([
        (b"9" * 5000, "out_of_range"), (b"1e400", "out_of_range"), (b"-1e999", "out_of_range"),
        (b"1E400", "out_of_range"), (str(2**53).encode(), "out_of_range"), (str(-2**53).encode(), "out_of_range"),
        (b"1" + b"0" * 400 + b".5", "out_of_range"), (b"007", "malformed_json"), (b"+1", "malformed_json"),
        (b".5", "malformed_json"), (b"1.", "malformed_json"), (b"0x1F", "malformed_json"), (b"NaN", "non_finite"),
        (b"Infinity", "non_finite"), (b"-Infinity", "non_finite"), (b"1e-400", None), (str(2**53 - 1).encode(), None),
        (b"0" * 5000 + b"7", "malformed_json"),
    ])
    return Mutation("numbers", f"{'/'.join(map(str, path))} := {text[:20].decode()}", dump(_set(value, path, Raw(text))),
                    code=code)


def respelt(value: Any, rng: random.Random, share: float = 1.0) -> Any:
    """``value`` with (a ``share`` of) its numbers spelt another way — the same value (F-VALUES)."""
    if _is_number(value) and rng.random() < share:
        if isinstance(value, int):
            return Raw(_respell_int(value, rng))
        return Raw(rng.choice([f"{value:.17e}", f"{value:.17E}", repr(value)]).encode())
    if isinstance(value, dict):
        return {k: respelt(x, rng, share) for k, x in value.items()}
    if isinstance(value, list):
        return [respelt(x, rng, share) for x in value]
    return value


def _values(value: Any, rng: random.Random) -> Mutation:
    share = rng.choice([0.1, 0.5, 1.0])
    return Mutation("values", f"{share:.0%} of the numbers re-spelt", dump(respelt(value, rng, share)), same=True)


def _keys(value: Any, rng: random.Random) -> Mutation:
    path, node = _pick(value, rng, lambda n: isinstance(n, dict) and n)
    if not (isinstance(node, dict) and node):
        path, node = (), value
    k = rng.choice(sorted(node))
    op = rng.choice(["dup-same", "dup-wrong-first", "dup-wrong-last", "drop", "extra", "rename"])
    where = "/".join(map(str, path + (k,)))
    if op.startswith("dup"):
        other = node[k] if op == "dup-same" else rng.choice([None, "x", 12345, [], {"z": 1}])
        pairs = [(x, node[x]) for x in node]
        i = [x for x, _ in pairs].index(k)
        if op == "dup-wrong-first":
            pairs.insert(i, (k, other))
        else:
            pairs.insert(i + 1, (k, other))
        return Mutation("keys", f"{where} twice ({op})", dump(_set(value, path, Pairs(pairs))), code="duplicate_key")
    if op == "drop":
        new = {x: v for x, v in node.items() if x != k}
        return Mutation("keys", f"{where} dropped", dump(_set(value, path, new)))
    if op == "extra":
        extra = rng.choice([Raw(b"-1e999"), Raw(b"1e400"), None, DEEP, "\u00e9", {"a": {"b": []}}, Raw(b"9" * 30)])
        code = {b"-1e999": "out_of_range", b"1e400": "out_of_range"}.get(extra.data) if isinstance(extra, Raw) else None
        if isinstance(extra, Raw) and extra.data.startswith(b"9"):
            code = "out_of_range"
        new = Pairs([*node.items(), ("zz_unknown", extra)])
        return Mutation("keys", f"{where} + zz_unknown", dump(_set(value, path, new)), code=code)
    new = {(x + "_" if x == k else x): v for x, v in node.items()}
    return Mutation("keys", f"{where} renamed", dump(_set(value, path, new)))


def _encoding(value: Any, rng: random.Random) -> Mutation:
    path, node = _pick(value, rng, lambda n: isinstance(n, str) and n)
    if not isinstance(node, str) or not node:
        path, node = ("zz_text",), "text"
        value = {**value, "zz_text": "text"} if isinstance(value, dict) else value
    raw = json.dumps(node, ensure_ascii=False).encode("utf-8")
    cut = rng.randrange(1, len(raw))  # inside the quotes
    op = rng.choice(["bad-byte", "truncated-utf8", "overlong", "utf8-surrogate", "lone-high", "lone-low",
                     "pair", "ascii-escape", "control", "bom"])
    if op == "ascii-escape":  # the same string with one character escaped
        i = rng.randrange(len(node))
        text = json.dumps(node[:i], ensure_ascii=False)[:-1] + "\\u%04x" % ord(node[i]) + json.dumps(node[i + 1:], ensure_ascii=False)[1:]
        return Mutation("encoding", f"{'/'.join(map(str, path))} escaped", dump(_set(value, path, Raw(text.encode()))),
                        same=node.isascii() and "\\" not in node and '"' not in node)
    if op == "bom":
        return Mutation("encoding", "byte order mark", b"\xef\xbb\xbf" + dump(value), code="malformed_json")
    insert, code = {"bad-byte": (b"\xff", "bad_encoding"), "truncated-utf8": (b"\xc3", "bad_encoding"),
                    "overlong": (b"\xc0\xaf", "bad_encoding"), "utf8-surrogate": (b"\xed\xa0\x80", "bad_encoding"),
                    "lone-high": (b"\\ud800", "bad_encoding"), "lone-low": (b"\\udc00", "bad_encoding"),
                    "pair": (b"\\ud83d\\ude00", None), "control": (b"\x01", "malformed_json")}[op]
    if raw[cut - 1:cut] == b"\\":  # never split an escape
        cut -= 1
    text = raw[:cut] + insert + raw[cut:]
    return Mutation("encoding", f"{'/'.join(map(str, path))} {op}", dump(_set(value, path, Raw(text))), code=code)


def _whitespace(value: Any, rng: random.Random) -> Mutation:
    op = rng.choice(["between", "around", "crlf", "vt", "ff", "nbsp"])
    if op == "between":
        return Mutation("whitespace", "JSON whitespace between tokens",
                        dump(value, ws=lambda: rng.choice([b"", b"", b" ", b"\t", b"\r", b"  \t"])), same=True)
    if op == "around":
        return Mutation("whitespace", "spaces around the line", b" \t" + dump(value) + b"  ", same=True)
    if op == "crlf":
        return Mutation("whitespace", "CRLF line end", dump(value) + b"\r", same=True)
    bad = {"vt": b"\x0b", "ff": b"\x0c", "nbsp": b"\xc2\xa0"}[op]
    data = dump(value)
    cut = rng.choice([0, len(data), data.index(b":") + 1 if b":" in data else 0])
    return Mutation("whitespace", f"{op} in the line", data[:cut] + bad + data[cut:], code="malformed_json")


def _lines(value: Any, rng: random.Random) -> Mutation:
    data = dump(value)
    op = rng.choice(["blank-before", "many-blank-before", "spaces-line-before", "split", "two-on-one", "extra-line",
                     "truncated", "empty", "debug-print"])
    if op == "blank-before":
        return Mutation("lines", op, b"\n" + data, code="malformed_json")
    if op == "many-blank-before":
        return Mutation("lines", op, b"\n" * 10_000 + data, code="malformed_json")
    if op == "spaces-line-before":
        return Mutation("lines", op, b"   \n" + data, code="malformed_json")
    if op == "split":
        cut = rng.randrange(1, len(data))
        return Mutation("lines", op, data[:cut] + b"\n" + data[cut:], code="malformed_json")
    if op == "two-on-one":
        return Mutation("lines", op, data + data, code="malformed_json")
    if op == "extra-line":  # the next request reads this one: out of order
        return Mutation("lines", op, data + b"\n" + data)
    if op == "truncated":
        return Mutation("lines", op, data[:rng.randrange(0, len(data))], code="malformed_json")
    if op == "empty":
        return Mutation("lines", op, b"", code="malformed_json")
    return Mutation("lines", op, b"DEBUG: step\n" + data, code="malformed_json")


def _robot0(reply: Any) -> str:
    return sorted(reply["state"]["robots"])[0]


# The instances a hostile-simulator review found, by name: (position, edit of the reply value or line, the code)
NAMED: dict[str, tuple[str, Any, str]] = {
    "digits-5000": ("step:2", lambda r: dump({**r, "state": {**r["state"], "released": Raw(b"9" * 5000)}}), "out_of_range"),
    "1e400": ("step:2", lambda r: dump({**r, "state": {**r["state"], "wip": Raw(b"1e400")}}), "out_of_range"),
    "surrogate-compared": ("step:2", lambda r: dump({**r, "state": {**r["state"], "products": [
        {**r["state"]["products"][0], "recipe": Raw(b'"pair\\ud800"')}, *r["state"]["products"][1:]]}}), "bad_encoding"),
    "surrogate-start-name": ("start", lambda r: dump({**r, "implementation": {**r["implementation"],
                                                                               "name": Raw(b'"sim\\ud800"')}}), "bad_encoding"),
    "events-string": ("step:2", lambda r: dump({**r, "events": "none"}), "bad_field"),
    "robot-null": ("step:2", lambda r: dump({**r, "state": {**r["state"], "robots": {**r["state"]["robots"],
                                                                                       _robot0(r): None}}}), "bad_field"),
    "shelves-string": ("step:2", lambda r: dump({**r, "state": {**r["state"], "shelves": "full"}}), "bad_field"),
    "proposals-list": ("step:2", lambda r: dump({**r, "state": {**r["state"], "proposals": []}}), "bad_field"),
    "extra-minus-1e999": ("step:2", lambda r: dump({**r, "debug": Raw(b"-1e999")}), "out_of_range"),
    "utf8-invalid": ("step:2", lambda r: dump({**r, "state": {**r["state"], "products": [
        {**r["state"]["products"][0], "recipe": Raw(b'"pair\xff"')}, *r["state"]["products"][1:]]}}), "bad_encoding"),
    "blank-lines-10000": ("step:2", lambda r: b"\n" * 10_000 + dump(r), "malformed_json"),
    "seq-leading-zeros": ("step:2", lambda r: dump(r).replace(b'{"seq":', b'{"seq":00', 1), "malformed_json"),
    "seq-5000-zeros": ("step:2", lambda r: dump(r).replace(b'{"seq":', b'{"seq":' + b"0" * 5000, 1), "malformed_json"),
    "state-twice": ("step:2", lambda r: dump(Pairs([(k, v) for k, v in r.items() if k != "state"][:3]
                                                    + [("state", {**r["state"], "wip": 99}), ("state", r["state"])]
                                                    + [(k, v) for k, v in r.items() if k != "state"][3:])),
                    "duplicate_key"),
}


def named(name: str, reply: Any) -> Mutation:
    """The instance ``name`` of :data:`NAMED` applied to ``reply``."""
    _, edit, code = NAMED[name]
    return Mutation("named", name, edit(reply), code=code)


_MUTATORS = {"types": _types, "numbers": _numbers, "values": _values, "keys": _keys, "encoding": _encoding, "whitespace": _whitespace,
             "lines": _lines}


def mutate(reply: Any, klass: str, rng: random.Random) -> Mutation:
    """One mutation of class ``klass`` of the reply value ``reply`` (see the module docstring);
    ``named:NAME`` is the instance NAME of :data:`NAMED`."""
    if klass.startswith("named:"):
        return named(klass.split(":", 1)[1], reply)
    return _MUTATORS[klass](reply, rng)


__all__ = ["CLASSES", "NAMED", "Mutation", "mutate", "named", "respelt", "dump", "Raw", "Pairs"]
