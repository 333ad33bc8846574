"""Talking to a child process in JSON Lines: the one transport below the harness and policy evaluation.

:mod:`.process` starts a child in a session of its own, reads its output on threads, exchanges lines
with bounded waits and tears the whole process group down (F-PROTOCOL-TEARDOWN); :mod:`.peer` is the
request/reply discipline over it (seq numbering, the one reply decoder, F-PROTOCOL-LINES);
:mod:`.factory` imports the ``module:attr`` a ``python:`` simulator or a Python policy names;
:mod:`.teardown` holds the signal and pipe mechanics.  Simulators under test
(:mod:`agspec.conform.impl`) and policy processes and hosts (:mod:`agspec.policy`) use these and no
copy of them.
"""
