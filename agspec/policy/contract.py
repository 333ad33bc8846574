"""What ``--policy`` names and how a misbehaving policy is reported (F-POLICY-SPEC, F-POLICY-ERRORS).

A policy is one of: a reference controller name (C-RANDOM … C-CENTRALIZED), an in-process Python
factory ``PATH.py:NAME`` or ``package.module:NAME`` (F-POLICY-PYTHON), a training run directory of
``agspec train`` (F-POLICY-CHECKPOINT), or a command line speaking ``agspec-policy/1``
(F-POLICY-PROTOCOL).  A :class:`PolicySpec` is plain data so that it crosses
process boundaries; the factory is imported where the episode runs.
"""

from __future__ import annotations

import re
import shlex
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any, Callable

from agspec.controllers import CONTROLLERS
from agspec.extras import MissingExtra, require_torch
from agspec.formats.digest import file_sha256
from agspec.transport import factory as factories

KINDS = ("controller", "python", "checkpoint", "command")
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

    kind: str  # controller | python | checkpoint | command
    target: str  # controller name, "module:attr" / "path.py:attr", a run directory, or the command line
    label: str
    version: str | None = None
    file_digest: str | None = None  # sha256 of the policy's file, where it has one
    training: tuple[tuple[str, Any], ...] | None = None  # F-POLICY-CHECKPOINT: what the run was

    def identity(self) -> dict[str, Any]:
        """The policy's identity as recorded in a results bundle."""
        out = {"label": self.label, "kind": self.kind, "target": self.target, "version": self.version,
               "file_sha256": self.file_digest}
        if self.training is not None:
            out["training"] = dict(self.training)
        return out


def parse_policy(text: str, label: str | None = None, version: str | None = None) -> PolicySpec:
    """F-POLICY-SPEC: a controller name, ``PATH.py:NAME``, ``package.module:NAME`` or a command line."""
    text = (text or "").strip()
    if not text:
        raise PolicySpecError("--policy is empty")
    if text in CONTROLLERS:
        return PolicySpec("controller", text, label or text, version)
    if Path(text).is_dir():
        return checkpoint_policy(Path(text), label, version)
    m = _PYTHON_TARGET.match(text)
    if m:
        module = m.group("module")
        if module.endswith(".py") or "/" in module:
            path = Path(module)
            if not path.is_file():
                raise PolicySpecError(f"--policy {text}: no file {module}")
            return PolicySpec("python", f"{path.resolve()}:{m.group('attr')}", label or path.stem, version,
                              file_sha256(path))
        return PolicySpec("python", text, label or m.group("attr"), version, _module_digest(module))
    try:
        argv = shlex.split(text)
    except ValueError as exc:
        raise PolicySpecError(f"--policy {text!r}: {exc}") from None
    script = next((Path(a) for a in argv[1:] if Path(a).suffix and Path(a).is_file()), None)
    return PolicySpec("command", text, label or (script.stem if script is not None else Path(argv[0]).name), version,
                      file_sha256(script) if script is not None else None)


def checkpoint_policy(run_dir: Path, label: str | None = None, version: str | None = None) -> PolicySpec:
    """F-POLICY-CHECKPOINT: a finished ``agspec train`` run directory; its identity is the policy file's
    SHA-256 with the run's algorithm, scenario, seed, steps and configuration digest."""
    from agspec.checkpoint.rundir import POLICY, RunDirError, read_summary

    try:
        summary = read_summary(run_dir)
    except RunDirError as exc:
        raise PolicySpecError(f"--policy {run_dir}: {exc}") from None
    policy_file = run_dir / POLICY
    if summary.get("status") != "complete" or not policy_file.is_file():
        raise PolicySpecError(f"--policy {run_dir}: the training run is not complete (status "
                              f"{summary.get('status')!r}); finish it with agspec train --resume")
    digest = file_sha256(policy_file)
    if digest != (summary.get("policy") or {}).get("sha256"):
        raise PolicySpecError(f"--policy {run_dir}: {POLICY} does not match the digest its run.json records")
    training = (("algorithm", summary["algorithm"]), ("scenario", summary["scenario"]), ("seed", summary["seed"]),
                ("steps", summary["steps"]), ("config_sha256", summary["config_sha256"]))
    return PolicySpec("checkpoint", str(run_dir.resolve()), label or run_dir.resolve().name, version, digest,
                      training)


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
    return file_sha256(origin) if origin is not None and origin.is_file() else None


@lru_cache(maxsize=8)
def _checkpoint_factory(run_dir: str, digest: str | None) -> Callable[..., Any]:
    """A run directory's factory, loaded once per process and policy file (F-POLICY-HOST: the import of a
    Python policy's module is once per worker; a checkpoint's load is the same)."""
    from agspec.checkpoint.files import CheckpointError

    try:
        require_torch()  # before the import: the networks' module imports torch at its top
        from agspec.checkpoint.policy import factory_from_run

        return factory_from_run(run_dir)
    except (MissingExtra, CheckpointError) as exc:
        raise PolicySpecError(f"--policy {run_dir}: {exc}") from None


def load_factory(spec: PolicySpec) -> Callable[..., Any]:
    """The factory an in-process policy names (F-POLICY-PYTHON), imported in the calling process."""
    if spec.kind == "checkpoint":  # F-POLICY-CHECKPOINT
        return _checkpoint_factory(spec.target, spec.file_digest)
    try:
        return factories.load_factory(spec.target, "--policy ")
    except factories.FactoryError as exc:
        raise PolicySpecError(str(exc)) from None
