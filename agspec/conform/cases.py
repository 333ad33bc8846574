"""The conformance suite: case files, content-fingerprint ids, expectations, coverage and self-lint.

A case (``conformance/cases/*.yaml``, schema ``schemas/case.schema.json``) names an instance, an
execution seed, a joint-action script (symbolic actions allowed) or a driver, and expectations on
the canonical global state (O-GLOBAL-STATE), on the events of a tick, on observations and on the
end of the execution.  Loading resolves everything an implementation needs:

* the instance IR (catalogue reference, a JSON file under the suite root, or inline IR);
* the script as integers (O-ACTION-ENCODING), symbolic actions being resolved against the
  *reference* interpreter's option lists of that epoch (``Simulator.decision.options``), padded
  with idle ticks up to the last expectation;
* for a ``{"trace": …}`` driver, the trace's applied actions, and every state and event of the
  trace as expectations (the trace *is* the expected run);
* the case id, ``"c-"`` + 12 hex digits of the SHA-256 of the RFC 8785 form of the case's
  defining content — instance fingerprint, execution seed, resolved actions or driver, expectations
  — so that titles, tags, rule lists, notes and file names can change without breaking an
  expected-failures file (the JSON-Schema-Test-Suite's stable-id request).

Malformed files raise :class:`SuiteError` with ``file:line`` locations (never a traceback).
``lint_suite`` is the suite's self-check; ``coverage`` measures it against the ``### R-…`` and
``### INV-…`` headings of the spec (``agspec.spec_index``).

Running a case (what a harness does; ``reference_run`` / ``check_reference`` do it in-process):

1. ``reset(case.execution_seed)`` on ``case.instance``;
2. for ``t`` in ``range(case.ticks)``: step with ``case.actions[t]`` (robots not listed idle) or, for
   a ``{"controller": …}`` driver, with the controller's actions; then
   ``check_expectations(case, t, state, events, observations=…, done=…)``, where ``state`` is the
   canonical global state after the step (s_{t+1}), ``events`` the events of the step, and
   ``observations`` the per-robot observations after the step (pass None without that capability:
   observation assertions are then not evaluated, see ``Case.needs_observations``).

Expectation dicts carry the loader key ``_index`` (position in the file, or ``"trace"`` for the
per-tick expectations generated from a reference trace); it is metadata, not an assertion.
"""

from __future__ import annotations

import copy
import hashlib
import json
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any, Iterable, Iterator, Mapping, Sequence

import rfc8785
import yaml
from jsonschema import Draft202012Validator
from jsonschema.exceptions import best_match

from agspec.formats import limits
from agspec.resources import conformance_dir, schemas_dir

ACTION_LIMIT = 114  # O-ACTION-ENCODING: 0 .. 113
DIRECTIONS = ("N", "NE", "E", "SE", "S", "SW", "W", "NW")
IDLE, DELIVER, PICK0, HANDOFF0, RECEIVE0, OP0 = 0, 1, 2, 34, 42, 50
CASE_GLOBS = ("*.yaml", "*.yml", "*.json")
STATE_KEYS = ("t", "released", "delivered", "wip", "lost_releases", "robots", "products", "items", "shelves",
              "proposals", "activities")


# =============================================================================================
# errors


@dataclass(frozen=True)
class Located:
    """One problem of the suite, at ``file:line``."""

    file: str
    line: int | None
    message: str

    def __str__(self) -> str:
        where = f"{self.file}:{self.line}" if self.line else self.file
        return f"{where}: {self.message}"


class SuiteError(Exception):
    """A malformed suite: one or more located problems (``file:line: message`` each)."""

    def __init__(self, problems: Located | Sequence[Located]):
        self.problems: list[Located] = [problems] if isinstance(problems, Located) else list(problems)
        super().__init__("\n".join(str(p) for p in self.problems))

    @property
    def file(self) -> str:
        return self.problems[0].file

    @property
    def line(self) -> int | None:
        return self.problems[0].line


# =============================================================================================
# the case


