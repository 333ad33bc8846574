"""The in-process adapters (``python:``, the reference) and :func:`make_impl`, which reads ``--impl`` (F-PROTOCOL).

The face of this package, :mod:`agspec.conform.impl`, says what every adapter offers.
"""

from __future__ import annotations

import copy
import shlex
import traceback
from typing import Any, Callable

from agspec.conform.impl.base import Implementation, ImplSpecError, MessageHook
from agspec.conform.impl.process import SubprocessImpl
from agspec.conform.impl.serve import Server
from agspec.formats import reply as reply_format
from agspec.formats.protocol import ProtocolError
from agspec.transport.factory import FactoryError, load_factory

# ============================================================================================ in process


class PythonImpl(Implementation):
    """An in-process adapter: ``factory()`` returns an object with ``handle(msg) -> reply``.

    Messages are passed as dicts; each request is a deep copy and each reply goes through a JSON
    round trip (``isolate``), so an adapter cannot alias harness data and must answer plain JSON.
    """

    def __init__(self, factory: Callable[[], Any], spec: str = "python", *, isolate: bool = True, **kw: Any):
        super().__init__(**kw)
        self.factory = factory
        self.spec = spec
        self.isolate = isolate
        self.adapter: Any = None
        self._errors: list[str] = []

    def _open(self) -> None:
        try:
            self.adapter = self.factory()
        except Exception as exc:
            raise ProtocolError("exception", f"the adapter factory raised {type(exc).__name__}: {exc}",
                                stderr=traceback.format_exc())
        if not callable(getattr(self.adapter, "handle", None)):
            raise ProtocolError("exception", f"the adapter {type(self.adapter).__name__} has no handle(msg) method")

    def _exchange(self, msg: dict[str, Any], timeout: float | None) -> Any:
        try:
            reply = self.adapter.handle(copy.deepcopy(msg) if self.isolate else msg)
        except Exception as exc:
            tb = traceback.format_exc()
            self._errors.append(tb)
            raise ProtocolError("exception", f"the adapter raised {type(exc).__name__}: {exc}", stderr=tb)
        if self.isolate:  # the line a process would have sent, decoded as any other (F-PROTOCOL-LINES)
            try:
                return reply_format.encode_in_process(reply)
            except reply_format.LineError as exc:
                raise ProtocolError(exc.code, f"the {msg['cmd']} reply is not plain JSON: {exc.message}")
        return reply

    def _shutdown(self) -> None:
        self.adapter = None

    def stderr_tail(self) -> str:
        return self._errors[-1] if self._errors else ""


class ReferenceImpl(PythonImpl):
    """The built-in reference interpreter (:class:`agspec.conform.impl.serve.Server`), in process."""

    def __init__(self, *, observations: bool = True, masks: bool = True, **kw: Any):

        kw.setdefault("isolate", False)  # fresh dicts on every reply: nothing to isolate
        super().__init__(lambda: Server(observations=observations, masks=masks), spec="reference", **kw)
        self.trusted = not self.isolate

    @property
    def simulator(self):
        """The interpreter behind the server (what a ``global`` policy reads), or None before ``load``."""
        return self.adapter.sim if self.adapter is not None else None


def make_impl(spec: str, *, timeout: float = 5.0, validate: bool = False,
              on_message: MessageHook | None = None) -> Implementation:
    """The implementation an ``--impl`` value names (see the module docstring)."""
    spec = (spec or "").strip()
    if not spec:
        raise ImplSpecError("--impl is empty")
    if spec == "reference":
        return ReferenceImpl(validate=validate, on_message=on_message)
    if spec.startswith("python:"):
        try:
            factory = load_factory(spec[len("python:"):], "python:")
        except FactoryError as exc:
            raise ImplSpecError(str(exc)) from None
        return PythonImpl(factory, spec=spec, validate=validate, on_message=on_message)
    try:
        argv = shlex.split(spec)
    except ValueError as exc:
        raise ImplSpecError(f"--impl {spec!r}: {exc}") from None
    if not argv:
        raise ImplSpecError("--impl is empty")
    return SubprocessImpl(spec, timeout, validate=validate, on_message=on_message)


__all__ = ["PythonImpl", "ReferenceImpl", "make_impl"]
