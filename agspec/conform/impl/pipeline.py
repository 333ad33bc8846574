"""Step requests in flight (F-GOLDEN pipelining): the replies to a sequence of ``step`` requests, in order.

F-PROTOCOL has one reply per request, in request order, so a harness may write the next requests
before it reads the earlier replies; a golden replay does, so that a simulator process computes
while the harness checks.  The transport is the implementation's own (``_send``, ``_receive``,
``_exchange``) and every reply is finished as a single request's is (``_finish``).
"""

from __future__ import annotations

import collections
from typing import Any, Callable, Iterator, Mapping, Sequence

from agspec.formats import protocol
from agspec.formats.protocol import ProtocolError

Reply = dict[str, Any]


class Pipeline:
    """F-GOLDEN: the replies to a sequence of ``step`` requests, in order, each as ``_request`` returns it
    (MATCHED, or decoded and checked; a failure raises).  A process gets up to ``window`` requests
    ahead of the reply read; :meth:`rest` reads the replies still in flight, so the session stays in
    step when the caller stops early."""

    def __init__(self, impl: Any, steps: Sequence[tuple[Mapping[str, int], tuple[str, str]]],
                 window: int):
        self.impl, self.steps, self.window = impl, list(steps), max(1, window)
        self.sent: collections.deque = collections.deque()  # (msg, golden, send error) awaiting replies
        self.next = 0

    def _fill(self) -> None:
        impl = self.impl
        while self.next < len(self.steps) and len(self.sent) < self.window:
            actions, golden = self.steps[self.next]
            msg = protocol.request("step", impl._next_seq(), actions=dict(actions))
            impl.requests.record("step", msg)
            self.next += 1
            if self.window == 1:  # in process: the reply is computed when it is asked for
                self.sent.append((msg, golden, None))
                return
            try:
                impl._send(msg)
            except ProtocolError as exc:
                self.sent.append((msg, golden, exc))
                return
            self.sent.append((msg, golden, None))

    def _receiver(self, msg: dict[str, Any], error: ProtocolError | None) -> Callable[[], Any]:
        def receive() -> Any:
            if error is not None:  # the request could not be sent
                raise error
            return self.impl._exchange(msg, None) if self.window == 1 else self.impl._receive(msg, None)
        return receive

    def __iter__(self) -> Iterator[Reply]:
        while True:
            self._fill()
            if not self.sent:
                return
            msg, golden, error = self.sent.popleft()
            yield self.impl._finish(msg, self._receiver(msg, error), golden)

    def rest(self) -> list[Any]:
        """The replies to the requests still in flight, decoded and checked (a failure ends the list as
        its last element)."""
        out: list[Any] = []
        while self.sent:
            msg, _, error = self.sent.popleft()
            try:
                out.append(self.impl._finish(msg, self._receiver(msg, error), None))
            except ProtocolError as exc:
                self.sent.clear()
                out.append(exc)
        return out


__all__ = ["Pipeline"]
