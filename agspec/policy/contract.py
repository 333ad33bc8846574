"""What ``--policy`` names and how a misbehaving policy is reported (F-POLICY-SPEC, F-POLICY-ERRORS).

A policy is one of: a reference controller name (C-RANDOM … C-CENTRALIZED), an in-process Python
factory ``PATH.py:NAME`` or ``package.module:NAME`` (F-POLICY-PYTHON), or a command line speaking
``agspec-policy/1`` (F-POLICY-PROTOCOL).  A :class:`PolicySpec` is plain data so that it crosses
process boundaries; the factory is imported where the episode runs.
"""

from __future__ import annotations

import hashlib
import re
import shlex
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

from agspec.controllers import CONTROLLERS

KINDS = ("controller", "python", "command")
_PYTHON_TARGET = re.compile(r"^(?P<module>[^\s:]+):(?P<attr>[A-Za-z_][A-Za-z0-9_]*)$")


class PolicySpecError(ValueError):
    """``--policy`` names nothing that can be run (usage error, exit 2)."""


class PolicyError(Exception):
    """A policy misbehaved during an episode (F-POLICY-ERRORS): the episode is recorded as an error.

    ``code`` is one of the F-POLICY-ERRORS codes; ``tick`` and ``agent`` locate it when known.
    """

    def __init__(self, code: str, message: str, *, tick: int | None = None, agent: str | None = None,
                 detail: str = ""):
        super().__init__(message)
        self.code, self.message, self.tick, self.agent, self.detail = code, message, tick, agent, detail

    def record(self) -> dict[str, Any]:
        return {"code": self.code, "message": self.message, "tick": self.tick, "agent": self.agent,
                "detail": self.detail[-4000:] if self.detail else None}


@dataclass(frozen=True)
class PolicySpec:
    """One evaluated policy (F-POLICY-SPEC): its kind, target, label, user version and file digest."""

    kind: str  # controller | python | command
    target: str  # controller name, "module:attr" / "path.py:attr", or the command line
    label: str
    version: str | None = None
    file_digest: str | None = None  # sha256 of the policy's file, where it has one

    def identity(self) -> dict[str, Any]:
        """The policy's identity as recorded in a results bundle."""
        return {"label": self.label, "kind": self.kind, "target": self.target, "version": self.version,
                "file_sha256": self.file_digest}


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def parse_policy(text: str, label: str | None = None, version: str | None = None) -> PolicySpec:
    """F-POLICY-SPEC: a controller name, ``PATH.py:NAME``, ``package.module:NAME`` or a command line."""
    text = (text or "").strip()
    if not text:
        raise PolicySpecError("--policy is empty")
    if text in CONTROLLERS:
        return PolicySpec("controller", text, label or text, version)
    m = _PYTHON_TARGET.match(text)
    if m:
        module = m.group("module")
        if module.endswith(".py") or "/" in module:
            path = Path(module)
            if not path.is_file():
                raise PolicySpecError(f"--policy {text}: no file {module}")
            return PolicySpec("python", f"{path.resolve()}:{m.group('attr')}", label or path.stem, version,
                              _sha256(path))
        return PolicySpec("python", text, label or m.group("attr"), version, _module_digest(module))
    try:
        argv = shlex.split(text)
    except ValueError as exc:
        raise PolicySpecError(f"--policy {text!r}: {exc}") from None
    script = next((Path(a) for a in argv[1:] if Path(a).suffix and Path(a).is_file()), None)
    return PolicySpec("command", text, label or (script.stem if script is not None else Path(argv[0]).name), version,
                      _sha256(script) if script is not None else None)


def _module_digest(module: str) -> str | None:
    """The digest of an importable module's source file, when it has one (not for namespace packages)."""
    import importlib.util

    try:
        spec = importlib.util.find_spec(module)
    except (ImportError, ValueError):
        raise PolicySpecError(f"--policy {module}: no module named {module!r}") from None
    if spec is None:
        raise PolicySpecError(f"--policy {module}: no module named {module!r}")
    origin = Path(spec.origin) if spec.origin and spec.origin not in ("built-in", "frozen") else None
    return _sha256(origin) if origin is not None and origin.is_file() else None


def load_factory(spec: PolicySpec) -> Callable[..., Any]:
    """The factory an in-process policy names (F-POLICY-PYTHON), imported in the calling process."""
    from agspec.conform.impl import ImplSpecError, _load_factory

    try:
        return _load_factory(spec.target)
    except ImplSpecError as exc:
        raise PolicySpecError(str(exc).replace("`python:", "`--policy ")) from None
