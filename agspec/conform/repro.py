"""Reproducers (F-REPRO, ``schemas/repro.schema.json``): a failure saved as a self-contained file that
``agspec conform --replay`` runs again.

A reproducer holds the instance, the execution seed, the joint actions from reset to the failure, the
failure itself, the case's expectations and — for a failure that depends on what the process did before
(F-CONFORM-HISTORY) — the earlier requests of that process.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any, Mapping, Sequence

from agspec import __version__
from agspec.formats import limits, output
from agspec.formats.actions import NotAnAction, action_value
from agspec.formats.schemas import self_check
from agspec.formats.values import integer
from agspec.ir.schemas import ir_integers, validate_schema

REPRO_FORMAT = "agspec-repro/1"


def make_reproducer(*, ident: str, title: str, instance: Mapping[str, Any], execution_seed: int | None,
                    actions: Sequence[Mapping[str, int]], impl: str, failure: Mapping[str, Any] | None,
                    tolerance: float | None = None, expectations: Sequence[Mapping[str, Any]] = (),
                    history: Sequence[tuple[str, Any]] = ()) -> dict[str, Any]:
    """A self-contained reproducer: re-running ``actions`` from reset reproduces the failure — after the
    ``history`` requests (F-REPRO: a failure that depends on what the process did before), with the
    case's ``expectations`` checked."""
    data = {
        "format": REPRO_FORMAT,
        "agspec_version": __version__,
        "id": ident,
        "title": title,
        "impl": impl,
        "instance": dict(instance),
        "execution_seed": execution_seed,
        "actions": [dict(a) for a in actions],
        "failure": dict(failure) if failure else None,
        "options": {"tolerance": tolerance},
    }
    if expectations:
        data["expectations"] = [dict(e) for e in expectations]
    if history:
        data["history"] = history_record(history)
    return data


def history_record(requests: Sequence[tuple[str, Any]]) -> dict[str, Any]:
    """F-REPRO ``history``: the requests, each instance written once (``instances``, referenced by index)."""
    instances: list[Mapping[str, Any]] = []
    index: dict[int, int] = {}  # id() of an instance dict -> its index (the same object is one instance)
    out: list[dict[str, Any]] = []
    for cmd, payload in requests:
        if cmd == "load":
            if id(payload) not in index:
                index[id(payload)] = len(instances)
                instances.append(payload)
            out.append({"cmd": "load", "instance": index[id(payload)]})
        elif cmd == "reset":
            out.append({"cmd": "reset", "execution_seed": payload})
        else:
            out.append({"cmd": "step", "actions": dict(payload)})
    return {"instances": [dict(i) for i in instances], "requests": out}


def save_reproducer(directory: str | Path, data: Mapping[str, Any]) -> Path:
    directory = output.make_dir(directory)  # F-OUTPUT-FAILURES: written whole or not at all
    self_check("repro", data)  # F-SCHEMAS-SELF
    safe = re.sub(r"[^A-Za-z0-9_.-]+", "_", str(data.get("id", "case")))
    return output.write_text(directory / f"{safe}.repro.json",
                             json.dumps(data, indent=1, sort_keys=True, ensure_ascii=False, allow_nan=False) + "\n")


class ReproError(ValueError):
    """A reproducer file cannot be used: ``exit_code`` 2 when it cannot be read, 1 when its content is
    invalid (F-EXIT-CODES)."""

    def __init__(self, message: str, exit_code: int = 1) -> None:
        super().__init__(message)
        self.exit_code = exit_code