@dataclass(frozen=True)
class Case:
    """One loaded conformance case; ``actions`` are resolved integers, one joint action per tick."""

    id: str
    title: str
    rules: tuple[str, ...]
    invariants: tuple[str, ...]
    tags: tuple[str, ...]
    instance: dict[str, Any] = field(repr=False)
    execution_seed: int | None
    actions: tuple[dict[str, int], ...] = field(repr=False)
    driver: dict[str, Any] | None
    expectations: tuple[dict[str, Any], ...] = field(repr=False)
    source: Path
    line: int
    fingerprint: str = field(default="", repr=False)
    instance_ref: Any = field(default=None, repr=False)  # as written: {"scenario","index"}, a path, or "inline"
    lines: dict[str, int] = field(default_factory=dict, repr=False)  # "script/3", "expectations/0" -> line
    notes: str = field(default="", repr=False)
    root: Path | None = field(default=None, repr=False)  # the suite root instance/trace paths are relative to

    def __hash__(self) -> int:
        return hash(self.id)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Case) and other.id == self.id and other.source == self.source

    @property
    def ticks(self) -> int:
        """How many transitions the case runs."""
        if self.driver is not None and "controller" in self.driver:
            return int(self.driver["ticks"])
        return len(self.actions)

    @property
    def location(self) -> str:
        return f"{_show_path(self.source)}:{self.line}"

    @property
    def needs_observations(self) -> bool:
        return any("observations" in e for e in self.expectations)

    def expectations_at(self, t_after: int) -> list[dict[str, Any]]:
        return [e for e in self.expectations if e["after_tick"] == t_after]

    def line_of(self, key: str) -> int:
        return self.lines.get(key, self.line)


def _show_path(path: Path) -> str:
    try:
        return str(path.resolve().relative_to(Path.cwd().resolve()))
    except ValueError:
        return str(path)


# =============================================================================================
# YAML with line numbers


def _compose(text: str, file: str) -> tuple[Any, dict[str, int]]:
    """Parse YAML (JSON is YAML) into plain values plus a map JSON Pointer -> 1-based line."""
    try:
        node = yaml.compose(text, Loader=yaml.SafeLoader)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None) or getattr(exc, "context_mark", None)
        line = mark.line + 1 if mark is not None else None
        problem = getattr(exc, "problem", None) or str(exc)
        raise SuiteError(Located(file, line, f"not valid YAML: {problem}")) from None
    if node is None:
        raise SuiteError(Located(file, 1, "empty case file"))
    lines: dict[str, int] = {}
    constructor = yaml.SafeLoader("")

    def conv(n: yaml.Node, ptr: str) -> Any:
        lines[ptr] = n.start_mark.line + 1
        if isinstance(n, yaml.MappingNode):
            out: dict[str, Any] = {}
            for k, v in n.value:
                key = constructor.construct_object(k, deep=True)
                if not isinstance(key, str):
                    key = str(key) if isinstance(key, (int, float)) and not isinstance(key, bool) else key
                if not isinstance(key, str):
                    raise SuiteError(Located(file, k.start_mark.line + 1, f"mapping key {key!r} is not a string"))
                if key in out:
                    raise SuiteError(Located(file, k.start_mark.line + 1, f"duplicate key {key!r}"))
                out[key] = conv(v, f"{ptr}/{_escape(key)}")
            return out
        if isinstance(n, yaml.SequenceNode):
            return [conv(v, f"{ptr}/{i}") for i, v in enumerate(n.value)]
        try:
            return constructor.construct_object(n, deep=True)
        except yaml.YAMLError as exc:
            raise SuiteError(Located(file, n.start_mark.line + 1, f"bad YAML value: {exc}")) from None

    return conv(node, ""), lines


def _escape(token: str) -> str:
    return token.replace("~", "~0").replace("/", "~1")


def _line_for(lines: Mapping[str, int], pointer: str) -> int | None:
    """The line of ``pointer`` or of its closest located ancestor."""
    ptr = pointer
    while True:
        if ptr in lines:
            return lines[ptr]
        if not ptr:
            return None
        ptr = ptr.rsplit("/", 1)[0]


# =============================================================================================
# JSON Pointer and comparison


class PointerError(ValueError):
    pass


_MISSING = object()


def parse_pointer(pointer: str) -> list[str]:
    """RFC 6901 tokens of ``pointer``; ``""`` is the whole document."""
    if pointer == "":
        return []
    if not pointer.startswith("/"):
        raise PointerError(f"JSON Pointer {pointer!r} must be empty or start with '/'")
    tokens = pointer[1:].split("/")
    for tok in tokens:
        if "~" in tok.replace("~0", "").replace("~1", ""):
            raise PointerError(f"JSON Pointer {pointer!r} has a bad escape (only ~0 and ~1)")
    return [t.replace("~1", "/").replace("~0", "~") for t in tokens]


def resolve_pointer(doc: Any, pointer: str) -> Any:
    """The value at ``pointer`` in ``doc``, or ``_MISSING``."""
    cur = doc
    for tok in parse_pointer(pointer):
        if isinstance(cur, Mapping):
            if tok not in cur:
                return _MISSING
            cur = cur[tok]
        elif isinstance(cur, (list, tuple)):
            if not tok.isdigit() or (len(tok) > 1 and tok[0] == "0") or int(tok) >= len(cur):
                return _MISSING
            cur = cur[int(tok)]
        else:
            return _MISSING
    return cur


