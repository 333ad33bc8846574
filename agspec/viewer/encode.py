"""Trace records (F-TRACE) -> the compact replay document embedded in the page (``agspec-replay/1``).

The document is internal to the viewer (docs/viewer.md describes it). States are delta-encoded: a
full keyframe every ``K`` ticks and, for every tick, the diff from the previous state, so a 48-robot
400-tick trace stays far below 5 MB and the page reconstructs any tick from the nearest keyframe.
Observations (when the trace has them) are encoded the same way.

A diff is a list of operations on a JSON value, applied in order:

* ``[path, value]`` — set: ``path`` is a list of object keys (str) and array indices (int); an index
  equal to the array's length appends;
* ``[path]`` — delete: remove the object key, or truncate the array to the last index of ``path``.

``apply_diff`` (Python) and ``applyDiff`` (assets/model.js) are the same function; the round trip
``decode(encode(records)) == states`` is tested at every tick (tests/test_render.py).
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass
from typing import Any, Iterable, Mapping, Sequence

from agspec.viewer.capacity import capacity_series

REPLAY_FORMAT = "agspec-replay/1"
DEFAULT_KEYFRAME = 25

Path = list  # list[str | int]


class EncodeError(ValueError):
    """The records cannot be replayed (exit 1); the message says where."""


def _same(a: Any, b: Any) -> bool:
    """Exact JSON equality of scalars: 1 != 1.0 != True, -0.0 != 0.0 (the round trip is byte-exact)."""
    if type(a) is not type(b):
        return False
    if isinstance(a, float):
        return a == b and math.copysign(1.0, a) == math.copysign(1.0, b) or (a != a and b != b)
    return a == b


def _key(v: Any) -> Any:
    return v.get("id") if isinstance(v, dict) else None


def diff(old: Any, new: Any, path: Path | None = None, out: list | None = None) -> list:
    """The operations turning ``old`` into ``new`` (both JSON values; the root must be a container)."""
    path = [] if path is None else path
    out = [] if out is None else out
    if isinstance(old, dict) and isinstance(new, dict):
        for k in old:
            if k not in new:
                out.append([path + [k]])
        for k, v in new.items():
            if k not in old:
                out.append([path + [k], v])
            else:
                diff(old[k], v, path + [k], out)
        return out
    if isinstance(old, list) and isinstance(new, list):
        n = min(len(old), len(new))
        for i in range(n):
            a, b = old[i], new[i]
            # list elements with ids (activities, products) are replaced whole when the id changes:
            # an activity ending in front shifts the list, and per-field diffs would then be larger
            if isinstance(a, dict) and isinstance(b, dict) and _key(a) != _key(b):
                out.append([path + [i], b])
            else:
                diff(a, b, path + [i], out)
        for i in range(n, len(new)):
            out.append([path + [i], new[i]])
        if len(new) < len(old):
            out.append([path + [len(new)]])
        return out
    if isinstance(old, (dict, list)) or isinstance(new, (dict, list)) or not _same(old, new):
        if not path:
            raise EncodeError("a state must be a JSON object")
        out.append([path, new])
    return out


def apply_diff(value: Any, ops: Iterable[Sequence[Any]]) -> Any:
    """Apply ``ops`` to ``value`` in place and return it (mirror of model.js ``applyDiff``)."""
    for op in ops:
        path = op[0]
        parent = value
        for k in path[:-1]:
            parent = parent[k]
        last = path[-1]
        if len(op) == 1:
            if isinstance(parent, list):
                del parent[last:]
            else:
                parent.pop(last, None)
        elif isinstance(parent, list) and last == len(parent):
            parent.append(copy.deepcopy(op[1]))  # later ops mutate it: never alias the document
        else:
            parent[last] = copy.deepcopy(op[1])
    return value


def delta_encode(values: Sequence[Any], keyframe: int) -> dict[str, Any]:
    """``{"K", "keys": [values[0], values[K], ...], "diffs": [null, diff(v0, v1), ...]}``."""
    keys = [values[i] for i in range(0, len(values), keyframe)]
    diffs: list[Any] = [None]
    for i in range(1, len(values)):
        diffs.append(diff(values[i - 1], values[i]))
    return {"K": keyframe, "keys": keys, "diffs": diffs}


def delta_decode(enc: Mapping[str, Any], index: int) -> Any:
    """The value at ``index``: the nearest keyframe at or before it, then the diffs up to it."""
    k = enc["K"]
    base = (index // k) * k
    value = copy.deepcopy(enc["keys"][index // k])
    for i in range(base + 1, index + 1):
        apply_diff(value, enc["diffs"][i])
    return value


@dataclass(frozen=True)
class TraceData:
    """What the viewer needs from a trace: s_0 .. s_T, events and actions per transition, I_t."""

    header: dict[str, Any]
    states: list[dict[str, Any]]  # states[t] = s_t
    events: list[list]  # events[0] = reset events; events[t] = events of the transition into s_t
    actions: list[dict[str, int]]  # actions[t] = applied at epoch t (record t), t < T
    observations: list[Any] | None  # observations[t] = I_t, t < T (None: the trace has none)
    footer: dict[str, Any] | None


def _need(cond: bool, where: str, message: str) -> None:
    if not cond:
        raise EncodeError(f"{where}: {message}")


def trace_data(records: Sequence[Mapping[str, Any]], *, name: str = "<trace>",
               lines: Sequence[int] | None = None) -> TraceData:
    """Split parsed records into :class:`TraceData`, checking what the page relies on (located errors)."""
    _need(bool(records), name, "the trace is empty: no records")
    line = (lambda i: lines[i]) if lines else (lambda i: i + 1)
    header = records[0]
    _need(header.get("type") == "header", f"{name}:{line(0)}", "the first record is not the trace header")
    inst = header.get("instance")
    _need(isinstance(inst, dict) and isinstance(inst.get("scenario"), dict)
          and isinstance(inst["scenario"].get("grid"), dict), f"{name}:{line(0)}",
          "/instance: the header has no instance IR with a scenario grid")
    grid = inst["scenario"]["grid"]
    _need(isinstance(grid.get("rows"), int) and isinstance(grid.get("cols"), int), f"{name}:{line(0)}",
          "/instance/scenario/grid: rows and cols must be integers")
    _check_state(header.get("state"), f"{name}:{line(0)}", "/state")
    states = [header["state"]]
    events: list[list] = [list(header.get("events") or [])]
    actions: list[dict[str, int]] = []
    obs: list[Any] = []
    has_obs = True
    footer = None
    for i, rec in enumerate(records[1:], start=1):
        kind = rec.get("type")
        if kind == "footer":
            footer = dict(rec)
            break
        if kind != "tick":
            continue
        where = f"{name}:{line(i)}"
        _check_state(rec.get("state"), where, "/state")
        states.append(rec["state"])
        events.append(list(rec.get("events") or []))
        actions.append({r: a for r, a in (rec.get("actions") or {}).items() if a})
        if isinstance(rec.get("observations"), dict):
            obs.append(rec["observations"])
        else:
            has_obs = False
    return TraceData(dict(header), states, events, actions, obs if has_obs and obs else None, footer)


def _check_state(state: Any, where: str, pointer: str) -> None:
    _need(isinstance(state, dict), where, f"{pointer}: the record has no state object (O-GLOBAL-STATE)")
    _need(isinstance(state.get("robots"), dict), where, f"{pointer}/robots: missing or not an object")
    _need(isinstance(state.get("t"), int), where, f"{pointer}/t: missing or not an integer")


def _summary(inst: Mapping[str, Any]) -> dict[str, Any]:
    """The static layout: grid, profile constants, shelves and the recipes' operation roles."""
    sc = inst["scenario"]
    prof = inst.get("profile") or {}
    real = inst.get("realization") or {}
    recipes = {}
    for rid, rec in (inst.get("recipes") or {}).items():
        ops = {}
        for op in rec.get("operations") or []:
            ops[op.get("id")] = {"type": op.get("type"), "arity": op.get("arity"),
                                 "roles": [r.get("name") for r in op.get("roles") or []],
                                 "inputs": op.get("inputs"), "outputs": op.get("outputs")}
        recipes[rid] = {"raw": rec.get("raw"), "operations": ops}
    return {
        "id": inst.get("id"),
        "scenario": sc.get("id"),
        "family": sc.get("family"),
        "level": sc.get("level"),
        "grid": {k: sc["grid"].get(k) for k in ("rows", "cols", "topology", "radius")},
        "profile": {"id": prof.get("id"), "variant": prof.get("variant"), "spacing": prof.get("spacing", 1.0),
                    "reach": prof.get("reach", 1.5), "rho_conf": prof.get("rho_conf")},
        "coordination": sc.get("coordination"),
        "shelves": real.get("shelves"),
        "shelf_access": real.get("shelf_access"),
        "recipes": recipes,
    }


