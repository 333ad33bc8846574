"""The live protocol F-PROTOCOL ("agspec-protocol/1"): messages, schemas and protocol errors.

JSON Lines over the simulator's stdin/stdout, one reply per request, an opaque ``seq`` echoed back
unchanged, expected results never sent (spec/09-formats.md, F-PROTOCOL).  This module builds the
requests, checks the replies a harness needs (F-PROTOCOL-ERRORS) and validates any message against
its schema (``schemas/protocol/{cmd}.{request,reply}.schema.json``, ``error.schema.json``; Draft
2020-12) for ``agspec conform --validate-protocol``.

Schemas are loaded, compiled and worded by :mod:`agspec.formats.schemas` (one setup for every
format).
"""

from __future__ import annotations

import json
from typing import Any, Mapping

from agspec.formats import shape
from agspec.formats.jsonl import MAX_DEPTH, NonFinite, TooDeep, depth, loads
from agspec.formats.schemas import SchemaProblem, json_type, schema_id, validate, validator

PROTOCOL = "agspec-protocol/1"
COMMANDS = ("start", "load", "reset", "step", "stop")

# F-PROTOCOL-ERRORS: error categories (what the outcome "error" reports) and their codes.
CRASH, TIMEOUT, PROTOCOL_ERROR, GAVE_UP = "crash", "timeout", "protocol", "gave_up"
UNSUPPORTED = "unsupported"  # error.code of a refusal that is not an error (F-PROTOCOL-UNSUPPORTED)
UNSUPPORTED_COMMANDS = ("load", "reset")  # a refusal elsewhere could hide a divergence: an error_reply
CODES: dict[str, tuple[str, str]] = {
    # code: (category, meaning)
    "spawn": (CRASH, "the simulator command cannot be started"),
    "exit": (CRASH, "the simulator exited (non-zero status or signal) before replying"),
    "eof": (CRASH, "the simulator closed its stdout before replying"),
    "exception": (CRASH, "the in-process adapter raised an exception"),
    "harness_killed": (CRASH, "the harness worker died while running the item against a simulator it had started"),
    "timeout": (TIMEOUT, "no reply within the per-request timeout"),
    "malformed_json": (PROTOCOL_ERROR, "a line on stdout is not one JSON object (a blank line included)"),
    "bad_encoding": (PROTOCOL_ERROR, "a reply is not UTF-8, or a string in it holds a lone surrogate"),
    "duplicate_key": (PROTOCOL_ERROR, "an object in a reply names a member twice"),
    "out_of_range": (PROTOCOL_ERROR, "a number beyond the F-VALUES range (an integer beyond ±(2^53 − 1), "
                                     "or beyond binary64)"),
    "wrong_seq": (PROTOCOL_ERROR, "a reply does not echo the seq of any request sent"),
    "out_of_order": (PROTOCOL_ERROR, "a reply echoes the seq of an earlier request"),
    "missing_field": (PROTOCOL_ERROR, "a reply lacks a field the protocol or the declared capabilities require"),
    "bad_field": (PROTOCOL_ERROR, "a reply field has the wrong type or shape (F-PROTOCOL-SHAPE), or a wrong value"),
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
    of :data:`CODES`), ``stderr`` the simulator's captured standard error, if any, ``pointer`` the
    JSON Pointer of the offending member of the reply, if one is to blame.
    """

    def __init__(self, code: str, message: str, *, stderr: str = "", detail: Any = None, pointer: str | None = None):
        super().__init__(message)
        self.code = code
        self.kind = CODES.get(code, (PROTOCOL_ERROR, ""))[0]
        self.message = message
        self.stderr = stderr
        self.detail = detail
        self.pointer = pointer

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


def encode(msg: Any) -> str:
    """One protocol line: compact JSON, no NaN, UTF-8 kept."""
    return json.dumps(msg, separators=(",", ":"), ensure_ascii=False, allow_nan=False)


# --------------------------------------------------------------------------- reply checks


def check_reply(cmd: str, reply: Any, capabilities: Mapping[str, Any] | None = None) -> None:
    """The checks of every reply, with or without --validate-protocol (F-PROTOCOL-ERRORS).

    Raises :class:`ProtocolError`: ``handshake`` for a start reply of another protocol; ``missing_field``
    / ``bad_field`` / ``too_deep`` when the reply does not have its schema's shape (F-PROTOCOL-SHAPE,
    with the JSON Pointer; an integral float where an integer is required is made one, F-VALUES);
    ``error_reply`` for ``ok: false``; ``missing_field`` when a field a declared capability requires
    is absent.  Raises :class:`Unsupported` for a declined instance (F-PROTOCOL-UNSUPPORTED).
    """
    if not isinstance(reply, dict):
        raise ProtocolError("malformed_json", f"the {cmd} reply is not a JSON object")
    if cmd == "start" and reply.get("ok") is True and reply.get("protocol") != PROTOCOL:
        # another protocol version may well have another shape: say that first
        raise ProtocolError("handshake", f"the simulator speaks {_shown(reply.get('protocol'))}, the harness {PROTOCOL!r}")
    problem = shape.conform(reply, f"protocol/{cmd}.reply")
    if problem is not None:
        where = f"field {problem.pointer}" if problem.pointer else "reply"
        raise ProtocolError(problem.code, f"the {cmd} reply {where} {problem.message}", pointer=problem.pointer)
    check_outcome(cmd, reply, capabilities)


def check_outcome(cmd: str, reply: Mapping[str, Any], capabilities: Mapping[str, Any] | None = None) -> None:
    """What a reply of the right shape says: ``error_reply`` / :class:`Unsupported` for ``ok: false``,
    ``missing_field`` when a field a declared capability requires is absent.  Alone, for replies agspec
    built itself (the in-process reference); after the shape check for everything else."""
    if reply.get("ok") is False:
        err = reply.get("error") if isinstance(reply.get("error"), dict) else {}
        code, message = err.get("code"), err.get("message")
        if code == UNSUPPORTED and cmd in UNSUPPORTED_COMMANDS:
            raise Unsupported(cmd, message if isinstance(message, str) and message.strip() else "(no reason given)")
        raise ProtocolError("error_reply", f"the simulator refused `{cmd}`: [{code}] {message or '(no message)'}",
                            detail=err)
    caps = capabilities or {}
    need: list[str] = []
    if cmd in ("reset", "step"):
        if caps.get("privileged_state", True):
            need.append("state")
        if caps.get("events", True):
            need.append("events")
        if caps.get("observations"):
            need.append("observations")
        if caps.get("masks"):
            need.append("masks")
    missing = [k for k in need if k not in reply]
    if missing:
        raise ProtocolError("missing_field", f"the {cmd} reply lacks " + ", ".join(f"`{k}`" for k in missing)
                            + " (a declared capability requires it)", pointer="/" + missing[0])


def _shown(value: Any) -> str:
    text = repr(value) if isinstance(value, (str, int, float, bool, type(None))) else f"a {type(value).__name__}"
    return text if len(text) <= 60 else text[:57] + "..."


CAPABILITIES = ("observations", "masks", "privileged_state", "events", "diagnostic_state")


def normalize_capabilities(caps: Any) -> dict[str, bool]:
    """Declared capabilities with the flags of F-PROTOCOL (absent flags are false)."""
    caps = caps if isinstance(caps, dict) else {}
    return {k: bool(caps.get(k, False)) for k in CAPABILITIES}


# --------------------------------------------------------------------------- schemas (agspec.formats.schemas)


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
    "stop", "error_reply", "encode", "check_reply", "check_outcome", "normalize_capabilities", "json_type", "validator", "validate",
    "validate_request", "validate_reply", "schema_id",
]
