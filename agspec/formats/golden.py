"""Golden reference traces (F-GOLDEN): what the reference replied to one item, as digests.

A golden trace records one passing lockstep run of the reference interpreter against itself: the
joint actions the policy chose, and for the reset reply and every step reply two digests — of the
exact protocol line the reference server sends (``text``, the ``seq`` member left out) and of the
reply's canonical JSON bytes (``value``: keys sorted, so any simulator's key order matches, while a
boolean stays apart from a number and ``1`` apart from ``1.0``).  Replies are never stored, only their digests, so a
golden trace of a 400-tick episode is a few hundred kilobytes whatever the observations weigh.

The file is one JSON object (``schemas/golden.schema.json``); its ``digest`` is the SHA-256 of the
canonical JSON text of the object without ``digest``, checked on every load — a file that does not
verify is never used.
"""

from __future__ import annotations

import hashlib
import json
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

from agspec.formats import jsonl, limits, output, schemas

GOLDEN_FORMAT = "agspec-golden/1"
# the seq as the decoder reads it: an integer literal without leading zeros, within F-VALUES (16 digits at
# most), so that a line with the golden digest is always one the decoder accepts (RES-GOLDEN-IDENTITY)
_SEQ_FIRST = re.compile(rb'\{"seq":(0|[1-9][0-9]{0,15}),')


def _hex(*chunks: bytes | memoryview) -> str:
    """SHA-256 of the chunks in turn, truncated to 128 bits (hex): the fastest strong hash here (CPUs
    hash SHA-256 in hardware)."""
    h = hashlib.sha256()
    for chunk in chunks:
        h.update(chunk)
    return h.hexdigest()[:32]


def line_digest(line: str | bytes, seq: int) -> str | None:
    """The ``text`` digest of one protocol reply line (text, or its UTF-8 bytes as read) whose first
    member is ``"seq": seq``, without it; None when the line does not start that way (the caller then
    decodes it)."""
    data = line.encode("utf-8") if isinstance(line, str) else line
    m = _SEQ_FIRST.match(data)
    if m is None or int(m.group(1)) != seq:
        return None
    return _hex(b"{", memoryview(data)[m.end():])


def text_digest(reply: Mapping[str, Any]) -> str:
    """The ``text`` digest of a reply object: the line the reference server sends for it
    (:func:`agspec.formats.jsonl.compact_bytes`), without ``seq``."""
    return _hex(jsonl.compact_bytes({k: v for k, v in reply.items() if k != "seq"}))


def canonical_bytes(value: Any) -> bytes:
    """The canonical JSON bytes of a decoded value: object keys sorted, compact, UTF-8 — orjson's with
    the ``fast`` extra, else ``json``'s (:func:`encoder` says which; float spellings differ)."""
    if jsonl.orjson is not None:
        try:
            return jsonl.orjson.dumps(value, option=jsonl.orjson.OPT_SORT_KEYS)
        except TypeError:
            pass
    return json.dumps(value, sort_keys=True, separators=(",", ":"), ensure_ascii=False, allow_nan=False).encode()


def encoder() -> str:
    """Which encoder :func:`canonical_bytes` and :func:`~agspec.formats.jsonl.compact_bytes` use (part of the key)."""
    return f"orjson/{jsonl.orjson.__version__}" if jsonl.orjson is not None else "json"


def value_digest(reply: Mapping[str, Any]) -> str | None:
    """The ``value`` digest of a decoded reply without ``seq``: of its canonical JSON bytes, so the key
    order of the simulator's objects does not matter while a boolean stays apart from a number and
    ``1`` from ``1.0`` (different text).  Decoded replies never hold NaN (the strict decoder refuses
    it); None when the value is not plain JSON."""
    try:
        return _hex(canonical_bytes({k: v for k, v in reply.items() if k != "seq"}))
    except (TypeError, ValueError):
        return None


@dataclass(frozen=True)
class Golden:
    """One golden trace: ``key`` (what it is the trace of), ``replies`` ((text, value) digests, the
    reset reply first), ``actions`` (the joint action sent before each step reply) and ``summary``
    (the counts of the passing run it was recorded from, totals and per reply; F-GOLDEN)."""

    key: Mapping[str, Any]
    replies: tuple[tuple[str, str], ...]
    actions: tuple[Mapping[str, int], ...]
    summary: Mapping[str, Any]

    def body(self) -> dict[str, Any]:
        # the digests as one string (64 hex digits per reply: text, then value): a 400-tick trace is
        # then one schema check instead of 800
        return {"format": GOLDEN_FORMAT, "key": dict(self.key), "replies": "".join(t + v for t, v in self.replies),
                "actions": [dict(a) for a in self.actions], "summary": dict(self.summary)}


