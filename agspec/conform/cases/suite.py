"""Loading the suite: YAML with line numbers, the case schema, instances, symbolic scripts
(F-SYMBOLIC-ACTIONS), trace drivers and content-fingerprint ids."""

from __future__ import annotations

import copy
import hashlib
import json
from functools import lru_cache
from pathlib import Path
from typing import Any, Iterable, Mapping

import rfc8785
import yaml
from jsonschema.exceptions import best_match

from agspec.catalogue import load_scenario_bundle
from agspec.conform.cases.model import CASE_GLOBS, Case, Located, SuiteError, _show_path
from agspec.formats import limits
from agspec.formats.actions import IDLE, IllegalAction, resolve
from agspec.formats.jsonl import iter_lines
from agspec.formats.pointer import MISSING, PointerError, escape, show
from agspec.formats.pointer import parse as parse_pointer
from agspec.formats.pointer import resolve as resolve_pointer
from agspec.formats.schemas import validator
from agspec.interp.state import cell_id
from agspec.interp.tick import Simulator
from agspec.ir.fingerprint import FingerprintError, fingerprint
from agspec.ir.instance import make_instance
from agspec.resources import conformance_dir

# =============================================================================================
# YAML with line numbers


def _compose(text: str, file: str) -> tuple[Any, dict[str, int]]:
    """Parse YAML (JSON is YAML) into plain values plus a map JSON Pointer -> 1-based line."""
    try:  # F-LIMITS: alias bombs, depth, long scalars and duplicate keys refused before anything is built
        node = limits.compose_yaml(text, file, limits.Limits.from_env())
    except limits.InputError as exc:
        raise SuiteError(Located(file, exc.line, str(exc))) from None
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
                out[key] = conv(v, f"{ptr}/{escape(key)}")
            return out
        if isinstance(n, yaml.SequenceNode):
            return [conv(v, f"{ptr}/{i}") for i, v in enumerate(n.value)]
        try:
            return constructor.construct_object(n, deep=True)
        except yaml.YAMLError as exc:
            raise SuiteError(Located(file, n.start_mark.line + 1, f"bad YAML value: {exc}")) from None

    return conv(node, ""), lines


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
# loading


def _schema_problems(doc: Any, lines: Mapping[str, int], file: str) -> list[Located]:
    errors = list(validator("case").iter_errors(doc))
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
                message = f"{show(err.instance)} matches none of the allowed forms" + (f" ({desc})" if desc else "")
                break
            err, message = sub, sub.message
        if err.validator == "pattern" and isinstance(err.schema, Mapping) and err.schema.get("description"):
            message = f"{show(err.instance)} is not {err.schema['description']}"
        pointer = "".join(f"/{escape(str(p))}" for p in err.absolute_path)
        holder = resolve_pointer(doc, pointer)
        if isinstance(holder, Mapping) and isinstance(err.instance, str) and err.instance in holder:
            pointer += f"/{escape(err.instance)}"  # a bad key (propertyNames): point at the key itself
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
    file = _show_path(path, root)
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

    sc, recipes, profile = load_scenario_bundle(scenario)
    return json.dumps(make_instance(sc, recipes, profile, index=index))


@lru_cache(maxsize=64)
def _file_json(path: str, mtime: float) -> str:
    return limits.read_text(path)  # F-LIMITS: a case may name any file


def _resolve_instance(ref: Any, root: Path, file: str, line: int | None) -> dict[str, Any]:
    if isinstance(ref, str):
        path = (root / ref).resolve()
        try:
            text = _file_json(str(path), path.stat().st_mtime)
            data = limits.parse_json(text, str(path))
        except OSError as exc:
            raise SuiteError(Located(file, line, f"instance file {ref!r} (under {_show_path(root)}): {exc.strerror}")) from None
        except limits.InputError as exc:
            raise SuiteError(Located(file, line, f"instance file {ref!r}: {exc}")) from None
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

    try:
        sim = Simulator(instance)
        sim.reset(seed)
    except Exception as exc:  # a malformed instance: reported, not a traceback
        raise SuiteError(Located(file, line, f"the reference interpreter cannot load the instance: "
                                             f"{type(exc).__name__}: {exc}")) from None
    return sim


# --------------------------------------------------------------------------- symbolic actions


def _resolve_script(script: list, sim: Any, lines: Mapping[str, int], file: str) -> list[dict[str, int]]:

    robots = {cell_id(c): c for c in sim.model.cells}
    out = []
    for t, joint in enumerate(script):
        resolved: dict[str, int] = {}
        for robot, value in joint.items():
            line = _line_for(lines, f"/script/{t}/{escape(robot)}")
            if robot not in robots:
                raise SuiteError(Located(file, line, f"script tick {t}: no robot {robot} on a "
                                                     f"{sim.model.rows}x{sim.model.cols} grid"))
            try:
                options = sim.decision.options[robots[robot]]
                a = resolve(value, [p["id"] for p in options.picks], [c.cid for c in options.operations])
            except IllegalAction as exc:
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
    for line in iter_lines(path):
        if not line.ok:
            raise ValueError(f"line {line.lineno}: {line.error}")
        rec = line.value
        kind = rec.get("type") if isinstance(rec, dict) else None
        if kind == "header":
            header = rec
        elif kind == "tick":
            if rec.get("t") != len(ticks):
                raise ValueError(f"line {line.lineno}: tick record t={rec.get('t')!r}, expected {len(ticks)}")
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
        except (ValueError, KeyError, TypeError, limits.InputError) as exc:  # F-LIMITS: a special or huge file
            raise SuiteError(Located(file, _line_for(lines, "/driver/trace"), f"trace {driver['trace']!r}: {exc}")) from None

        if fingerprint(header["instance"]) != fingerprint(instance):
            raise SuiteError(Located(file, inst_line, f"the instance differs from the one in trace {driver['trace']!r} "
                                                      f"(fingerprints {fingerprint(instance)[:19]}… vs {fingerprint(header['instance'])[:19]}…)"))
    seed = entry.get("execution_seed", MISSING)
    if seed is MISSING:
        if driver is not None and "trace" in driver:
            seed = header.get("execution_seed")
        else:
            seed = (instance.get("seeds") or {}).get("execution")

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
