"""The live protocol F-PROTOCOL ("agspec-protocol/1"): messages, schemas and protocol errors.

JSON Lines over the simulator's stdin/stdout, one reply per request, an opaque ``seq`` echoed back
unchanged, expected results never sent (spec/09-formats.md, F-PROTOCOL).  This module builds the
requests, checks the replies a harness needs (F-PROTOCOL-ERRORS) and validates any message against
its schema (``schemas/protocol/{cmd}.{request,reply}.schema.json``, ``error.schema.json``; Draft
2020-12) for ``agspec conform --validate-protocol``.

Schemas are compiled once with every ``$ref`` inlined (``_inline``): jsonschema's reference
lookups dominate validation time otherwise, and a trace or protocol session validates thousands of
records.
"""

from __future__ import annotations

import copy
import json
from dataclasses import dataclass
from functools import lru_cache
from typing import Any, Mapping

from jsonschema import Draft202012Validator
from referencing import Registry, Resource

from agspec.resources import schemas_dir

PROTOCOL = "agspec-protocol/1"
COMMANDS = ("start", "load", "reset", "step", "stop")

# F-PROTOCOL-ERRORS: error categories (what the outcome "error" reports) and their codes.
CRASH, TIMEOUT, PROTOCOL_ERROR, GAVE_UP = "crash", "timeout", "protocol", "gave_up"
UNSUPPORTED = "unsupported"  # error.code of a refusal that is not an error (F-PROTOCOL-UNSUPPORTED)
UNSUPPORTED_COMMANDS = ("load", "reset")  # a refusal elsewhere could hide a divergence: an error_reply
MAX_DEPTH = 64  # F-PROTOCOL-ERRORS: no protocol message nests deeper (a state is < 10 levels)
CODES: dict[str, tuple[str, str]] = {
    # code: (category, meaning)
    "spawn": (CRASH, "the simulator command cannot be started"),
    "exit": (CRASH, "the simulator exited (non-zero status or signal) before replying"),
    "eof": (CRASH, "the simulator closed its stdout before replying"),
    "exception": (CRASH, "the in-process adapter raised an exception"),
    "timeout": (TIMEOUT, "no reply within the per-request timeout"),
    "malformed_json": (PROTOCOL_ERROR, "a line on stdout is not a JSON object"),
    "wrong_seq": (PROTOCOL_ERROR, "a reply does not echo the seq of any request sent"),
    "out_of_order": (PROTOCOL_ERROR, "a reply echoes the seq of an earlier request"),
    "missing_field": (PROTOCOL_ERROR, "a reply lacks a field the protocol or the declared capabilities require"),
    "bad_field": (PROTOCOL_ERROR, "a reply field has the wrong type or value (e.g. t not advanced by one)"),
    "error_reply": (PROTOCOL_ERROR, "the simulator answered ok: false"),
    "handshake": (PROTOCOL_ERROR, "the start reply announces another protocol version"),
    "schema": (PROTOCOL_ERROR, "a message violates its schema (--validate-protocol)"),
    "non_finite": (PROTOCOL_ERROR, "a reply contains NaN or Infinity, which JSON does not have"),
    "too_deep": (PROTOCOL_ERROR, f"a reply nests arrays/objects deeper than {MAX_DEPTH} levels"),
    "gave_up": (GAVE_UP, "the harness stopped restarting a simulator that failed too often"),
}


class ProtocolError(Exception):
    """An implementation failed to speak the protocol (outcome ``error``, F-PROTOCOL-ERRORS).

    ``kind`` is the category (``crash``, ``timeout``, ``protocol``), ``code`` the precise cause (a key
    of :data:`CODES`), ``stderr`` the simulator's captured standard error, if any.
    """

    def __init__(self, code: str, message: str, *, stderr: str = "", detail: Any = None):
        super().__init__(message)
        self.code = code
        self.kind = CODES.get(code, (PROTOCOL_ERROR, ""))[0]
        self.message = message
        self.stderr = stderr
        self.detail = detail

    def __str__(self) -> str:
        return f"{self.kind}/{self.code}: {self.message}"


class Unsupported(Exception):
    """F-PROTOCOL-UNSUPPORTED: the simulator declines an instance; the item is skipped with ``reason``.

    Not a failure of the simulator: no restart, nothing counted towards giving up.
    """

    def __init__(self, cmd: str, reason: str):
        super().__init__(reason)
        self.cmd, self.reason = cmd, reason


# --------------------------------------------------------------------------- requests


def request(cmd: str, seq: Any, **fields: Any) -> dict[str, Any]:
    """One request object (F-PROTOCOL); ``fields`` are the command's own fields."""
    if cmd not in COMMANDS:
        raise ValueError(f"unknown protocol command {cmd!r}")
    return {"cmd": cmd, "seq": seq, **fields}


def start(seq: Any) -> dict[str, Any]:
    return request("start", seq, protocol=PROTOCOL)


def load(seq: Any, instance: Mapping[str, Any]) -> dict[str, Any]:
    return request("load", seq, instance=instance)


