"""The protocol session every implementation under test shares (F-PROTOCOL): seq numbering, the one
reply decoder and shape check, schema validation, golden replay, restart and replay of the session
commands after a failure.  The adapters are in :mod:`agspec.conform.impl` (in process) and
:mod:`agspec.conform.impl.process` (a simulator process).
"""

from __future__ import annotations

from typing import Any, Callable, Mapping, Sequence

from agspec.conform.impl.history import Budget, RequestLog
from agspec.conform.impl.pipeline import Pipeline
from agspec.formats import golden as golden_format
from agspec.formats import jsonl, protocol
from agspec.formats.protocol import ProtocolError
from agspec.transport import peer

Reply = dict[str, Any]
# F-GOLDEN: a reply line that is byte for byte the golden one (returned instead of the decoded reply)
MATCHED: Any = type("Matched", (), {"__repr__": lambda self: "MATCHED", "__slots__": ()})()
# on_message(direction "->" or "<-", cmd, message) — for --validate-protocol and transcripts
MessageHook = Callable[[str, str, Any], None]


class ImplSpecError(ValueError):
    """``--impl`` names nothing that can be run (usage error, exit 2)."""


class Implementation:
    """Common protocol session logic: seq numbering, reply checks, schema validation, restart."""

    spec: str = ""
    # replies built by agspec itself (the reference interpreter in process): not decoded, their shape
    # not checked (F-PROTOCOL-SHAPE; a test holds the reference's replies to it)
    trusted: bool = False

    def __init__(self, *, validate: bool = False, on_message: MessageHook | None = None):
        self.validate = validate
        self.on_message = on_message
        self.info: dict[str, Any] = {}
        self.capabilities: dict[str, bool] = {}
        self._seq = 0
        self._instance: Mapping[str, Any] | None = None
        self._alive = False
        self.last_reply: Reply | None = None
        self.restarts = 0
        self.start_timeout: float | None = None  # the start request may take longer (process start-up)
        self.budget = Budget()  # RES-GIVE-UP-SCOPE (max_restarts None: never give up)
        self.requests = RequestLog()  # F-REPRO: the requests of the current process

    # ---------------------------------------------------------------- transport (subclasses)

    def _open(self) -> None:
        """Make the transport ready (spawn a process, build the adapter)."""

    def _exchange(self, msg: dict[str, Any], timeout: float | None) -> Any:
        """Send ``msg`` and return the reply: its line (a process) or its object (in process); raise
        ProtocolError when there is none."""
        raise NotImplementedError

    def _shutdown(self) -> None:
        """Release the transport."""

    def stderr_tail(self) -> str:
        return ""

    # ---------------------------------------------------------------- requests

    def _next_seq(self) -> int:
        self._seq += 1
        return self._seq

    def _request(self, cmd: str, golden: tuple[str, str] | None = None, **fields: Any) -> Reply:
        """One request and its checked reply.  With ``golden`` (the F-GOLDEN digests of the reply the
        reference gave), a reply line whose exact text has the golden digest is :data:`MATCHED`
        without being decoded — it is the golden reply byte for byte; any other reply is decoded
        and checked as always."""
        msg = self._prepare(cmd, **fields)
        return self._finish(msg, lambda: self._exchange(msg, self._limit(cmd)), golden)

    def _prepare(self, cmd: str, **fields: Any) -> dict[str, Any]:
        """The request ``cmd`` with the next seq, recorded, shown and (with ``validate``) checked."""
        msg = protocol.request(cmd, self._next_seq(), **fields)
        self.requests.record(cmd, fields)
        if self.on_message:
            self.on_message("->", cmd, msg)
        if self.validate:
            problems = protocol.validate_request(msg)
            if problems:  # a request we built is wrong: an agspec bug, reported loudly
                raise ProtocolError("schema", f"the harness's own {cmd} request violates its schema: {problems[0]}")
        return msg

    def _limit(self, cmd: str) -> float | None:
        # start and load may build a whole model (interpreter start-up, instance compilation)
        return self.start_timeout if cmd in ("start", "load") else None

    @property
    def max_restarts(self) -> int | None:
        return self.budget.limit

    @max_restarts.setter
    def max_restarts(self, limit: int | None) -> None:
        self.budget.limit = limit

    def _finish(self, msg: dict[str, Any], receive: Callable[[], Any], golden: tuple[str, str] | None) -> Reply:
        """The reply to ``msg`` (``receive()`` waits for it): MATCHED, or decoded and checked; a failure
        ends the session (the next request restarts it)."""
        cmd = msg["cmd"]
        try:
            raw = receive()
            # F-GOLDEN: only a line the one decoder accepts can have the golden text digest
            # (RES-GOLDEN-IDENTITY: the golden line itself passed decode_line and check_reply)
            if golden is not None and _golden_text(raw, msg["seq"]) == golden[0]:
                return MATCHED
            reply = self._decoded(msg, raw)
            if self.on_message:
                self.on_message("<-", cmd, reply)
            if self.validate:
                problems = protocol.validate_reply(cmd, reply)
                if problems:
                    raise ProtocolError("schema", f"the {cmd} reply violates schemas/protocol/{cmd}.reply.schema.json: "
                                        + "; ".join(str(p) for p in problems[:3]), detail=[str(p) for p in problems],
                                        pointer=problems[0].pointer)
            if self.trusted:
                protocol.check_outcome(cmd, reply, self.capabilities if cmd != "start" else None)
            else:
                protocol.check_reply(cmd, reply, self.capabilities if cmd != "start" else None)
        except ProtocolError as exc:
            if not exc.stderr:
                exc.stderr = self.stderr_tail()
            # an `ok: false` answer to load or reset leaves the session in step (nothing else is in
            # flight): the simulator answered, so it keeps running (F-PROTOCOL, timing and isolation)
            if not (exc.code == "error_reply" and cmd in ("load", "reset")):
                self.budget.failed(cmd, exc)
                self._fail()
            raise
        except protocol.Unsupported:  # a declined instance: the session goes on (F-PROTOCOL-UNSUPPORTED)
            raise
        except BaseException:  # never leave a session whose replies are out of step with its requests
            self._fail()
            raise
        self.last_reply = reply  # what a resumed run mirrors (F-GOLDEN)
        return reply

    def pipeline(self, steps: Sequence[tuple[Mapping[str, int], tuple[str, str]]]) -> Pipeline:
        """F-GOLDEN: ``step`` requests (actions, golden digests) answered in order; in process one at a time."""
        self._ensure()
        return Pipeline(self, steps, window=1)

    def _decoded(self, msg: Mapping[str, Any], raw: Any) -> Reply:
        """The reply object of what ``_exchange`` returned, through the one decoder
        (:func:`agspec.transport.peer.decode_reply`); its nesting is bounded by the shape check that follows."""
        return peer.decode_reply(msg, raw, self._seq, self.stderr_tail)

    def _fail(self) -> None:
        """Forget the session after a failure: the next request restarts it."""
        if self._alive:
            self._alive = False
            try:
                self._shutdown()
            except Exception:
                pass

    # ---------------------------------------------------------------- session

    def start(self) -> dict[str, Any]:
        """Open the transport and hand-shake (``start``); returns the start reply (``info``)."""
        if self._alive:
            return self.info
        self.budget.check_start(self.spec)
        if self.info:
            self.restarts += 1
        self.requests.clear()  # a new process (or adapter) has no history
        try:
            self._open()
        except ProtocolError as exc:
            self.budget.failed("start", exc)
            raise
        self._alive = True
        reply = self._request("start", protocol=protocol.PROTOCOL)
        self.budget.started()
        self.info = {k: v for k, v in reply.items() if k not in ("seq", "ok")}
        self.capabilities = protocol.normalize_capabilities(reply.get("capabilities"))
        return self.info

    def _ensure(self) -> None:
        if not self._alive:
            self.start()
            if self._instance is not None:  # replay the session after a restart
                self._request("load", instance=self._instance)

    def load(self, instance: Mapping[str, Any]) -> None:
        self.budget.check_instance(instance, self.spec)
        if not self._alive:
            self.start()
        self._instance = None
        self._request("load", instance=instance)
        self._instance = instance

    def begin(self, instance: Mapping[str, Any] | None, execution_seed: int | None,
              golden: tuple[str, str] | None = None) -> Reply:
        """An episode's start: ``load`` of ``instance`` (None: the one loaded stays) and ``reset``; the reset
        reply.  A process gets both requests in one write (RES-STREAM-INPUT)."""
        if instance is not None:
            self.load(instance)
        return self.reset(execution_seed, golden)

    def reset(self, execution_seed: int | None, golden: tuple[str, str] | None = None) -> Reply:
        self._ensure()
        return self._request("reset", golden, execution_seed=execution_seed)

    def step(self, actions: Mapping[str, int], golden: tuple[str, str] | None = None) -> Reply:
        self._ensure()
        return self._request("step", golden, actions=dict(actions))

    def close(self) -> None:
        if self._alive:
            try:
                self._request("stop")
            except ProtocolError:
                pass
        self._alive = False
        try:
            self._shutdown()
        except Exception:
            pass

    def describe(self) -> dict[str, Any]:
        """For reports: the spec, and what the implementation said about itself."""
        return {"spec": self.spec, **{k: v for k, v in self.info.items() if k in ("implementation", "capabilities", "protocol")}}

    def __enter__(self) -> "Implementation":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


def _golden_text(raw: Any, seq: int) -> str | None:
    """F-GOLDEN: the text digest of what ``_exchange`` returned — of the line itself, or of an in-process
    reply's compact line when the ``fast`` encoder makes that cheaper than its value digest."""
    if isinstance(raw, (str, bytes)):
        return golden_format.line_digest(raw, seq)
    if isinstance(raw, dict) and jsonl.orjson is not None and raw.get("seq") == seq:
        try:
            return golden_format.text_digest(raw)
        except (TypeError, ValueError):
            return None
    return None