def _same_scalar(a: Any, b: Any) -> bool:
    if isinstance(a, bool) or isinstance(b, bool):
        return isinstance(a, bool) and isinstance(b, bool) and a == b
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        return a == b
    return type(a) is type(b) and a == b


def first_difference(expected: Any, actual: Any, pointer: str = "") -> tuple[str, Any, Any] | None:
    """The first place (depth first, keys sorted) where ``actual`` differs from ``expected``."""
    if isinstance(expected, Mapping) and isinstance(actual, Mapping):
        for key in sorted(set(expected) | set(actual)):
            sub = f"{pointer}/{_escape(str(key))}"
            if key not in actual:
                return (sub, expected[key], _MISSING)
            if key not in expected:
                return (sub, _MISSING, actual[key])
            diff = first_difference(expected[key], actual[key], sub)
            if diff:
                return diff
        return None
    if isinstance(expected, (list, tuple)) and isinstance(actual, (list, tuple)):
        for i, (e, a) in enumerate(zip(expected, actual)):
            diff = first_difference(e, a, f"{pointer}/{i}")
            if diff:
                return diff
        if len(expected) != len(actual):
            i = min(len(expected), len(actual))
            return (f"{pointer}/{i}", expected[i] if i < len(expected) else _MISSING,
                    actual[i] if i < len(actual) else _MISSING)
        return None
    if isinstance(expected, (Mapping, list, tuple)) or isinstance(actual, (Mapping, list, tuple)):
        return (pointer, expected, actual)
    return None if _same_scalar(expected, actual) else (pointer, expected, actual)


def _show(value: Any) -> str:
    if value is _MISSING:
        return "<absent>"
    text = json.dumps(value, sort_keys=True, ensure_ascii=False)
    return text if len(text) <= 160 else text[:157] + "..."


def event_matches(pattern: Mapping[str, Any], event: Mapping[str, Any]) -> bool:
    """Subset match: ``event`` has every key of ``pattern`` with an equal value."""
    return all(k in event and first_difference(v, event[k]) is None for k, v in pattern.items())


def _match_events(patterns: Sequence[Mapping[str, Any]], events: Sequence[Mapping[str, Any]]) -> list[int]:
    """Indices of patterns left unmatched by a maximum one-to-one matching onto events."""
    options = [[j for j, ev in enumerate(events) if event_matches(p, ev)] for p in patterns]
    owner: dict[int, int] = {}

    def augment(i: int, seen: set[int]) -> bool:
        for j in options[i]:
            if j in seen:
                continue
            seen.add(j)
            if j not in owner or augment(owner[j], seen):
                owner[j] = i
                return True
        return False

    return [i for i in range(len(patterns)) if not augment(i, set())]


# =============================================================================================
# expectations


@dataclass(frozen=True)
class Mismatch:
    """One failed assertion: kind is state, absent, event, no_event, observation or done."""

    kind: str
    after_tick: int
    pointer: str
    expected: Any
    actual: Any
    file: str
    line: int
    message: str

    def __str__(self) -> str:
        return f"{self.file}:{self.line}: {self.message}"


def mismatches(
    case: Case,
    t_after: int,
    state: Mapping[str, Any],
    events: Sequence[Mapping[str, Any]],
    *,
    observations: Mapping[str, Any] | None = None,
    done: bool | None = None,
) -> list[Mismatch]:
    """Every failed assertion of ``case`` after the step applied at epoch ``t_after``.

    Observation assertions are skipped when ``observations`` is None (the implementation lacks the
    capability, see ``Case.needs_observations``); ``done`` assertions when ``done`` is None.
    """
    out: list[Mismatch] = []
    file = _show_path(case.source)
    for k, exp in enumerate(case.expectations):
        if exp["after_tick"] != t_after:
            continue
        line = case.line_of(f"expectations/{exp.get('_index', k)}")
        where = f"after tick {t_after}"

        def add(kind: str, pointer: str, expected: Any, actual: Any, message: str) -> None:
            out.append(Mismatch(kind, t_after, pointer, expected, actual, file, line, f"{where}: {message}"))

        for pointer, want in exp.get("state", {}).items():
            got = resolve_pointer(state, pointer)
            diff = first_difference(want, got, pointer) if got is not _MISSING else (pointer, want, _MISSING)
            if diff:
                at, e, a = diff
                add("state", at, e, a, f"state {at or '(whole state)'}: expected {_show(e)}, got {_show(a)}")
        for pointer in exp.get("absent", []):
            got = resolve_pointer(state, pointer)
            if got is not _MISSING:
                add("absent", pointer, _MISSING, got, f"state {pointer}: expected absent, got {_show(got)}")
        patterns = exp.get("events", [])
        for i in _match_events(patterns, events):
            near = [ev for ev in events if ev.get("type") == patterns[i].get("type")]
            add("event", "", patterns[i], near or list(events),
                f"no event matches {_show(patterns[i])}; events of this type: {_show(near)}")
        for pattern in exp.get("no_events", []):
            hits = [ev for ev in events if event_matches(pattern, ev)]
            if hits:
                add("no_event", "", pattern, hits, f"unexpected event {_show(hits[0])} (matches {_show(pattern)})")
        if observations is not None:
            for pointer, want in exp.get("observations", {}).items():
                got = resolve_pointer(observations, pointer)
                diff = first_difference(want, got, pointer) if got is not _MISSING else (pointer, want, _MISSING)
                if diff:
                    at, e, a = diff
                    add("observation", at, e, a, f"observation {at}: expected {_show(e)}, got {_show(a)}")
        if done is not None and "done" in exp and bool(exp["done"]) != bool(done):
            add("done", "", exp["done"], done, f"expected done={exp['done']}, got done={done}")
    return out


