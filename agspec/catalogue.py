"""The official catalogue: scenario names, index splits, and the catalogue lock (F-LOCK).

The lock file ``catalogue/lock.json`` (schema ``schemas/lock.schema.json``) pins the content of
the official scenarios: the fingerprint of each scenario, of the recipes and profile it uses, and
of its realizations for suite indices 0-4 (agspec fingerprint and the original release's
``instance_sha256``). ``agspec catalogue verify`` recomputes these and reports any drift.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping, Sequence

from agspec import IR_VERSION
from agspec.formats import limits, output
from agspec.formats.schemas import self_check
from agspec.interop.original import ExportError, instance_definition, instance_sha256
from agspec.ir.fingerprint import fingerprint
from agspec.ir.instance import make_instance
from agspec.resources import catalogue_dir
from agspec.suggest import did_you_mean

# Table order of the paper (family-major, easy -> hard).
OFFICIAL_SCENARIOS: tuple[str, ...] = (
    "flow-easy", "flow-medium", "flow-hard",
    "coalition-easy", "coalition-medium", "coalition-hard",
    "concurrency-easy", "concurrency-medium", "concurrency-hard",
)
# Matched geometry control (not official): supported_insert, WIP 4, interval 5, conflict variants.
GEOMETRY_MATCHED: tuple[str, ...] = ("geometry-matched-low", "geometry-matched-medium", "geometry-matched-high")

SPLITS: dict[str, range] = {
    "catalogue": range(0, 5),
    "training": range(0, 5),
    "validation": range(200, 205),
    "final-test": range(1000, 1050),
    "geometry-matched": range(0, 50),
}

LOCK_SCHEMA = "agspec-catalogue-lock/1"
LOCK_INDICES: tuple[int, ...] = tuple(SPLITS["catalogue"])

Bundle = tuple[dict[str, Any], dict[str, dict[str, Any]], dict[str, Any]]
LoadFn = Callable[[str], Bundle]


class CatalogueError(ValueError):
    """A scenario cannot be found or loaded, or an index list is malformed (usage error)."""


class InvalidDocumentError(CatalogueError):
    """A scenario, recipe or profile document has errors (message = rendered diagnostics)."""


class InvalidInstanceError(ValueError):
    """An instance IR file violates its schema, or no instance can be generated (invalid input)."""


# --------------------------------------------------------------------------- indices


def parse_indices(text: str, limit: int | None = None) -> list[int]:
    """Parse ``"1000-1049,3"`` (ranges inclusive) or a split name into indices, in order, deduplicated.

    ``limit`` bounds the number of indices before any range is expanded, so ``0-1000000000`` fails
    at once instead of running forever.
    """
    text = (text or "").strip()
    if text in SPLITS:
        return list(SPLITS[text])
    out: list[int] = []
    seen: set[int] = set()
    for part in text.split(","):
        part = part.strip()
        if not part:
            raise CatalogueError(f"empty item in index list `{text}`")
        lo, sep, hi = part.partition("-")
        try:
            first = int(lo)
            last = int(hi) if sep else first
        except ValueError:
            raise CatalogueError(
                f"`{part}` is not an index, a range like 1000-1049, or a split ({', '.join(SPLITS)})"
            ) from None
        if first < 0 or last < first:
            raise CatalogueError(f"invalid index range `{part}`")
        if limit is not None and len(seen) + (last - first + 1) > limit:
            raise CatalogueError(f"index list `{text}` has more than {limit} indices")
        for i in range(first, last + 1):
            if i not in seen:
                seen.add(i)
                out.append(i)
    return out


# --------------------------------------------------------------------------- loading


def load_scenario_bundle(name_or_path: str | Path, search_paths: Sequence[str | Path] = ()) -> Bundle:
    """(scenario_ir, recipes, profile_ir) for a scenario name or a scenario ``.ag``/``.json`` file.

    Names resolve through ``agspec.load.Resolver`` (search paths, then the official catalogue);
    recipes and the profile resolve from the scenario document (its ``use`` includes and
    directory tree first). Every document is fully checked (schema, references, semantics)
    before it is realized. Failures raise :class:`CatalogueError` (unknown names, missing
    files) or :class:`InvalidDocumentError` (documents with errors), with a message that can be
    shown to a person as is.
    """
    from agspec.load import Resolver, check_document, load_document

    resolver = Resolver(search_paths)
    target = str(name_or_path)
    path = Path(target)
    if path.suffix.lower() in (".ag", ".json") or path.exists():
        try:  # F-LIMITS: a directory, FIFO or device is refused before it is opened
            limits.check_file(path)
        except limits.InputError as exc:
            if exc.exit_code == limits.EXIT_USAGE:
                raise CatalogueError(str(exc)) from None
        doc = load_document(path)
    else:
        found = resolver.resolve_scenario_name(target)
        if found is None:
            raise CatalogueError(_unknown_scenario(target, resolver.names("scenario")))
        doc = resolver.load_path(found)
    _check(doc, resolver, check_document)
    if doc.kind != "scenario":
        raise CatalogueError(f"{target} holds a {doc.kind} document, not a scenario")
    bound = resolver.bind(doc)
    scenario = doc.ir
    recipes = {}
    for rid in dict.fromkeys(scenario.get("recipes", [])):
        recipes[rid] = _dependency(bound, doc, "recipe", rid, check_document)
    profile = _dependency(bound, doc, "profile", scenario["profile"]["id"], check_document)
    return scenario, recipes, profile


def read_instance_file(target: str | Path) -> dict[str, Any] | None:
    """The instance IR held by a ``.json`` file (schema-checked, S-INSTANCE), or None when ``target``
    is not an instance file.  Unreadable files raise CatalogueError, schema violations
    InvalidInstanceError (message located by JSON Pointer)."""
    path = Path(target)
    if path.suffix != ".json" or not path.exists():
        return None
    try:
        data = limits.load_json(path)
    except limits.InputError as exc:  # F-EXIT-CODES: I/O faults are usage errors, bad content invalid input
        raise (CatalogueError if exc.exit_code == limits.EXIT_USAGE else InvalidInstanceError)(str(exc)) from None
    if not (isinstance(data, dict) and data.get("kind") == "instance"):
        return None
    from agspec.ir.schemas import validate_schema

    problems = validate_schema(data)
    if not problems:  # S-INSTANCE consistency (AG5xx): a simulator must never see an inconsistent instance
        from agspec.ir.validate import errors, validate_instance

        problems = errors(validate_instance(data))
    if problems:
        first = problems[0]
        raise InvalidInstanceError(f"{target}{first.pointer or ''}: error[{first.code}]: {first.message}")
    return data


def load_instance(target: str | Path, index: int | None = None, seed: int | None = None,
                  search_paths: Sequence[str | Path] = ()) -> dict[str, Any]:
    """An instance IR from an instance ``.json`` file, or realized from a scenario name or file at
    suite ``index`` (default 0) or generation ``seed`` (S-SEEDS).  Raises CatalogueError (not found,
    unreadable, invalid scenario) or InvalidInstanceError (bad instance file, no instance possible)."""
    inst = read_instance_file(target)
    if inst is not None:
        return inst
    scenario, recipes, profile = load_scenario_bundle(target, search_paths)
    if index is None and seed is None:
        index = 0
    try:
        return make_instance(scenario, recipes, profile, index=index, generation_seed=seed)
    except (ValueError, KeyError, TypeError) as exc:
        raise InvalidInstanceError(f"{target}: cannot generate an instance: {exc}") from None


def _check(doc: Any, resolver: Any, check_document: Callable[..., list]) -> None:
    from agspec.load import io_fault

    diags = [d for d in check_document(doc, resolver) if d.severity == "error"]
    if io_fault(doc, diags):
        raise CatalogueError("\n".join(d.render() for d in diags))
    if diags:
        raise InvalidDocumentError("\n".join(d.render(doc.text) for d in diags))


def _dependency(bound: Any, origin: Any, kind: str, name: str, check_document: Callable[..., list]) -> dict:
    dep = bound.load(kind, name, origin)
    if dep is None:  # check_document reported AG005 already; kept for safety
        raise InvalidDocumentError(f"{origin.file}: cannot resolve {kind} `{name}`")
    _check(dep, bound, check_document)
    return dep.ir


def _unknown_scenario(name: str, known: Iterable[str] = ()) -> str:
    return (f"unknown scenario `{name}`{did_you_mean(name, [*OFFICIAL_SCENARIOS, *GEOMETRY_MATCHED, *known])} "
            f"(official: {', '.join(OFFICIAL_SCENARIOS)}; "
            f"matched: {', '.join(GEOMETRY_MATCHED)}; or give a .ag/.json file)")


# --------------------------------------------------------------------------- lock


def scenario_lock_entry(bundle: Bundle, indices: Iterable[int] = LOCK_INDICES) -> dict[str, Any]:
    """Lock data of one scenario: its fingerprints and those of its realizations."""
    scenario, recipes, profile = bundle
    instances = []
    for index in indices:
        inst = make_instance(scenario, recipes, profile, index=index)
        try:
            digest: str | None = instance_sha256(instance_definition(inst))
        except ExportError:
            digest = None  # not expressible in the original's identity (non-registry recipe)
        instances.append({"index": index, "id": inst["id"], "fingerprint": fingerprint(inst),
                          "instance_sha256": digest})
    return {
        "fingerprint": fingerprint(scenario),
        "recipes": {rid: fingerprint(recipes[rid]) for rid in dict.fromkeys(scenario["recipes"])},
        "profile": {"id": profile.get("id"), "variant": (scenario.get("profile") or {}).get("variant"),
                    "fingerprint": fingerprint(profile)},
        "instances": instances,
    }


def lock_entries(
    load_fn: LoadFn, names: Sequence[str] = OFFICIAL_SCENARIOS, indices: Iterable[int] = LOCK_INDICES
) -> dict[str, Any]:
    """The lock document for ``names`` (default: the 9 official scenarios x indices 0-4)."""
    indices = list(indices)
    return {
        "schema": LOCK_SCHEMA,
        "ir_version": IR_VERSION,
        "indices": indices,
        "scenarios": {name: scenario_lock_entry(load_fn(name), indices) for name in names},
    }


def _short(fp: Any) -> str:
    return str(fp)[:19] + "…" if isinstance(fp, str) and len(fp) > 20 else str(fp)


def verify_lock(current: Mapping[str, Any], locked: Mapping[str, Any]) -> list[str]:
    """Drift messages between freshly computed lock data and the locked data ([] = no drift)."""
    drift: list[str] = []
    if current.get("ir_version") != locked.get("ir_version"):
        drift.append(f"IR version: locked {locked.get('ir_version')}, now {current.get('ir_version')}")
    if list(current.get("indices", [])) != list(locked.get("indices", [])):
        drift.append(f"locked indices {locked.get('indices')} differ from {current.get('indices')}")
    cur_s, old_s = current.get("scenarios", {}), locked.get("scenarios", {})
    for name in old_s:
        if name not in cur_s:
            drift.append(f"scenario `{name}` is locked but no longer in the catalogue")
    for name, cur in cur_s.items():
        old = old_s.get(name)
        if old is None:
            drift.append(f"scenario `{name}` is not in the lock")
            continue
        if cur["fingerprint"] != old.get("fingerprint"):
            drift.append(f"scenario `{name}` changed: fingerprint {_short(old.get('fingerprint'))} -> "
                         f"{_short(cur['fingerprint'])}")
        old_r = old.get("recipes", {})
        for rid, fp in cur.get("recipes", {}).items():
            if old_r.get(rid) != fp:
                what = "changed" if rid in old_r else "is new"
                drift.append(f"scenario `{name}`: recipe `{rid}` {what}: fingerprint "
                             f"{_short(old_r.get(rid))} -> {_short(fp)}")
        for rid in old_r:
            if rid not in cur.get("recipes", {}):
                drift.append(f"scenario `{name}`: recipe `{rid}` is no longer used")
        cp, op = cur.get("profile", {}), old.get("profile", {})
        if cp != op:
            drift.append(f"scenario `{name}`: profile changed: {op.get('id')}/{op.get('variant')} "
                         f"{_short(op.get('fingerprint'))} -> {cp.get('id')}/{cp.get('variant')} "
                         f"{_short(cp.get('fingerprint'))}")
        old_i = {e.get("index"): e for e in old.get("instances", [])}
        for inst in cur.get("instances", []):
            prev = old_i.get(inst["index"])
            label = f"instance `{inst['id']}` ({name} index {inst['index']})"
            if prev is None:
                drift.append(f"{label} is not in the lock")
                continue
            if prev.get("id") != inst["id"]:
                drift.append(f"{label}: id changed from `{prev.get('id')}`")
            if prev.get("fingerprint") != inst["fingerprint"]:
                drift.append(f"{label}: realization changed: fingerprint {_short(prev.get('fingerprint'))} -> "
                             f"{_short(inst['fingerprint'])}")
            if prev.get("instance_sha256") != inst["instance_sha256"]:
                drift.append(f"{label}: original instance_sha256 changed: {_short(prev.get('instance_sha256'))}"
                             f" -> {_short(inst['instance_sha256'])}")
    return drift


def lock_path() -> Path:
    return catalogue_dir() / "lock.json"


def lock_text(lock: Mapping[str, Any]) -> str:
    """The lock file's exact text: 2-space JSON, key order as built, trailing newline."""
    return json.dumps(lock, indent=2, ensure_ascii=False) + "\n"


def read_lock(path: Path | None = None) -> dict[str, Any]:
    path = path or lock_path()
    if not path.exists():
        raise CatalogueError(f"no lock file at {path}; create it with `agspec catalogue verify --update`")
    try:
        data = limits.load_json(path)
    except limits.InputError as exc:
        raise CatalogueError(f"cannot read lock file: {exc}") from None
    if not isinstance(data, dict) or data.get("schema") != LOCK_SCHEMA:
        raise CatalogueError(f"{path} is not an agspec catalogue lock ({LOCK_SCHEMA})")
    return data


def write_lock(lock: Mapping[str, Any], path: Path | None = None) -> Path:
    path = path or lock_path()
    self_check("catalogue-lock", lock)  # F-SCHEMAS-SELF
    output.write_text(path, lock_text(lock))  # F-OUTPUT-FAILURES
    return path
