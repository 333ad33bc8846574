"""The request/reply discipline over a line transport (F-PROTOCOL, F-PROTOCOL-LINES, F-POLICY-PROTOCOL).

Every request carries a fresh ``seq``; every reply is one line that goes through the one decoder
(:func:`agspec.formats.reply.decode_line`) and must be a JSON object echoing that ``seq``
(:func:`decode_reply`).  The simulator side of F-PROTOCOL adds its reply checks on top
(:mod:`agspec.conform.impl`); a policy process (F-POLICY-PROTOCOL) speaks its own message set through
:class:`Peer` with the same decoding, waits and teardown.
"""

from __future__ import annotations

import json
from typing import Any, Callable, Mapping, Sequence

from agspec.formats import jsonl
from agspec.formats import reply as reply_format
from agspec.formats.protocol import ProtocolError, encode, json_type
from agspec.transport.process import LineProcess

StderrTail = Callable[[], str]


def decode_line(line: bytes, cmd: str, stderr: StderrTail) -> Any:
    """One reply line through the one decoder (F-PROTOCOL-LINES); every malformation is the peer's
    protocol error, shown with the start of the line."""
    try:
        return reply_format.decode_line(line)
    except reply_format.LineError as exc:
        shown = line[:117].decode("utf-8", "backslashreplace") + ("..." if len(line) > 117 else "")
        raise ProtocolError(exc.code, f"the {cmd} reply is malformed: {exc.message}: {shown!r}",
                            stderr=stderr()) from None


def line_of(text: str, cmd: str, stderr: StderrTail) -> bytes:
    """A reply given as text: its UTF-8 line (a lone surrogate has none)."""
    try:
        return text.encode("utf-8")
    except UnicodeEncodeError:
        raise ProtocolError("bad_encoding", f"the {cmd} reply holds a lone surrogate, which is not Unicode text",
                            stderr=stderr()) from None


def check_seq(msg: Mapping[str, Any], reply: Mapping[str, Any], current: int) -> None:
    """F-PROTOCOL: the reply echoes the request's seq; an earlier one is out of order."""
    if "seq" not in reply:
        raise ProtocolError("missing_field", f"the {msg['cmd']} reply has no `seq`")
    got, sent = reply["seq"], msg["seq"]
    if got == sent and isinstance(got, bool) == isinstance(sent, bool):  # F-VALUES: 4.0 echoes 4
        return
    if isinstance(got, (int, float)) and not isinstance(got, bool) and 0 < got < current:
        raise ProtocolError("out_of_order", f"the reply to {msg['cmd']} (seq {msg['seq']}) echoes seq {got} "
                                            "of an earlier request")
    raise ProtocolError("wrong_seq", f"the reply to {msg['cmd']} (seq {msg['seq']}) echoes seq {json.dumps(got)[:80]}")


def decode_reply(msg: Mapping[str, Any], raw: Any, current: int, stderr: StderrTail) -> dict[str, Any]:
    """The reply object of what a transport returned: a line (bytes; text is encoded first) goes through
    the one decoder; either must be an object echoing the request's seq."""
    if isinstance(raw, str):
        raw = line_of(raw, msg["cmd"], stderr)
    if isinstance(raw, bytes):
        raw = decode_line(raw, msg["cmd"], stderr)
    if not isinstance(raw, dict):
        raise ProtocolError("malformed_json", f"the {msg['cmd']} reply is not a JSON object but {json_type(raw)}",
                            stderr=stderr())
    check_seq(msg, raw, current)
    return raw


def check_depth(reply: Any, cmd: str, stderr: StderrTail) -> None:
    """A reply that no shape check bounds is bounded here (F-LIMITS: nesting)."""
    if jsonl.depth(reply) > jsonl.MAX_DEPTH:
        raise ProtocolError("too_deep", f"the {cmd} reply nests deeper than {jsonl.MAX_DEPTH} levels", stderr=stderr())


class Peer:
    """A child process asked one request at a time: ``request(cmd, timeout, **fields) -> reply`` (decoded,
    seq checked, nesting bounded).  A failed exchange kills the process group; :meth:`close` asks the
    child to ``stop`` and tears the group down whatever it does."""

    def __init__(self, argv: Sequence[str], *, display: str, name: str, timeout: float):
        self.timeout = timeout
        self.seq = 0
        self.process = LineProcess(argv, display=display, name=name)

    def stderr_tail(self) -> str:
        return self.process.stderr_tail()

    def request(self, cmd: str, timeout: float | None = None, **fields: Any) -> dict[str, Any]:
        self.seq += 1
        msg = {"cmd": cmd, "seq": self.seq, **fields}
        try:
            self.process.send((encode(msg) + "\n").encode("utf-8"), cmd)
            raw = self.process.receive(cmd, self.seq, self.timeout if timeout is None else timeout)
            reply = decode_reply(msg, raw, self.seq, self.stderr_tail)
            check_depth(reply, cmd, self.stderr_tail)
        except ProtocolError as exc:
            if not exc.stderr:
                exc.stderr = self.stderr_tail()
            self.process.kill()
            raise
        return reply

    def close(self, grace: float = 2.0) -> None:
        if self.process.alive:
            try:
                self.request("stop", grace)
            except ProtocolError:
                pass
        self.process.kill()  # still running after stop, or children left behind: the whole group goes


__all__ = ["Peer", "check_depth", "check_seq", "decode_line", "decode_reply", "line_of"]