def check_expectations(
    case: Case,
    t_after: int,
    state: Mapping[str, Any],
    events: Sequence[Mapping[str, Any]],
    *,
    observations: Mapping[str, Any] | None = None,
    done: bool | None = None,
) -> list[str]:
    """Messages (``file:line: after tick t: …``) for every failed assertion after tick ``t_after``."""
    return [str(m) for m in mismatches(case, t_after, state, events, observations=observations, done=done)]


# =============================================================================================
# loading


@lru_cache(maxsize=1)
def case_validator() -> Draft202012Validator:
    schema = json.loads((schemas_dir() / "case.schema.json").read_text(encoding="utf-8"))
    return Draft202012Validator(schema)


def _schema_problems(doc: Any, lines: Mapping[str, int], file: str) -> list[Located]:
    errors = list(case_validator().iter_errors(doc))
    if not errors:
        return []
    # Report the most relevant error per top-level case (a list file) or the single best one.
    groups: dict[Any, list] = {}
    for err in errors:
        key = err.absolute_path[0] if isinstance(doc, list) and err.absolute_path else None
        groups.setdefault(key, []).append(err)
    out = []
    for errs in groups.values():
        err = best_match(errs)
        message = err.message
        while err.context:  # descend into oneOf/anyOf while that reaches deeper into the document
            sub = best_match(err.context)
            if len(sub.absolute_path) <= len(err.absolute_path):
                desc = err.schema.get("description") if isinstance(err.schema, Mapping) else None
                message = f"{_show(err.instance)} matches none of the allowed forms" + (f" ({desc})" if desc else "")
                break
            err, message = sub, sub.message
        if err.validator == "pattern" and isinstance(err.schema, Mapping) and err.schema.get("description"):
            message = f"{_show(err.instance)} is not {err.schema['description']}"
        pointer = "".join(f"/{_escape(str(p))}" for p in err.absolute_path)
        holder = resolve_pointer(doc, pointer)
        if isinstance(holder, Mapping) and isinstance(err.instance, str) and err.instance in holder:
            pointer += f"/{_escape(err.instance)}"  # a bad key (propertyNames): point at the key itself
        field = pointer or "(top level)"
        out.append(Located(file, _line_for(lines, pointer), f"case schema: {field}: {message}"))
    return out


def _case_files(root: Path) -> list[Path]:
    cases = root / "cases"
    if not cases.is_dir():
        raise SuiteError(Located(str(root), None, "no cases/ directory in the suite root"))
    files = {p for pattern in CASE_GLOBS for p in cases.rglob(pattern) if p.is_file()}
    return sorted(files)


def load_suite(root: Path | str | None = None, *, files: Iterable[Path | str] | None = None) -> list[Case]:
    """Every case of the suite at ``root`` (default: the repository's conformance/ directory).

    ``files`` restricts loading to some case files.  Raises :class:`SuiteError` listing every
    malformed case with its ``file:line``.
    """
    root = Path(root) if root is not None else conformance_dir()
    paths = [Path(f) for f in files] if files is not None else _case_files(root)
    out: list[Case] = []
    problems: list[Located] = []
    for path in paths:
        try:
            out.extend(load_case_file(path, root))
        except SuiteError as exc:
            problems.extend(exc.problems)
    if problems:
        raise SuiteError(problems)
    return out


