"""CLI: `instance`, `fingerprint`, `export`, `catalogue list|verify|lock`."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, NoReturn

import click
from rich import box
from rich.markup import escape
from rich.table import Table

from agspec.catalogue import GEOMETRY_MATCHED, OFFICIAL_SCENARIOS, CatalogueError, InvalidDocumentError
from agspec.catalogue import load_scenario_bundle, lock_entries, lock_path, read_lock, verify_lock, write_lock
from agspec.cli.common import EXIT_INVALID, EXIT_OK, EXIT_USAGE, FORMAT_OPTION, SEED_RANGE, Choice, emit_json, error
from agspec.cli.common import fail, stderr, stdout
from agspec.formats import limits
from agspec.formats.output import write_text
from agspec.interop.original import ExportError, instance_definition, instance_sha256, original_instance_id
from agspec.ir.fingerprint import FingerprintError
from agspec.ir.fingerprint import fingerprint as ir_fingerprint
from agspec.ir.instance import InstanceError, make_instance
from agspec.load import Resolver, check_document, io_fault, load_document
from agspec.resources import catalogue_dir

EXPORT_FORMATS = ("assemblygrid-instance-v1",)


def _fail(message: str, code: int) -> NoReturn:
    """common.fail with the message shown literally (paths and diagnostics contain brackets)."""
    fail(message, code)


def _error(message: str) -> None:
    error(message)


def _json_text(data: Any) -> str:
    return json.dumps(data, indent=2, ensure_ascii=False) + "\n"


def _write(path: Path, text: str) -> None:
    write_text(path, text)  # F-OUTPUT-FAILURES


def _bundle(name: str) -> tuple[dict, dict, dict]:
    try:
        return load_scenario_bundle(name)
    except InvalidDocumentError as exc:
        _fail(str(exc), EXIT_INVALID)
    except CatalogueError as exc:
        _fail(str(exc), EXIT_USAGE)


def _make(name: str, index: int | None, seed: int | None, execution_seed: int | None) -> dict[str, Any]:
    if index is not None and seed is not None:
        _fail("give either --index or --generation-seed, not both", EXIT_USAGE)
    if index is None and seed is None:
        index = 0
    scenario, recipes, profile = _bundle(name)
    try:
        return make_instance(scenario, recipes, profile, index=index, generation_seed=seed,
                             execution_seed=execution_seed)
    except InstanceError as exc:
        _fail(str(exc), EXIT_USAGE)


INDEX_OPTION = click.option("--index", type=SEED_RANGE, default=None,
                            help="Suite index k (generation seed = base + k). Default: 0.")
SEED_OPTION = click.option("--generation-seed", "seed", type=SEED_RANGE, default=None,
                           help="An instance from this explicit generation seed instead of --index (S-SEEDS).")


@click.command("instance")
@click.argument("scenario")
@INDEX_OPTION
@SEED_OPTION
@click.option("--execution-seed", type=SEED_RANGE, default=None, help="Override the execution seed.")
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Write the instance IR to FILE instead of stdout.")
def instance(scenario: str, index: int | None, seed: int | None, execution_seed: int | None,
             output: Path | None) -> None:
    """Realize SCENARIO (official name or .ag/.json file) into a self-contained instance IR."""
    inst = _make(scenario, index, seed, execution_seed)
    if output is None:
        emit_json(inst, "instance")
        return
    _write(output, _json_text(inst))
    stderr.print(f"wrote {output}: {inst['id']}  {ir_fingerprint(inst)}", markup=False)


# --------------------------------------------------------------------------- fingerprint


def _load_ir(target: str) -> dict[str, Any]:
    """The checked IR of a .json file, an .ag file, or an official scenario name (F-FINGERPRINT hashes
    only valid documents). Raises CatalogueError (not found, unreadable) or InvalidDocumentError."""
    path = Path(target)
    if path.suffix in (".json", ".ag") or path.exists():
        doc = load_document(path)
        diags = [d for d in check_document(doc, Resolver()) if d.severity == "error"]
        if io_fault(doc, diags):
            raise CatalogueError("\n".join(d.render() for d in diags))
        if diags or doc.ir is None:
            raise InvalidDocumentError("\n".join(d.render(doc.text) for d in diags) or f"{target}: cannot load")
        return doc.ir
    return load_scenario_bundle(target)[0]


@click.command("fingerprint")
@click.argument("files", nargs=-1, required=True)
@FORMAT_OPTION
def fingerprint(files: tuple[str, ...], fmt: str) -> None:
    """Print the F-FINGERPRINT of IR .json files, .ag files, or official scenario names."""
    rows, code = [], EXIT_OK
    for target in files:
        try:
            ir = _load_ir(target)
            fp = ir_fingerprint(ir)
        except InvalidDocumentError as exc:
            _error(str(exc))
            code = max(code, EXIT_INVALID)
            continue
        except CatalogueError as exc:
            _error(str(exc))
            code = max(code, EXIT_USAGE)
            continue
        except (ValueError, FingerprintError) as exc:
            _error(str(exc))
            code = max(code, EXIT_INVALID)
            continue
        rows.append({"path": target, "kind": ir.get("kind"), "id": ir.get("id"), "fingerprint": fp})
    if fmt == "json":
        emit_json(rows, "fingerprint")
    else:
        for row in rows:
            stdout.print(f"{row['fingerprint']}  {row['path']}", markup=False)
    raise SystemExit(code)


# --------------------------------------------------------------------------- export


def _instance_for_export(target: str, index: int | None, seed: int | None) -> dict[str, Any]:
    path = Path(target)
    if path.suffix == ".json" and path.exists():
        try:
            data = limits.load_json(path)
        except limits.InputError as exc:
            _fail(str(exc), exc.exit_code)
        if isinstance(data, dict) and data.get("kind") == "instance":
            if index is not None or seed is not None:
                _fail("--index/--generation-seed cannot be used with an instance file", EXIT_USAGE)
            return data
    return _make(target, index, seed, None)


@click.command("export")
@click.argument("scenario")
@INDEX_OPTION
@SEED_OPTION
@click.option("--to", "to_format", type=Choice(EXPORT_FORMATS), default=EXPORT_FORMATS[0],
              show_default=True, help="Target format.")
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Write the definition to FILE (default: stdout).")
def export(scenario: str, index: int | None, seed: int | None, to_format: str, output: Path | None) -> None:
    """Export SCENARIO at an index (or an instance .json) as the original's instance definition."""
    inst = _instance_for_export(scenario, index, seed)
    try:
        defn = instance_definition(inst)
    except ExportError as exc:
        _fail(str(exc), EXIT_INVALID)
    except (KeyError, TypeError) as exc:
        _fail(f"{scenario}: not a complete instance IR ({exc})", EXIT_INVALID)
    digest, oid = instance_sha256(defn), original_instance_id(inst)
    text = json.dumps(defn, indent=2, sort_keys=True, ensure_ascii=False) + "\n"
    if output is None:
        click.echo(text, nl=False)
        stderr.print(f"{digest}  {oid}", markup=False)
    else:
        _write(output, text)
        stdout.print(f"{digest}  {oid}", markup=False)