def reset(seq: Any, execution_seed: int | None) -> dict[str, Any]:
    return request("reset", seq, execution_seed=execution_seed)


def step(seq: Any, actions: Mapping[str, int]) -> dict[str, Any]:
    return request("step", seq, actions=dict(actions))


def stop(seq: Any) -> dict[str, Any]:
    return request("stop", seq)


def error_reply(seq: Any, code: str, message: str) -> dict[str, Any]:
    return {"seq": seq, "ok": False, "error": {"code": code, "message": message}}


class NonFinite(ValueError):
    """A JSON text with NaN / Infinity / -Infinity, which RFC 8259 does not allow (F-PROTOCOL-ERRORS)."""


class TooDeep(ValueError):
    """A JSON value nested deeper than :data:`MAX_DEPTH` (F-PROTOCOL-ERRORS)."""


def _no_constant(name: str) -> Any:
    raise NonFinite(f"non-finite number {name} (JSON has no NaN or Infinity)")


def depth(value: Any, limit: int = MAX_DEPTH) -> int:
    """Nesting depth of a decoded JSON value, iteratively (no recursion); stops counting past ``limit``."""
    deepest, stack = 0, [(value, 1)]
    while stack:
        node, d = stack.pop()
        if isinstance(node, dict):
            node = list(node.values())
        if isinstance(node, list):
            deepest = max(deepest, d)
            if d <= limit:
                stack.extend((x, d + 1) for x in node if isinstance(x, (dict, list)))
    return deepest


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


def encode(msg: Any) -> str:
    """One protocol line: compact JSON, no NaN, UTF-8 kept."""
    return json.dumps(msg, separators=(",", ":"), ensure_ascii=False, allow_nan=False)


# --------------------------------------------------------------------------- reply checks


def check_reply(cmd: str, reply: Any, capabilities: Mapping[str, Any] | None = None) -> None:
    """The structural checks every harness needs, with or without --validate-protocol.

    Raises :class:`ProtocolError`: ``error_reply`` for ``ok: false``; ``missing_field`` when a field
    the command or a declared capability requires is absent; ``bad_field`` for a wrong type.
    """
    if not isinstance(reply, dict):
        raise ProtocolError("malformed_json", f"the {cmd} reply is not a JSON object")
    ok = reply.get("ok")
    if ok is False:
        err = reply.get("error") if isinstance(reply.get("error"), dict) else {}
        if err.get("code") == UNSUPPORTED and cmd in UNSUPPORTED_COMMANDS:
            reason = err.get("message")
            raise Unsupported(cmd, reason if isinstance(reason, str) and reason.strip() else "(no reason given)")
        raise ProtocolError("error_reply", f"the simulator refused `{cmd}`: "
                                           f"[{err.get('code', '?')}] {err.get('message', '(no message)')}",
                            detail=err)
    if ok is not True:
        raise ProtocolError("missing_field" if "ok" not in reply else "bad_field",
                            f"the {cmd} reply needs `ok`: true or false")
    caps = capabilities or {}
    need: list[str] = []
    if cmd == "start":
        need = ["protocol", "implementation", "capabilities"]
    elif cmd in ("reset", "step"):
        need = ["t"]
        if caps.get("privileged_state", True):
            need.append("state")
        if caps.get("events", True):
            need.append("events")
        if caps.get("observations"):
            need.append("observations")
        if caps.get("masks"):
            need.append("masks")
        if cmd == "step":
            need.append("done")
    missing = [k for k in need if k not in reply]
    if missing:
        raise ProtocolError("missing_field", f"the {cmd} reply lacks " + ", ".join(f"`{k}`" for k in missing))
    types = {"t": int, "state": dict, "events": list, "observations": dict, "masks": dict, "done": bool,
             "implementation": dict, "capabilities": dict, "applied": dict}
    for key, typ in types.items():
        if key in reply and (not isinstance(reply[key], typ) or (typ is int and isinstance(reply[key], bool))):
            raise ProtocolError("bad_field", f"the {cmd} reply field `{key}` must be {typ.__name__}, "
                                             f"found {type(reply[key]).__name__}")
    if cmd == "start" and reply.get("protocol") != PROTOCOL:
        raise ProtocolError("handshake", f"the simulator speaks {reply.get('protocol')!r}, the harness {PROTOCOL!r}")


CAPABILITIES = ("observations", "masks", "privileged_state", "events", "diagnostic_state")


def normalize_capabilities(caps: Any) -> dict[str, bool]:
    """Declared capabilities with the flags of F-PROTOCOL (absent flags are false)."""
    caps = caps if isinstance(caps, dict) else {}
    return {k: bool(caps.get(k, False)) for k in CAPABILITIES}


# --------------------------------------------------------------------------- schemas


@dataclass(frozen=True)
class SchemaProblem:
    """One schema violation: JSON Pointer into the message, stable code (AG2xx), message."""

    pointer: str
    code: str
    message: str

    def __str__(self) -> str:
        return f"{self.pointer or '/'}: {self.message} [{self.code}]"