def load_case_file(path: Path | str, root: Path | str | None = None) -> list[Case]:
    """The cases of one file (one case object or a list of them)."""
    path = Path(path)
    root = Path(root) if root is not None else conformance_dir()
    file = _show_path(path)
    try:  # F-LIMITS: bounded reading of a suite file
        text = limits.read_text(path)
    except limits.InputError as exc:
        raise SuiteError(Located(file, exc.line, f"cannot read case file: {exc.message}")) from None
    doc, lines = _compose(text, file)
    problems = _schema_problems(doc, lines, file)
    if problems:
        raise SuiteError(problems)
    entries = doc if isinstance(doc, list) else [doc]
    prefixes = [f"/{i}" for i in range(len(entries))] if isinstance(doc, list) else [""]
    out, errs = [], []
    for entry, prefix in zip(entries, prefixes):
        sub = {k[len(prefix):] : v for k, v in lines.items() if k == prefix or k.startswith(prefix + "/")}
        try:
            out.append(_build_case(entry, sub, path, file, root))
        except SuiteError as exc:
            errs.extend(exc.problems)
    if errs:
        raise SuiteError(errs)
    return out


# --------------------------------------------------------------------------- instances


@lru_cache(maxsize=32)
def _catalogue_instance(scenario: str, index: int) -> str:
    from agspec.catalogue import load_scenario_bundle
    from agspec.ir.instance import make_instance

    sc, recipes, profile = load_scenario_bundle(scenario)
    return json.dumps(make_instance(sc, recipes, profile, index=index))


@lru_cache(maxsize=64)
def _file_json(path: str, mtime: float) -> str:
    return Path(path).read_text(encoding="utf-8")


def _resolve_instance(ref: Any, root: Path, file: str, line: int | None) -> dict[str, Any]:
    if isinstance(ref, str):
        path = (root / ref).resolve()
        try:
            text = _file_json(str(path), path.stat().st_mtime)
            data = json.loads(text)
        except OSError as exc:
            raise SuiteError(Located(file, line, f"instance file {ref!r} (under {_show_path(root)}): {exc.strerror}")) from None
        except json.JSONDecodeError as exc:
            raise SuiteError(Located(file, line, f"instance file {ref!r}: not JSON: {exc}")) from None
        if not isinstance(data, dict) or data.get("kind") != "instance":
            raise SuiteError(Located(file, line, f"instance file {ref!r} does not hold an instance IR"))
        return data
    if isinstance(ref, Mapping) and ref.get("kind") == "instance":
        return copy.deepcopy(dict(ref))  # an inline instance IR (it has a "scenario" key too)
    if isinstance(ref, Mapping) and "scenario" in ref:
        try:
            return json.loads(_catalogue_instance(str(ref["scenario"]), int(ref["index"])))
        except Exception as exc:  # CatalogueError, InstanceError: shown to the suite author
            raise SuiteError(Located(file, line, f"catalogue instance {ref['scenario']!r} index {ref['index']}: {exc}")) from None
    return copy.deepcopy(dict(ref))


def _simulator(instance: Mapping[str, Any], seed: int | None, file: str, line: int | None):
    from agspec.interp.tick import Simulator

    try:
        sim = Simulator(instance)
        sim.reset(seed)
    except Exception as exc:  # a malformed instance: reported, not a traceback
        raise SuiteError(Located(file, line, f"the reference interpreter cannot load the instance: "
                                             f"{type(exc).__name__}: {exc}")) from None
    return sim


# --------------------------------------------------------------------------- symbolic actions


def resolve_action(value: Any, options: Any) -> int:
    """One action as written in a script -> action integer, against one robot's option lists."""
    if isinstance(value, bool):
        raise ValueError(f"{value!r} is not an action")
    if isinstance(value, int):
        return value
    if value == "idle":
        return IDLE
    if value == "deliver":
        return DELIVER
    if isinstance(value, Mapping) and len(value) == 1:
        ((kind, arg),) = value.items()
        if kind == "handoff":
            return HANDOFF0 + DIRECTIONS.index(arg)
        if kind == "receive":
            return RECEIVE0 + DIRECTIONS.index(arg)
        if kind == "support":
            ids = [c.cid for c in options.operations]
            if arg not in ids:
                raise ValueError(f"candidate {arg!r} is not an operation option of this robot "
                                 f"(options: {', '.join(ids) or 'none'})")
            return OP0 + ids.index(arg)
        if kind == "pick":
            ids = [p["id"] for p in options.picks]
            if arg not in ids:
                raise ValueError(f"pick option {arg!r} is not offered to this robot (options: {', '.join(ids) or 'none'})")
            return PICK0 + ids.index(arg)
    raise ValueError(f"{value!r} is not an action")