def encode(data: TraceData, *, keyframe: int = DEFAULT_KEYFRAME, title: str | None = None) -> dict[str, Any]:
    """The replay document of one trace."""
    h = data.header
    inst = h["instance"]
    doc: dict[str, Any] = {
        "format": REPLAY_FORMAT,
        "title": title or f"{inst.get('id', 'trace')} · {(h.get('controller') or {}).get('name', '')}".strip(" ·"),
        "source": {"implementation": h.get("implementation"), "controller": h.get("controller"),
                   "fingerprint": h.get("fingerprint"), "execution_seed": h.get("execution_seed"),
                   "spec_version": h.get("spec_version")},
        "layout": _summary(inst),
        "T": len(data.states) - 1,
        "states": delta_encode(data.states, keyframe),
        "events": data.events,
        "actions": data.actions,
        "observations": delta_encode(data.observations, keyframe) if data.observations else None,
        "footer": data.footer,
        # K*(s_t) while the reference reproduces the recorded states (agspec/viewer/capacity.py)
        "kstar": capacity_series(h, data.states, data.actions),
    }
    return doc


def decode_states(doc: Mapping[str, Any]) -> list[dict[str, Any]]:
    """Every state of a replay document (for tests: must equal the trace's states)."""
    return [delta_decode(doc["states"], t) for t in range(doc["T"] + 1)]


__all__ = ["REPLAY_FORMAT", "EncodeError", "TraceData", "trace_data", "encode", "diff", "apply_diff",
           "delta_encode", "delta_decode", "decode_states"]
