"""Traces that lie in their header: a mutator over honest traces (F-TRACE-CLAIMS).

Every leaf of the header — its own fields, every field of the stored instance, the initial state
and the reset events — is changed (an integer +1, a boolean flipped, a number moved, a string
altered in its last character, null made 0) and every optional key is deleted, each once with the
header's fingerprint kept and once with it recomputed (the liar who fixes the fingerprint). A
mutant that changes a checkable claim must fail ``agspec check``; :func:`expected_to_fail` is the
oracle, written from F-TRACE-CLAIMS's table of what is not checked, and :func:`judge` runs exactly
what ``agspec check`` runs on one file (agspec.trace.check.check_file).

Used by tests/test_trace_claims.py (a bounded run) and benchmarks/fuzz_trace_claims.py (all of it).
"""

from __future__ import annotations

import copy
import json
import re
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterator

from agspec.trace.check import check_file
from agspec.formats.trace import DIAGNOSTIC_FIELDS
from agspec.controllers import CONTROLLERS
from agspec.ir.fingerprint import fingerprint

Json = dict[str, Any]

# F-TRACE-CLAIMS: the header fields whose change no check can see, and why (the spec's table)
UNCHECKED = (
    (r"^/implementation(/|$)", "self-declared name of the writer"),
    (r"^/execution_seed$", "inert in v1 (D-DETERMINISM)"),
    (r"^/instance/seeds/execution$", "inert in v1 (D-DETERMINISM), not part of the fingerprint"),
    (r"^/instance/meta(/|$)", "documentation, not part of the fingerprint"),
    (r"(^|/)doc$", "documentation, not part of the fingerprint"),
    (r"^/controller/seed$", "the controller's own seed: its choices are not replayed"),
    (r"^/controller/name$", "a policy's label is free; the choices are not replayed"),
)
# diagnostic state fields (F-TRACE-STATE) are no claim of the header, but the invariants read their
# behavioural meaning (free iff busy_until <= t): a change may or may not fail; not asserted
DIAGNOSTIC = (
    (r"^/state/robots/[^/]+/(" + "|".join(sorted(DIAGNOSTIC_FIELDS["robots"])) + r")(/|$)",
     "diagnostic field (F-TRACE-STATE)"),
    (r"^/state/activities/\d+/(" + "|".join(sorted(DIAGNOSTIC_FIELDS["activities"])) + r")$",
     "diagnostic field (F-TRACE-STATE)"),
)
OPTIONAL = {"/horizon", "/controller", "/observations", "/controller/information", "/controller/seed",
            "/instance/meta"}  # keys whose deletion withdraws a claim instead of changing it
LIST_CAP = 3  # of a list longer than this, its first two elements and its last are mutated


@dataclass(frozen=True)
class Mutant:
    pointer: str
    op: str  # "change" or "delete"
    refingerprinted: bool
    header: Json

    @property
    def label(self) -> str:
        return f"{self.op} {self.pointer}{' (fingerprint recomputed)' if self.refingerprinted else ''}"


def _leaves(value: Any, pointer: str = "") -> Iterator[tuple[str, Any]]:
    """(pointer, value) of every leaf, and of every object key as ('key', None) for deletion."""
    if isinstance(value, dict):
        for key in sorted(value):
            yield from _leaves(value[key], f"{pointer}/{key}")
    elif isinstance(value, list):
        picks = range(len(value)) if len(value) <= LIST_CAP else (0, 1, len(value) - 1)
        for i in picks:
            yield from _leaves(value[i], f"{pointer}/{i}")
    else:
        yield pointer, value


def _keys(value: Any, pointer: str = "") -> Iterator[str]:
    if isinstance(value, dict):
        for key in sorted(value):
            yield f"{pointer}/{key}"
            yield from _keys(value[key], f"{pointer}/{key}")
    elif isinstance(value, list):
        picks = range(len(value)) if len(value) <= LIST_CAP else (0, 1, len(value) - 1)
        for i in picks:
            yield from _keys(value[i], f"{pointer}/{i}")


def _changed(value: Any) -> Any:
    if isinstance(value, bool):
        return not value
    if isinstance(value, int):
        return value + 1
    if isinstance(value, float):
        return value * 1.5 + 0.25
    if isinstance(value, str):
        if re.fullmatch(r"sha256:[0-9a-f]{64}", value):
            return value[:-1] + ("0" if value[-1] != "0" else "1")  # one hex digit
        return value[:-1] + ("x" if not value.endswith("x") else "y") if value else "x"
    if value is None:
        return 0
    return value


def _parts(pointer: str) -> list[str]:
    return [int(p) if p.isdigit() else p for p in pointer.split("/")[1:]]  # type: ignore[misc]


def _set(doc: Json, pointer: str, value: Any, delete: bool = False) -> None:
    *path, last = _parts(pointer)
    target: Any = doc
    for p in path:
        target = target[p]
    if delete:
        del target[last]
    else:
        target[last] = value


