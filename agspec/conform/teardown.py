"""Teardown of simulators on every exit path of the harness (F-PROTOCOL-TEARDOWN).

Python runs ``finally`` blocks (and so every ``Implementation.close``, which kills the simulator's
process group) for exceptions and for SIGINT (``KeyboardInterrupt``), but not for SIGTERM or SIGHUP,
whose default action ends the process at once and leaves the simulators running.
:func:`exit_on_signals` turns those signals into ``SystemExit(128 + signal)`` for the duration of a
command, so the same ``finally`` blocks run.  On SIGKILL nothing runs in the harness: the simulator
then reads end of file on its standard input, and F-PROTOCOL requires it to exit.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from typing import Iterator

SIGNALS = tuple(s for s in (getattr(signal, "SIGTERM", None), getattr(signal, "SIGHUP", None)) if s is not None)


def _raise_exit(signum: int, frame: object) -> None:
    raise SystemExit(128 + signum)


@contextlib.contextmanager
def exit_on_signals() -> Iterator[None]:
    """SIGTERM / SIGHUP raise ``SystemExit(128 + signum)`` inside the block (main thread only)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {s: signal.signal(s, _raise_exit) for s in SIGNALS}
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)


__all__ = ["exit_on_signals", "SIGNALS"]
