"""The reference interpreter speaking F-PROTOCOL: ``agspec serve`` and the in-process adapter.

:class:`Server` answers protocol messages (dicts) with the reference interpreter; ``serve_stdio``
runs it over JSON Lines on stdin/stdout.  ``agspec conform --impl "agspec serve"`` therefore
exercises the whole protocol, and simulator authors have a live peer to test their client code
against.  ``python:agspec.conform.impl.serve:Server`` is the same server as an in-process adapter.

Robustness (F-PROTOCOL): a malformed request gets an error reply, never a crash — a line that is not
JSON (``bad_json``), not an object or without a known ``cmd`` (``bad_request``, ``unknown_cmd``),
a protocol version it does not speak (``unsupported_protocol``), an instance the interpreter cannot
load (``invalid_instance``), ``reset`` before ``load`` (``not_loaded``), ``step`` before ``reset``
(``not_reset``), malformed actions (``bad_actions``), an action-slot overflow (``slot_overflow``,
O-ACTION-ENCODING) and any unexpected failure (``internal``, with the traceback on stderr).
"""

from __future__ import annotations

import hashlib
import pickle
import sys
import traceback
from typing import IO, Any, Mapping

from agspec import __version__
from agspec.formats.actions import NotAnAction, action_value
from agspec.formats.diagnostics import Issue
from agspec.formats.jsonl import compact_bytes
from agspec.formats.protocol import PROTOCOL, encode, error_reply, loads
from agspec.formats.values import integer
from agspec.interp.observe import SlotOverflow
from agspec.interp.snapshot import global_state
from agspec.interp.tick import Simulator
from agspec.ir.schemas import ir_integers, validate_schema

IMPLEMENTATION = {"name": "agspec-reference", "version": __version__, "language": "python"}
SCHEMA_MEMO = 64  # instances whose schema errors a process remembers
_schema_errors_of: dict[bytes, tuple[Issue, ...]] = {}  # by the digest of the instance's pickle


def schema_errors(instance: dict[str, Any]) -> tuple[Issue, ...]:
    """The instance IR's schema errors (F-IR), remembered per process: they are a pure function of the
    document, and one process loads the same instance again and again (each suite case on it, the
    reference beside an in-process implementation, the session replayed after a restart).  The key is
    the SHA-256 of the document's pickle, which tells apart what JSON text may not (``1`` from ``1.0``
    and ``true``, NaN from null, a key ``1`` from ``"1"``) and keeps the key order (which problem the
    validator names first may depend on it): equal keys are the same document.  A document that
    cannot be pickled is validated as it is."""
    try:
        key = hashlib.sha256(pickle.dumps(instance, protocol=5)).digest()
    except Exception:
        return tuple(i for i in validate_schema(instance) if i.severity == "error")
    memo = _schema_errors_of
    found = memo.get(key)
    if found is None:
        found = memo[key] = tuple(i for i in validate_schema(instance) if i.severity == "error")
        if len(memo) > SCHEMA_MEMO:
            del memo[next(iter(memo))]  # the oldest
    return found


class RequestError(Exception):
    def __init__(self, code: str, message: str):
        super().__init__(message)
        self.code, self.message = code, message