def _resolve_script(script: list, sim: Any, lines: Mapping[str, int], file: str) -> list[dict[str, int]]:
    from agspec.interp.state import cell_id

    robots = {cell_id(c): c for c in sim.model.cells}
    out = []
    for t, joint in enumerate(script):
        resolved: dict[str, int] = {}
        for robot, value in joint.items():
            line = _line_for(lines, f"/script/{t}/{_escape(robot)}")
            if robot not in robots:
                raise SuiteError(Located(file, line, f"script tick {t}: no robot {robot} on a "
                                                     f"{sim.model.rows}x{sim.model.cols} grid"))
            try:
                a = resolve_action(value, sim.decision.options[robots[robot]])
            except ValueError as exc:
                raise SuiteError(Located(file, line, f"script tick {t}, robot {robot}: {exc}")) from None
            if a != IDLE:
                resolved[robot] = a
        out.append(dict(sorted(resolved.items(), key=lambda kv: tuple(int(x) for x in kv[0].split(",")))))
        sim.step(resolved)
    return out


# --------------------------------------------------------------------------- traces


@lru_cache(maxsize=16)
def _read_trace(path: str, mtime: float) -> tuple[dict[str, Any], tuple[dict[str, Any], ...], str]:
    header, ticks = None, []
    digest = hashlib.sha256()
    with open(path, encoding="utf-8") as fh:
        for lineno, text in enumerate(fh, start=1):
            if not text.strip():
                continue
            try:
                rec = json.loads(text)
            except json.JSONDecodeError as exc:
                raise ValueError(f"line {lineno}: not JSON: {exc}") from None
            kind = rec.get("type") if isinstance(rec, dict) else None
            if kind == "header":
                header = rec
            elif kind == "tick":
                if rec.get("t") != len(ticks):
                    raise ValueError(f"line {lineno}: tick record t={rec.get('t')!r}, expected {len(ticks)}")
                ticks.append(rec)
                digest.update(rfc8785.dumps({"actions": rec["actions"], "events": rec["events"], "state": rec["state"]}))
    if header is None:
        raise ValueError("no header record")
    if not ticks:
        raise ValueError("no tick records")
    return header, tuple(ticks), "sha256:" + digest.hexdigest()


def trace_records(case: Case, root: Path | str | None = None) -> tuple[dict[str, Any], tuple[dict[str, Any], ...]]:
    """(header, tick records) of a trace-driven case."""
    if not case.driver or "trace" not in case.driver:
        raise ValueError(f"case {case.id} is not trace-driven")
    root = Path(root) if root is not None else (case.root or conformance_dir())
    path = (root / case.driver["trace"]).resolve()
    header, ticks, _ = _read_trace(str(path), path.stat().st_mtime)
    return header, ticks


# --------------------------------------------------------------------------- building one case


