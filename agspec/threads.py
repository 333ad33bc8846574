"""The thread budget of every process agspec starts that runs torch (CAMP-THREADS).

One rule: ``workers`` processes of one command share the cores this process may use
(:func:`cores`), so each gets ``budget(workers)`` intra-op threads, ``workers × threads ≤ cores``;
an explicit ``--threads N`` (``requested``) overrides it.  Within that bound the default is
:data:`PER_PROCESS`: the paper's networks are small, and a second intra-op thread costs more than it
saves (RES-THREADS-ONE).  :func:`apply` gives this process its budget (torch's intra-op threads when
torch is imported; the OpenMP/MKL/OpenBLAS variables read when it is imported later) and puts it in
the environment, so that every child started afterwards (pool workers, policy hosts, fresh repeats)
inherits it and calls :func:`apply_inherited` at start.  No agspec imports: floor 0.
"""

from __future__ import annotations

import os
import sys
from typing import Any, Mapping, MutableMapping

BUDGET_VAR = "AGSPEC_THREADS"  # the budget a child inherits (CAMP-THREADS)
LIBRARY_VARS = ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS")
PER_PROCESS = 1  # RES-THREADS-ONE: the default per process, within the bound


def cores() -> int:
    """The cores this process may use: its CPU affinity where the platform has one, else the CPU count."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


def inherited(env: Mapping[str, str] | None = None) -> int | None:
    """The budget the environment carries (``AGSPEC_THREADS``), or None."""
    text = (os.environ if env is None else env).get(BUDGET_VAR, "")
    try:
        n = int(text)
    except ValueError:
        return None
    return n if n >= 1 else None


def budget(workers: int, requested: int | None = None) -> int:
    """Intra-op threads for each of ``workers`` processes a command starts: ``requested`` if given, else
    ``min(PER_PROCESS, cores() // workers)`` and at least 1 (CAMP-THREADS).  A command computes it
    afresh, whatever its own parent's budget was; its children inherit it (:func:`apply_inherited`)."""
    if requested is not None:
        return max(1, int(requested))
    return max(1, min(PER_PROCESS, cores() // max(1, int(workers))))


def set_env(n: int, env: MutableMapping[str, str]) -> MutableMapping[str, str]:
    """``env`` with the budget ``n`` for a child process started with it."""
    env[BUDGET_VAR] = str(n)
    for name in LIBRARY_VARS:
        env[name] = str(n)
    return env


def apply(n: int) -> int:
    """Give this process and the children it starts from now on ``n`` intra-op threads."""
    set_env(n, os.environ)
    torch = sys.modules.get("torch")
    if torch is not None and hasattr(torch, "set_num_threads") and torch.get_num_threads() != n:
        torch.set_num_threads(n)
    return n


def apply_inherited() -> int:
    """At a child's start: the inherited budget, or the default of one process (CAMP-THREADS)."""
    return apply(inherited() or budget(1))


def child_env(base: Mapping[str, str] | None = None) -> dict[str, str]:
    """A copy of ``base`` (default this environment) carrying this process's budget for a child."""
    env = dict(os.environ if base is None else base)
    return dict(set_env(inherited(env) or inherited() or budget(1), env))


def facts(workers: int, requested: int | None, n: int) -> dict[str, Any]:
    """What a results bundle records of the budget (F-POLICY-BUNDLE, CAMP-THREADS)."""
    return {"per_process": n, "workers": workers, "cores": cores(), "requested": requested}


__all__ = ["BUDGET_VAR", "LIBRARY_VARS", "PER_PROCESS", "apply", "apply_inherited", "budget", "child_env", "cores",
           "facts", "inherited", "set_env"]
