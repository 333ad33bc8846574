"""Importing the callable a ``module:attr`` target names (F-POLICY-PYTHON, F-PROTOCOL's ``python:`` adapter).

``pkg.module:attr`` is imported; ``path/to/file.py:attr`` is executed once per process under a name
derived from its resolved path, as an import would be, and a failed execution leaves nothing
half-initialised in ``sys.modules``.  ``--impl python:…`` and ``--policy …`` both load through here.
"""

from __future__ import annotations

import hashlib
import importlib
import importlib.util
import os
import sys
from pathlib import Path
from typing import Any, Callable


class FactoryError(ValueError):
    """The target names nothing that can be imported and called (a usage error, exit 2)."""


def load_factory(target: str, option: str) -> Callable[..., Any]:
    """``pkg.module:factory`` or ``path/to/file.py:factory`` -> the callable; ``option`` is how the user
    wrote it (``python:`` or ``--policy ``), used in messages."""
    module_name, sep, attr = target.rpartition(":")
    if not sep or not module_name or not attr:
        raise FactoryError(f"`{option}{target}`: expected {option}pkg.module:factory or {option}path/file.py:factory")
    try:
        if module_name.endswith(".py") or os.sep in module_name or "/" in module_name:
            path = Path(module_name)
            if not path.is_file():
                raise FactoryError(f"`{option}{target}`: no file {module_name}")
            # a name stable across processes (not hash(), which Python salts per process)
            name = "agspec_impl_" + hashlib.sha256(str(path.resolve()).encode("utf-8")).hexdigest()[:16]
            module = sys.modules.get(name)  # a file is executed once per process, as an import is
            if module is None:
                spec = importlib.util.spec_from_file_location(name, path)
                if spec is None or spec.loader is None:
                    raise FactoryError(f"`{option}{target}`: cannot import {module_name}")
                module = importlib.util.module_from_spec(spec)
                sys.modules[name] = module
                try:
                    spec.loader.exec_module(module)
                except BaseException:
                    sys.modules.pop(name, None)  # a failed import leaves nothing half-initialised behind
                    raise
        else:
            module = importlib.import_module(module_name)
    except FactoryError:
        raise
    except Exception as exc:  # ImportError, or the module raising at import time
        raise FactoryError(f"`{option}{target}`: cannot import {module_name}: {type(exc).__name__}: {exc}") from None
    factory = getattr(module, attr, None)
    if not callable(factory):
        raise FactoryError(f"`{option}{target}`: {module_name} has no callable `{attr}`")
    return factory


__all__ = ["FactoryError", "load_factory"]