def _build_case(entry: dict[str, Any], lines: dict[str, int], path: Path, file: str, root: Path) -> Case:
    line = lines.get("", 1)
    inst_line = _line_for(lines, "/instance")
    driver = entry.get("driver")
    expectations = [dict(e) for e in entry.get("expectations", [])]
    for k, e in enumerate(expectations):
        for pointer in list(e.get("state", {})) + list(e.get("absent", [])) + list(e.get("observations", {})):
            try:
                parse_pointer(pointer)
            except PointerError as exc:
                raise SuiteError(Located(file, _line_for(lines, f"/expectations/{k}"), str(exc))) from None
    instance = _resolve_instance(entry["instance"], root, file, inst_line)
    trace_digest = None
    if driver is not None and "trace" in driver:
        tpath = (root / driver["trace"]).resolve()
        try:
            header, ticks, trace_digest = _read_trace(str(tpath), tpath.stat().st_mtime)
        except OSError as exc:
            raise SuiteError(Located(file, _line_for(lines, "/driver/trace"), f"trace {driver['trace']!r}: {exc.strerror}")) from None
        except (ValueError, KeyError, TypeError) as exc:
            raise SuiteError(Located(file, _line_for(lines, "/driver/trace"), f"trace {driver['trace']!r}: {exc}")) from None
        from agspec.ir.fingerprint import fingerprint

        if fingerprint(header["instance"]) != fingerprint(instance):
            raise SuiteError(Located(file, inst_line, f"the instance differs from the one in trace {driver['trace']!r} "
                                                      f"(fingerprints {fingerprint(instance)[:19]}… vs {fingerprint(header['instance'])[:19]}…)"))
    seed = entry.get("execution_seed", _MISSING)
    if seed is _MISSING:
        if driver is not None and "trace" in driver:
            seed = header.get("execution_seed")
        else:
            seed = (instance.get("seeds") or {}).get("execution")
    from agspec.ir.fingerprint import FingerprintError, fingerprint

    try:
        inst_fp = fingerprint(instance)
    except FingerprintError as exc:
        raise SuiteError(Located(file, inst_line, str(exc))) from None

    last = max((e["after_tick"] for e in expectations), default=-1)
    actions: list[dict[str, int]] = []
    if driver is None:
        sim = _simulator(instance, seed, file, inst_line)
        actions = _resolve_script(entry["script"], sim, lines, file)
        actions += [{} for _ in range(last + 1 - len(actions))]
        ticks_n = len(actions)
    elif "trace" in driver:
        actions = [dict(rec["actions"]) for rec in ticks]
        actions = [{r: a for r, a in j.items() if a != IDLE} for j in actions]
        ticks_n = len(actions)
    else:
        ticks_n = int(driver["ticks"])
    for k, e in enumerate(expectations):
        if e["after_tick"] >= ticks_n:
            raise SuiteError(Located(file, _line_for(lines, f"/expectations/{k}/after_tick"),
                                     f"expectation after tick {e['after_tick']}, but the case runs only {ticks_n} ticks"))

    content = {
        "instance": inst_fp,
        "execution_seed": seed,
        "actions": actions if driver is None else None,
        "driver": ({"trace": trace_digest} if driver and "trace" in driver else driver),
        "expectations": expectations,
    }
    try:
        digest = hashlib.sha256(rfc8785.dumps(content)).hexdigest()
    except rfc8785.CanonicalizationError as exc:
        raise SuiteError(Located(file, line, f"case content has no canonical JSON form: {exc}")) from None

    all_expectations = [dict(e, _index=k) for k, e in enumerate(expectations)]
    if driver and "trace" in driver:
        for rec in ticks:  # the trace is the expected run: every state and every event of every tick
            all_expectations.append({"after_tick": rec["t"], "state": {"": rec["state"]}, "events": rec["events"],
                                     "_index": "trace"})
    lines_out = {"": line}
    for k in range(len(entry.get("script", []))):
        lines_out[f"script/{k}"] = lines.get(f"/script/{k}", line)
    for k in range(len(expectations)):
        lines_out[f"expectations/{k}"] = lines.get(f"/expectations/{k}", line)
    if driver and "trace" in driver:
        lines_out["expectations/trace"] = _line_for(lines, "/driver") or line

    ref = entry["instance"]
    return Case(
        id="c-" + digest[:12],
        title=entry["title"],
        rules=tuple(entry["rules"]),
        invariants=tuple(entry.get("invariants", [])),
        tags=tuple(entry.get("tags", [])),
        instance=instance,
        execution_seed=seed,
        actions=tuple(actions),
        driver=dict(driver) if driver else None,
        expectations=tuple(all_expectations),
        source=path,
        line=line,
        fingerprint="sha256:" + digest,
        instance_ref=ref if not (isinstance(ref, Mapping) and "kind" in ref) else "inline",
        lines=lines_out,
        notes=entry.get("notes", ""),
        root=root,
    )


# =============================================================================================
# running a case on the reference interpreter (used by lint, tests and the reference adapter)


@dataclass(frozen=True)
class TickResult:
    t: int  # the epoch the joint action was applied at (after_tick)
    actions: dict[str, int]  # submitted
    applied: dict[str, int]
    state: dict[str, Any]
    events: list[dict[str, Any]]
    observations: dict[str, Any] | None
    done: bool


def reference_run(case: Case, *, observations: bool | Iterable[int] = False) -> Iterator[TickResult]:
    """Run ``case`` on the reference interpreter, one :class:`TickResult` per transition.

    ``observations``: True for every tick, or the ticks after which observations are wanted.
    """
    from agspec.interp.snapshot import global_state
    from agspec.interp.tick import Simulator

    want = observations if isinstance(observations, bool) else set(observations)
    sim = Simulator(case.instance)
    sim.reset(case.execution_seed)
    ctl = None
    if case.driver is not None and "controller" in case.driver:
        from agspec.controllers import make_controller

        seed = case.driver.get("seed")
        seed = case.execution_seed if seed is None else seed
        ctl = make_controller(case.driver["controller"], seed)
        ctl.reset(seed)
    for t in range(case.ticks):
        if ctl is not None:
            actions = ctl.act(sim.observe(), sim if ctl.information == "global" else None)
        else:
            actions = case.actions[t]
        result = sim.step(actions)
        obs = sim.observe() if (want is True or (want is not False and t in want)) else None
        yield TickResult(t, dict(actions), dict(result.applied), global_state(sim.state), result.events, obs, sim.done)


def check_reference(case: Case) -> list[str]:
    """Run ``case`` on the reference and return every failed expectation (empty: the case passes)."""
    ticks = {e["after_tick"] for e in case.expectations if "observations" in e}
    out: list[str] = []
    for r in reference_run(case, observations=ticks):
        out += check_expectations(case, r.t, r.state, r.events, observations=r.observations, done=r.done)
    return out


# =============================================================================================
# coverage