def mutants(header: Json) -> Iterator[Mutant]:
    """Every mutant of ``header``: each leaf changed, each key deleted; fingerprint kept, then recomputed."""
    edits: list[tuple[str, str]] = [(p, "change") for p, _ in _leaves(header) if p not in ("/type",)]
    edits += [(p, "delete") for p in _keys(header) if p != "/type"]
    for pointer, op in edits:
        for refingerprint in (False, True):
            if refingerprint and not pointer.startswith("/instance/"):
                continue  # the fingerprint covers only the instance
            h = copy.deepcopy(header)
            if op == "change":
                old = h
                for p in _parts(pointer):
                    old = old[p]
                new = _changed(old)
                if new == old and type(new) is type(old):
                    continue
                _set(h, pointer, new)
            else:
                _set(h, pointer, None, delete=True)
            if refingerprint:
                try:
                    h["fingerprint"] = fingerprint(h["instance"])
                except Exception:
                    continue
            yield Mutant(pointer, op, refingerprint, h)


def _official(header: Json) -> bool:
    return bool(((header.get("instance") or {}).get("scenario") or {}).get("suite", {}).get("official"))


def _indexed(header: Json) -> bool:
    return ((header.get("instance") or {}).get("seeds") or {}).get("index") is not None


def _makes_claim(header: Json) -> bool:
    """Whether the stored instance names something outside the trace (F-TRACE-CLAIMS: official
    scenario, suite index); otherwise it is the trace's own definition."""
    return _official(header) or _indexed(header)


SUITE_INDEX_CLAIMS = re.compile(r"^/instance/(id|seeds/index|seeds/generation|realization(/.*)?)$")


def expected_to_fail(m: Mutant, honest: Json, terminated: bool) -> bool | None:
    """True: the mutant changes a checkable claim (check must fail); False: it changes nothing
    checkable (F-TRACE-CLAIMS says why); None: not asserted (a field of an unofficial instance that
    is the trace's own definition, re-fingerprinted; a diagnostic state field; deleting a field
    the schema may or may not require)."""
    p = m.pointer
    if any(re.search(rx, p) for rx, _ in UNCHECKED):
        return False if m.op == "change" else None  # deleting one is the schema's to judge (required or not)
    if any(re.search(rx, p) for rx, _ in DIAGNOSTIC):
        return None
    if m.op == "delete" and (p in OPTIONAL or p.startswith("/controller/")):
        return False if p != "/horizon" or terminated else True
    if p == "/horizon" and terminated and m.op == "change":
        return None  # a larger horizon is consistent with a run that ended by R-TERMINATION
    if p.startswith("/instance/"):
        if p == "/instance/id" and not _makes_claim(honest):
            return False if m.op == "change" else None  # a hand-made instance's name (required: the schema's)
        if not m.refingerprinted:
            return True  # F-CLAIM-FINGERPRINT (every field here is defining: the unchecked ones are above)
        if p == "/instance/realization/method" and not _makes_claim(honest):
            return False if m.op == "change" else None  # a provenance label (required: the schema's)
        if _official(honest):
            return True  # F-CLAIM-OFFICIAL: every defining field is the catalogue's
        if _indexed(honest) and SUITE_INDEX_CLAIMS.match(p):
            return True  # F-CLAIM-SUITE-INDEX: the seed, the name and the realization of the index
        return None  # the scenario, recipes and profile of an unofficial instance are its own definition
    if p.startswith("/controller/information"):
        return honest.get("controller", {}).get("name") in CONTROLLERS
    return True


def write(path: Path, header: Json, rest: list[str]) -> None:
    line = json.dumps(header, sort_keys=True, separators=(",", ":"), ensure_ascii=False)
    path.write_text("\n".join([line, *rest]) + "\n", encoding="utf-8")


def judge(header: Json, rest: list[str], workdir: Path | None = None) -> list[str]:
    """What ``agspec check FILE`` reports against the trace ([] = it passes): diagnostics, invariant
    violations and whole-trace problems."""
    with tempfile.TemporaryDirectory(dir=workdir) as tmp:
        path = Path(tmp) / "mutant.jsonl"
        write(path, header, rest)
        record = check_file(None, str(path))
    if record["exit"] == 0:
        return []
    return ([f"{d['code']} {d['pointer'] or ''} {d['message']}" for d in record.get("diagnostics", [])]
            + [f"{v['invariant']} {v['message']}" for v in record.get("violations", [])]
            + [f"{d['code']} {d['message']}" for d in record.get("whole_trace", [])]) or [f"exit {record['exit']}"]


def split(text: str) -> tuple[Json, list[str]]:
    lines = text.splitlines()
    return json.loads(lines[0]), lines[1:]


__all__ = ["Mutant", "mutants", "expected_to_fail", "judge", "split", "write", "UNCHECKED"]