# --------------------------------------------------------------------------- catalogue


@click.group("catalogue")
def catalogue() -> None:
    """The official scenarios and their lock (catalogue/lock.json)."""


@catalogue.command("list")
@FORMAT_OPTION
def catalogue_list(fmt: str) -> None:
    """List the official and geometry-matched scenarios."""
    rows = []
    for name in (*OFFICIAL_SCENARIOS, *GEOMETRY_MATCHED):
        scenario, _, _ = _bundle(name)
        grid, release = scenario["grid"], scenario["release"]
        rows.append({
            "name": name, "family": scenario.get("family"), "level": scenario.get("level"),
            "official": bool((scenario.get("suite") or {}).get("official")),
            "grid": f"{grid['rows']}x{grid['cols']}", "recipes": list(scenario["recipes"]),
            "variant": (scenario.get("profile") or {}).get("variant"),
            "wip_cap": release["wip_cap"], "interval": release["interval"],
            "fingerprint": ir_fingerprint(scenario),
        })
    if fmt == "json":
        emit_json(rows, "catalogue-list")
        return
    table = Table(title="AssemblyGrid v1 catalogue", box=box.SIMPLE_HEAD, show_edge=False, pad_edge=False, padding=(0, 1), collapse_padding=True,
                  caption="the name is what commands take (agspec run NAME); "
                          "* geometry-matched control (not official): abstract-v1 variant conflict-<level>")
    # family and level are in the name (`{family}-{level}`, RES-SCENARIO-IDS)
    for col in ("name", "grid", "recipe", "WIP", "interval", "sha256"):
        table.add_column(col, no_wrap=True, style="bold" if col == "name" else None)
    for r in rows:
        cells = (r["name"] + ("" if r["official"] else "*"), r["grid"], ", ".join(r["recipes"]),
                 str(r["wip_cap"]), str(r["interval"]), r["fingerprint"].removeprefix("sha256:")[:8] + "…")
        table.add_row(*(escape(str(c)) for c in cells))
    stdout.print(table, soft_wrap=False)