class GoldenError(ValueError):
    """A golden file that cannot be used (unreadable, malformed, or its digest does not verify)."""


def _digest(body: Mapping[str, Any]) -> str:
    return hashlib.sha256(jsonl.dumps(body).encode("utf-8")).hexdigest()


def dump(golden: Golden, path: str | Path) -> None:
    """Write ``golden`` atomically (a reader never sees half a file)."""
    path = Path(path)
    body = golden.body()
    doc = {**body, "digest": _digest(body)}
    schemas.self_check("golden", doc)  # F-SCHEMAS-SELF
    text = json.dumps(doc, separators=(",", ":"), sort_keys=True, ensure_ascii=False, allow_nan=False)
    output.make_dir(path.parent)
    output.write_text(path, text + "\n")  # F-OUTPUT-FAILURES


# the long arrays of a golden trace: one entry per step or per reply (F-GOLDEN `actions`, `summary`)
BY_REPLY = ("invariant_checks_by_reply", "expectations_by_reply")


def _bulk_plain(data: Mapping[str, Any]) -> bool:
    """Whether the long arrays hold only what schemas/golden.schema.json accepts in them, in the form
    ``dump`` writes: ``actions`` a list of objects of plain ``int`` values, each ``BY_REPLY`` count a
    list of plain ``int`` >= 0.  (An integral float or anything else is left to the schema.)"""
    actions, summary = data.get("actions"), data.get("summary")
    if type(actions) is not list or type(summary) is not dict:
        return False
    if not all(type(a) is dict and all(type(v) is int for v in a.values()) for a in actions):
        return False
    return all(type(summary.get(k)) is list and all(type(n) is int and n >= 0 for n in summary[k]) for k in BY_REPLY)


def _schema_problems(data: Mapping[str, Any]) -> list[schemas.SchemaProblem]:
    """The first problem of ``data`` against the golden schema, or none.  The schema says nothing of
    the long arrays but what each entry must be (tests/test_golden.py holds it to that), so when
    :func:`_bulk_plain` finds every entry acceptable, the schema checks the document with those
    arrays empty — one pass over 400 x 30 integers instead of a validator call per integer (about
    1 ms instead of 13 for a 400-tick trace).  Any other document, and any document that check
    finds a problem in, is validated whole: the verdict and the message are the schema's."""
    if _bulk_plain(data):
        light = {**data, "actions": [], "summary": {**data["summary"], **{k: [] for k in BY_REPLY}}}
        if not schemas.validate("golden", light, limit=1):
            return []
    return schemas.validate("golden", data, limit=1)


def load(path: str | Path, key: Mapping[str, Any]) -> Golden:
    """Read and verify a golden file: bounded reading (F-LIMITS), the format, the digest over the
    content, and the ``key`` it must be the trace of."""
    try:
        data = limits.load_json(Path(path))
    except limits.InputError as exc:
        raise GoldenError(str(exc)) from None
    if not isinstance(data, dict) or data.get("format") != GOLDEN_FORMAT:
        raise GoldenError(f"{path}: not a golden trace (expected \"format\": \"{GOLDEN_FORMAT}\")")
    body = {k: v for k, v in data.items() if k != "digest"}
    if data.get("digest") != _digest(body):
        raise GoldenError(f"{path}: the digest does not verify (the file was changed or is damaged)")
    if body.get("key") != dict(key):
        raise GoldenError(f"{path}: recorded for another key")
    problems = _schema_problems(data)
    if problems:
        raise GoldenError(f"{path}: not a valid golden trace: {problems[0]}")
    text, actions, summary = body["replies"], body["actions"], body["summary"]
    replies = [(text[i:i + 32], text[i + 32:i + 64]) for i in range(0, len(text), 64)]
    if len(replies) != len(actions) + 1 or any(len(summary[k]) != len(replies)
                                                for k in ("invariant_checks_by_reply", "expectations_by_reply")):
        raise GoldenError(f"{path}: {len(replies)} replies for {len(actions)} actions")
    return Golden(dict(key), tuple(replies), tuple(actions), summary)


__all__ = ["GOLDEN_FORMAT", "Golden", "GoldenError", "line_digest", "text_digest", "value_digest", "canonical_bytes",
           "encoder", "dump", "load"]