class Server:
    """The reference interpreter behind the protocol; ``handle(msg) -> reply`` (no JSON encoding)."""

    def __init__(self, observations: bool = True, masks: bool = True):
        self.capabilities = {"observations": bool(observations), "masks": bool(masks),
                             "privileged_state": True, "events": True, "diagnostic_state": True}
        self.sim = None
        self.instance: dict[str, Any] | None = None
        self.started = False
        self.was_reset = False
        self.stopped = False

    # ------------------------------------------------------------------ dispatch

    def handle(self, msg: Any) -> dict[str, Any]:
        """Answer one request; never raises."""
        if not isinstance(msg, dict):
            return error_reply(None, "bad_request", "a request is a JSON object with `cmd` and `seq`")
        seq = msg.get("seq")
        try:
            cmd = msg.get("cmd")
            if "seq" not in msg:
                raise RequestError("bad_request", "the request has no `seq`")
            handler = getattr(self, f"_cmd_{cmd}", None) if isinstance(cmd, str) else None
            if handler is None:
                raise RequestError("unknown_cmd", f"unknown command {cmd!r}; expected start, load, reset, step or stop")
            return {"seq": seq, "ok": True, **handler(msg)}
        except RequestError as exc:
            return error_reply(seq, exc.code, exc.message)
        except Exception as exc:  # an agspec bug: an error reply, and the traceback on stderr
            traceback.print_exc(file=sys.stderr)
            return error_reply(seq, "internal", f"internal error of the reference server: {type(exc).__name__}: {exc}")

    # ------------------------------------------------------------------ commands

    def _cmd_start(self, msg: Mapping[str, Any]) -> dict[str, Any]:
        if msg.get("protocol") != PROTOCOL:
            raise RequestError("unsupported_protocol", f"this server speaks {PROTOCOL}, not {msg.get('protocol')!r}")
        self.started = True
        return {"protocol": PROTOCOL, "implementation": dict(IMPLEMENTATION), "capabilities": dict(self.capabilities)}

    def _cmd_load(self, msg: Mapping[str, Any]) -> dict[str, Any]:

        instance = msg.get("instance")
        if not isinstance(instance, dict):
            raise RequestError("invalid_instance", "`instance` must be an instance IR object")
        problems = schema_errors(instance)
        if problems:
            first = problems[0]
            raise RequestError("invalid_instance", f"{first.pointer or '/'}: {first.message} [{first.code}]")
        ir_integers(instance)  # RES-INTEGRAL-NUMBERS: a radius of 1.0 is the radius 1
        try:
            sim = Simulator(instance)
        except Exception as exc:
            raise RequestError("invalid_instance", f"the interpreter cannot load the instance: {type(exc).__name__}: {exc}")
        self.sim, self.instance, self.was_reset = sim, instance, False
        return {}

    def _snapshot(self, events: list) -> dict[str, Any]:

        sim = self.sim
        reply: dict[str, Any] = {"t": sim.t, "state": global_state(sim.state), "events": list(events)}
        if self.capabilities["observations"]:
            reply["observations"] = sim.observe()
        if self.capabilities["masks"]:
            # O-MASK: the same lists the observations carry (built once per epoch), else their own
            obs = reply.get("observations")
            reply["masks"] = {r: o["mask"] for r, o in obs.items()} if obs is not None else sim.masks()
        reply["done"] = sim.done
        return reply

    def _cmd_reset(self, msg: Mapping[str, Any]) -> dict[str, Any]:
        if self.sim is None:
            raise RequestError("not_loaded", "`reset` before `load`")
        seed = msg.get("execution_seed")
        if seed is not None:  # RES-INTEGRAL-NUMBERS: 7.0 is the seed 7
            seed = integer(seed)
            if seed is None:
                raise RequestError("bad_request", "`execution_seed` must be an integer or null")
        self.was_reset = False
        try:
            self.sim.reset(seed)
        except SlotOverflow as exc:  # RES-SLOT-OVERFLOW-STATE: s_0 cannot be acted on
            raise RequestError("slot_overflow", f"O-ACTION-ENCODING: {exc}")
        self.was_reset = True
        return self._snapshot(self.sim.reset_events)

    def _cmd_step(self, msg: Mapping[str, Any]) -> dict[str, Any]:

        if self.sim is None:
            raise RequestError("not_loaded", "`step` before `load`")
        if not self.was_reset:
            raise RequestError("not_reset", "`step` before `reset`")
        actions = msg.get("actions", {})
        if not isinstance(actions, dict):
            raise RequestError("bad_actions", "`actions` must be an object: robot id -> action integer")
        robots = set(self.sim.agents())
        checked: dict[str, int] = {}
        for robot, a in actions.items():
            if robot not in robots:
                raise RequestError("bad_actions", f"no robot {robot!r} in this instance")
            try:  # RES-INTEGRAL-ACTIONS: 2.0 is the action 2; out of range, R-ACTION-VALIDATION makes it idle
                checked[robot] = action_value(a)
            except NotAnAction as exc:
                raise RequestError("bad_actions", f"/actions/{robot}: {exc}") from None
        actions = checked
        try:
            result = self.sim.step(actions)
        except SlotOverflow as exc:  # RES-SLOT-OVERFLOW-STATE: the state reached cannot be acted on
            self.was_reset = False
            raise RequestError("slot_overflow", f"O-ACTION-ENCODING: {exc}")
        reply = self._snapshot(result.events)
        reply["applied"] = dict(result.applied)
        return reply

    def _cmd_stop(self, msg: Mapping[str, Any]) -> dict[str, Any]:
        self.stopped = True
        return {}


def serve_stdio(stdin: IO[str] | None = None, stdout: IO[str] | None = None, server: Server | None = None) -> int:
    """Serve requests line by line until ``stop`` or end of input; returns the exit status (0).

    End of input ends the server (F-PROTOCOL-TEARDOWN): a harness killed with SIGKILL leaves its
    simulators only their closed stdin, and they must exit then.
    """
    stdin = stdin or sys.stdin
    stdout = stdout or sys.stdout
    stdout.flush()
    binary = getattr(stdout, "buffer", None)
    server = server or Server()
    for line in stdin:
        if not line.strip():
            continue
        try:
            msg = loads(line)
        except (ValueError, UnicodeDecodeError) as exc:  # not JSON, NaN / Infinity, nested too deeply
            reply = error_reply(None, "bad_json", f"the request is not JSON: {exc}")
        else:
            reply = server.handle(msg)
        try:
            # the reference's own values are finite; error replies carry only text (F-PROTOCOL);
            # bytes straight to the binary stream when there is one (no text round trip)
            line = compact_bytes(reply) + b"\n"
            if binary is not None:
                binary.write(line)
                binary.flush()
            else:
                stdout.write(line.decode("utf-8"))
                stdout.flush()
        except (BrokenPipeError, OSError):
            return 0
        except ValueError as exc:  # not encodable (NaN): an agspec bug, reported as such
            stdout.write(encode(error_reply(reply.get("seq"), "internal", f"reply not encodable: {exc}")) + "\n")
            stdout.flush()
        if server.stopped:
            return 0
    return 0


__all__ = ["Server", "serve_stdio", "schema_errors", "IMPLEMENTATION"]