def _current_lock(root: Path | None) -> dict[str, Any]:
    """Lock data recomputed from the catalogue at ``root`` (default: the one agspec was installed with)."""
    if root is None:
        load = load_scenario_bundle
    else:
        def load(name: str) -> Any:
            return load_scenario_bundle(root / "scenarios" / f"{name}.ag")
    try:
        return lock_entries(load)
    except InvalidDocumentError as exc:
        _fail(str(exc), EXIT_INVALID)
    except CatalogueError as exc:
        _fail(str(exc), EXIT_USAGE)
    except InstanceError as exc:
        _fail(f"cannot realize the catalogue: {exc}", EXIT_INVALID)


def _which_catalogue(root: Path | None) -> str:
    """Which copy of the catalogue a command reads: a clone's working tree is not the installed copy."""
    if root is not None:
        return f"checking the catalogue in {root}"
    here = catalogue_dir()
    where = "the copy installed with agspec" if "_data" in here.parts else "the source tree agspec runs from"
    return f"checking {here} ({where}; give --catalogue DIR for another copy)"


@catalogue.command("verify")
@click.option("--update", is_flag=True, help="Rewrite catalogue/lock.json from the current catalogue.")
@click.option("--lock", "lock_file", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Lock file to check (default: the catalogue's lock.json).")
@click.option("--catalogue", "root", type=click.Path(file_okay=False, exists=True, path_type=Path), default=None,
              help="The catalogue directory to check, e.g. a clone's catalogue/ (default: the copy agspec "
                   "runs from, printed first).")
def catalogue_verify(update: bool, lock_file: Path | None, root: Path | None = None) -> None:
    """Recompute scenario and realization fingerprints and compare them with the lock."""
    path = lock_file or (root / "lock.json" if root is not None else lock_path())
    stderr.print(_which_catalogue(root), markup=False)
    current = _current_lock(root)
    if update:
        write_lock(current, path)  # F-OUTPUT-FAILURES
        n = sum(len(s["instances"]) for s in current["scenarios"].values())
        stdout.print(f"wrote {path}: {len(current['scenarios'])} scenarios, {n} realizations", markup=False)
        return
    try:
        locked = read_lock(path)
    except CatalogueError as exc:
        _fail(str(exc), EXIT_USAGE)
    drift = verify_lock(current, locked)
    if drift:
        stderr.print(f"[bold red]catalogue drift[/]: {len(drift)} difference(s) from {escape(str(path))}:")
        for line in drift:
            stderr.print(f"  - {line}", markup=False)
        stderr.print("if the change is intended, run `agspec catalogue verify --update` and review the diff",
                     markup=False)
        raise SystemExit(EXIT_INVALID)
    n = sum(len(s["instances"]) for s in current["scenarios"].values())
    stdout.print(f"catalogue matches {path}: {len(current['scenarios'])} scenarios, {n} realizations",
                 markup=False)


@catalogue.command("lock")
@click.option("--lock", "lock_file", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Lock file to write (default: the catalogue's lock.json).")
@click.pass_context
def catalogue_lock(ctx: click.Context, lock_file: Path | None) -> None:
    """Rewrite the lock (same as `catalogue verify --update`)."""
    ctx.invoke(catalogue_verify, update=True, lock_file=lock_file, root=None)