def load_reproducer(path: str | Path) -> dict[str, Any]:
    """Read and check a reproducer file (F-REPRO); errors name the file and the offending field."""
    path = Path(path)
    try:  # F-LIMITS: bounded, located reading
        data = limits.load_json(path)
    except limits.InputError as exc:
        raise ReproError(str(exc), exc.exit_code) from None
    if not isinstance(data, dict) or data.get("format") != REPRO_FORMAT:
        raise ReproError(f"{path}: not a reproducer (expected \"format\": \"{REPRO_FORMAT}\")")
    inst = data.get("instance")
    if not isinstance(inst, dict) or inst.get("kind") != "instance":
        raise ReproError(f"{path}: /instance must be an instance IR")

    problems = [i for i in validate_schema(inst) if i.severity == "error"]
    if problems:
        raise ReproError(f"{path}: /instance{problems[0].pointer}: {problems[0].message} [{problems[0].code}]")
    ir_integers(inst)  # RES-INTEGRAL-NUMBERS
    actions = data.get("actions")
    if not isinstance(actions, list) or not all(isinstance(a, dict) for a in actions):
        raise ReproError(f"{path}: /actions must be a list of joint actions {{robot id: integer}}")
    for k, joint in enumerate(actions):
        _actions_in_place(path, f"/actions/{k}", joint)
    seed = data.get("execution_seed")
    if seed is not None:  # RES-INTEGRAL-NUMBERS: 7.0 is the seed 7
        data["execution_seed"] = seed = integer(seed)
        if seed is None:
            raise ReproError(f"{path}: /execution_seed must be an integer or null")
    exps = data.get("expectations", [])
    if not isinstance(exps, list) or not all(isinstance(e, dict) and integer(e.get("after_tick")) is not None
                                             for e in exps):
        raise ReproError(f"{path}: /expectations must be a list of case expectations with `after_tick`")
    for e in exps:
        e["after_tick"] = integer(e["after_tick"])
    _check_history(path, data.get("history"))
    return data


def _actions_in_place(path: Path, where: str, joint: dict) -> None:
    """A joint action {robot id: action} read by RES-INTEGRAL-ACTIONS (2.0 is the action 2), in place."""
    for robot, a in joint.items():
        try:
            joint[robot] = action_value(a)
        except NotAnAction as exc:
            raise ReproError(f"{path}: {where}/{robot}: {exc}") from None


def _check_history(path: Path, history: Any) -> None:
    """F-REPRO ``history``: ``{"instances": [instance IR...], "requests": [{"cmd": load|reset|step, ...}]}``."""
    if history is None:
        return
    if not isinstance(history, dict) or not isinstance(history.get("instances"), list) \
            or not isinstance(history.get("requests"), list):
        raise ReproError(f"{path}: /history must be {{\"instances\": [...], \"requests\": [...]}}")
    for k, inst in enumerate(history["instances"]):
        if not isinstance(inst, dict) or inst.get("kind") != "instance":
            raise ReproError(f"{path}: /history/instances/{k} must be an instance IR")
        problems = [i for i in validate_schema(inst) if i.severity == "error"]
        if problems:
            raise ReproError(f"{path}: /history/instances/{k}{problems[0].pointer}: {problems[0].message} "
                             f"[{problems[0].code}]")
        ir_integers(inst)
    n = len(history["instances"])
    for k, req in enumerate(history["requests"]):
        cmd = req.get("cmd") if isinstance(req, dict) else None
        index, seed = (integer(req.get("instance")), integer(req.get("execution_seed"))) if cmd else (None, None)
        ok = (cmd == "load" and index is not None and 0 <= index < n) \
            or (cmd == "reset" and (req.get("execution_seed") is None or seed is not None)) \
            or (cmd == "step" and isinstance(req.get("actions"), dict))
        if not ok:
            raise ReproError(f"{path}: /history/requests/{k} must be a load (instance index), reset or step request")
        if cmd == "load":  # RES-INTEGRAL-NUMBERS: read as the integers they are
            req["instance"] = index
        elif cmd == "reset" and seed is not None:
            req["execution_seed"] = seed
        elif cmd == "step":
            _actions_in_place(path, f"/history/requests/{k}/actions", req["actions"])


__all__ = ["REPRO_FORMAT", "ReproError", "history_record", "load_reproducer", "make_reproducer", "save_reproducer"]
