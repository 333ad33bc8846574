"""Implementations under test: one Python interface, three adapters (F-PROTOCOL).

``--impl reference``                 :class:`ReferenceImpl`, the built-in interpreter, in process;
``--impl python:pkg.module:factory`` :class:`PythonImpl`; ``factory()`` returns an object with
                                     ``handle(msg) -> reply`` taking and returning the protocol's
                                     messages as dicts (``pkg.module`` may also be a ``.py`` path);
``--impl "CMD ARGS"``                :class:`SubprocessImpl`, a process speaking JSON Lines on
                                     stdin/stdout (``shlex.split``, never a shell).

Every adapter offers ``start() -> info``, ``load(instance)``, ``reset(seed) -> reply``,
``step(actions) -> reply`` and ``close()``; a reply is a dict with ``t``, ``state``, ``events`` and,
as declared by the capabilities, ``observations``, ``masks``, ``done`` and ``applied``.  Failures
raise :class:`~agspec.formats.protocol.ProtocolError` (category ``crash``, ``timeout`` or
``protocol``; F-PROTOCOL-ERRORS).  After a failure the adapter restarts on next use and replays its
session commands (``start``, then ``load`` of the current instance), as Bowtie does, so one crashing
or hanging case never takes the following ones down.

The package: the protocol session every adapter shares (:mod:`.base`, with what a session remembers in
:mod:`.history` and pipelined step requests in :mod:`.pipeline`), the simulator process (:mod:`.process`,
over :mod:`agspec.transport`), the in-process adapters and ``make_impl`` (:mod:`.adapters`) and the
reference interpreter speaking F-PROTOCOL (:mod:`.serve`, ``agspec serve``).  This face keeps the one
import path the spec and the docs name, ``agspec.conform.impl``.
"""

from agspec.conform.impl.adapters import PythonImpl, ReferenceImpl, make_impl
from agspec.conform.impl.base import MATCHED, Implementation, ImplSpecError, MessageHook, Reply
from agspec.conform.impl.process import SubprocessImpl

__all__ = ["MATCHED", "Implementation", "ImplSpecError", "MessageHook", "PythonImpl", "ReferenceImpl", "Reply",
           "SubprocessImpl", "make_impl"]