@lru_cache(maxsize=1)
def _documents() -> dict[str, dict[str, Any]]:
    """Every agspec schema by ``$id``: schemas/*.schema.json and schemas/protocol/*.schema.json."""
    out: dict[str, dict[str, Any]] = {}
    root = schemas_dir()
    for path in sorted(root.glob("*.schema.json")) + sorted((root / "protocol").glob("*.schema.json")):
        doc = json.loads(path.read_text(encoding="utf-8"))
        if "$id" in doc:
            out[doc["$id"]] = doc
    return out


def _resolve_pointer(doc: Any, fragment: str) -> Any:
    cur = doc
    for tok in fragment.lstrip("/").split("/") if fragment else []:
        tok = tok.replace("~1", "/").replace("~0", "~")
        cur = cur[int(tok)] if isinstance(cur, list) else cur[tok]
    return cur


def _inline(node: Any, base: str, docs: Mapping[str, Any], stack: tuple[str, ...] = ()) -> Any:
    """Replace every ``$ref`` by the schema it names (``$ref`` with siblings becomes ``allOf``)."""
    if isinstance(node, list):
        return [_inline(x, base, docs, stack) for x in node]
    if not isinstance(node, dict):
        return node
    if "$ref" in node and isinstance(node["$ref"], str):
        ref = node["$ref"]
        uri, _, fragment = ref.partition("#")
        target_base = uri or base
        key = f"{target_base}#{fragment}"
        if key in stack or target_base not in docs:  # recursive or unknown: keep the reference
            return {k: _inline(v, base, docs, stack) if k != "$ref" else v for k, v in node.items()}
        target = _inline(_resolve_pointer(docs[target_base], fragment), target_base, docs, stack + (key,))
        siblings = {k: _inline(v, base, docs, stack) for k, v in node.items() if k != "$ref"}
        if not siblings:
            return target
        return {"allOf": [target], **siblings}
    out = {}
    for k, v in node.items():
        if k in ("$defs", "definitions"):
            continue  # inlined where used
        if k in ("properties", "patternProperties", "dependentSchemas"):
            out[k] = {name: _inline(sub, base, docs, stack) for name, sub in v.items()}
        elif k in ("enum", "const", "required", "examples", "default"):
            out[k] = copy.deepcopy(v)
        else:
            out[k] = _inline(v, base, docs, stack)
    return out


def schema_id(name: str) -> str:
    """``"trace"`` -> ``urn:agspec:schema:trace:1``; ``"protocol/step.reply"`` -> the protocol schema."""
    if name.startswith("protocol/"):
        return f"urn:agspec:schema:protocol:{name.split('/', 1)[1]}:1"
    return f"urn:agspec:schema:{name}:1"


@lru_cache(maxsize=None)
def validator(name: str) -> Draft202012Validator:
    """A compiled validator for schema ``name`` (see :func:`schema_id`), references inlined."""
    docs = _documents()
    sid = schema_id(name)
    if sid not in docs:
        raise KeyError(f"no schema {name!r} ({sid}) under {schemas_dir()}")
    schema = _inline(docs[sid], sid, docs)
    registry = Registry().with_resources((k, Resource.from_contents(v)) for k, v in docs.items())
    return Draft202012Validator(schema, registry=registry)


def validate(name: str, doc: Any, limit: int = 5) -> list[SchemaProblem]:
    """Schema problems of ``doc`` against schema ``name``, most relevant first, at most ``limit``."""
    from jsonschema.exceptions import best_match

    from agspec.diagnostics import json_pointer
    from agspec.ir.schemas import _issues, _sort_key  # the IR validator's wording and AG2xx codes

    errors = sorted(validator(name).iter_errors(doc), key=_sort_key)
    out: list[SchemaProblem] = []
    seen: set[tuple[str, str]] = set()
    for error in errors:
        if error.context:
            error = best_match([error]) or error
        issues = _issues(error) or []
        if not issues:
            issues = []
        for issue in issues:
            key = (issue.pointer, issue.message)
            if key not in seen:
                seen.add(key)
                out.append(SchemaProblem(issue.pointer or json_pointer(*error.absolute_path), issue.code, issue.message))
        if len(out) >= limit:
            break
    return out[:limit]


def validate_request(msg: Any) -> list[SchemaProblem]:
    cmd = msg.get("cmd") if isinstance(msg, dict) else None
    if cmd not in COMMANDS:
        return [SchemaProblem("/cmd", "AG205", f"`cmd` must be one of {', '.join(COMMANDS)}, found {cmd!r}")]
    return validate(f"protocol/{cmd}.request", msg)


def validate_reply(cmd: str, msg: Any) -> list[SchemaProblem]:
    return validate(f"protocol/{cmd}.reply", msg)


__all__ = [
    "PROTOCOL", "COMMANDS", "CODES", "MAX_DEPTH", "NonFinite", "TooDeep", "loads", "depth",
    "Unsupported", "UNSUPPORTED", "GAVE_UP", "ProtocolError", "SchemaProblem", "request", "start", "load", "reset", "step",
    "stop", "error_reply", "encode", "check_reply", "normalize_capabilities", "validator", "validate",
    "validate_request", "validate_reply", "schema_id",
]
