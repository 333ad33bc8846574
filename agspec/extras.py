"""The optional extras (pyproject ``[project.optional-dependencies]``): one error class and one loader each.

A command that needs an extra imports it through here, so that a missing extra is always the same
:class:`MissingExtra` (a usage error, exit 2, whose message is the install line; F-EXIT-CODES) and
never an ``ImportError`` traceback, whichever command met it first.
"""

from __future__ import annotations

from typing import Any


class MissingExtra(RuntimeError):
    """An optional dependency is not installed; the message names the extra that provides it."""


def require_torch() -> Any:
    """PyTorch, for training and for loading a trained checkpoint (extra ``train``)."""
    try:
        import torch
    except ImportError:
        raise MissingExtra("training needs PyTorch: pip install 'agspec[train]' "
                           "(a CPU build: pip install torch --index-url https://download.pytorch.org/whl/cpu)") from None
    return torch


def scipy_stats(purpose: str) -> Any:
    """``scipy.stats`` (extra ``eval``); ``purpose`` says what needs it, e.g. "the paired comparison"."""
    try:
        from scipy import stats
    except ImportError:
        raise MissingExtra(f"{purpose} needs SciPy: pip install 'agspec[eval]'") from None
    return stats


def pyplot() -> Any:
    """matplotlib's pyplot on the non-interactive Agg backend, SVG text kept as text (extra ``plot``)."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        matplotlib.rcParams["svg.fonttype"] = "none"  # text stays text: searchable, editable, checkable
        import matplotlib.pyplot as plt
    except ImportError:
        raise MissingExtra("figures need matplotlib: pip install 'agspec[plot]'") from None
    return plt