def coverage(cases: Sequence[Case], universe: Sequence[str] | None = None) -> dict[str, Any]:
    """Which spec rules and invariants the cases exercise.

    ``{"rules": {ID: [case ids]}, "invariants": {ID: [case ids]}, "uncovered": [IDs]}`` over the
    ``### R-…`` and ``### INV-…`` headings of spec/ (every declared ID appears as a key).
    """
    from agspec.spec_index import spec_ids

    ids = list(universe) if universe is not None else spec_ids(("R-", "INV-"))
    rules: dict[str, list[str]] = {i: [] for i in ids if i.startswith("R-")}
    invariants: dict[str, list[str]] = {i: [] for i in ids if i.startswith("INV-")}
    for case in cases:
        for rid in case.rules:
            if rid in rules and case.id not in rules[rid]:
                rules[rid].append(case.id)
        for iid in case.invariants:
            if iid in invariants and case.id not in invariants[iid]:
                invariants[iid].append(case.id)
    uncovered = [i for i in ids if not (rules.get(i) or invariants.get(i))]
    return {"rules": rules, "invariants": invariants, "uncovered": uncovered}


# =============================================================================================
# self-lint


def lint_suite(cases: Sequence[Case], *, run: bool = True) -> list[str]:
    """The suite's self-check; each problem is ``file:line: message``. Empty means clean.

    * case ids are unique (two cases with the same defining content are duplicates);
    * every cited rule / invariant ID is a heading of the spec;
    * every instance passes the instance schema and the semantic checks (AG5xx errors);
    * every case asserts something (no vacuous case);
    * with ``run``: on the reference interpreter, every scripted action is legal under the mask
      unless the case cites R-ACTION-VALIDATION (masked actions must be deliberate), and every
      asserted state or observation pointer exists.
    """
    from agspec.ir.fingerprint import fingerprint
    from agspec.ir.schemas import validate_schema
    from agspec.ir.validate import errors, validate_instance
    from agspec.spec_index import spec_ids

    problems: list[str] = []
    known = set(spec_ids(("R-", "INV-")))
    seen: dict[str, Case] = {}
    checked: dict[str, list[str]] = {}
    for case in cases:
        loc = case.location
        if case.id in seen:
            problems.append(f"{loc}: duplicate case id {case.id}: same content as {seen[case.id].location}")
        seen.setdefault(case.id, case)
        for ident in case.rules + case.invariants:
            if ident not in known:
                problems.append(f"{loc}: {ident} is not a rule or invariant heading of the spec")
        fp = fingerprint(case.instance)
        if fp not in checked:
            issues = errors(validate_schema(case.instance)) or errors(validate_instance(case.instance))
            checked[fp] = [f"{i.code} {i.pointer or '/'}: {i.message}" for i in issues]
        for msg in checked[fp]:
            problems.append(f"{case.location}: instance {case.instance.get('id')!r}: {msg}")
        if not case.expectations:
            problems.append(f"{loc}: the case asserts nothing (no expectations)")
        for ident, wanted in (("R-", case.rules), ("INV-", case.invariants)):
            if not wanted and ident == "R-":
                problems.append(f"{loc}: the case cites no rule")
        if run and not checked[fp]:
            problems += _lint_run(case)
    return problems


def _lint_run(case: Case) -> list[str]:
    out: list[str] = []
    file = _show_path(case.source)
    deliberate = "R-ACTION-VALIDATION" in case.rules
    obs_ticks = {e["after_tick"] for e in case.expectations if "observations" in e}
    try:
        for r in reference_run(case, observations=obs_ticks):
            if case.driver is None and not deliberate:
                for robot, a in r.actions.items():
                    if r.applied.get(robot) != a:
                        line = case.line_of(f"script/{r.t}")
                        out.append(f"{file}:{line}: script tick {r.t}, robot {robot}: action {a} is masked for the "
                                   "reference (coerced to idle); cite R-ACTION-VALIDATION if that is intended")
            for k, exp in enumerate(case.expectations):
                if exp["after_tick"] != r.t or exp.get("_index") == "trace":
                    continue
                line = case.line_of(f"expectations/{exp.get('_index', k)}")
                for pointer in exp.get("state", {}):
                    toks = parse_pointer(pointer)
                    if toks and toks[0] not in STATE_KEYS:
                        out.append(f"{file}:{line}: {pointer}: the global state has no field {toks[0]!r}")
                    elif resolve_pointer(r.state, pointer) is _MISSING:
                        out.append(f"{file}:{line}: {pointer} does not exist in the reference state after tick {r.t}")
                for pointer in exp.get("observations", {}):
                    if r.observations is not None and resolve_pointer(r.observations, pointer) is _MISSING:
                        out.append(f"{file}:{line}: observation {pointer} does not exist after tick {r.t}")
    except Exception as exc:  # the reference crashing on a case is a suite problem worth a located report
        out.append(f"{case.location}: the reference interpreter failed: {type(exc).__name__}: {exc}")
    return out
