"""CLI: `validate`, `compile`, `fmt` — the DSL and IR commands (spec F-DSL, F-DIAGNOSTICS).

Exit codes (F-EXIT-CODES): 0 valid, 1 invalid input (any error diagnostic, or `fmt --check`
finding a non-canonical file), 2 usage or I/O error (a file that cannot be read), 4 internal
error.  Diagnostics go to stderr, Rust style with the source line and a caret; `--format
json` prints them as a JSON list on stdout instead (schemas/diagnostics.schema.json).
"""

from __future__ import annotations

import difflib
import json
import sys
from pathlib import Path
from typing import Any, Iterable, Sequence

import click
from rich import box
from rich.console import Console
from rich.table import Table
from rich.text import Text

from agspec.cli.common import EXIT_INTERNAL, EXIT_INVALID, EXIT_OK, EXIT_USAGE, FORMAT_OPTION, emit_json, fail, stderr
from agspec.cli.common import stdout
from agspec.dsl.fmt import format_ir, format_source
from agspec.formats.diagnostics import Diagnostic
from agspec.formats.output import write_text
from agspec.load import Document, Resolver, check_document, io_fault, load_document, resolve_argument

SEARCH_PATH_OPTION = click.option(
    "-I", "--search-path", "search_paths", multiple=True,
    type=click.Path(file_okay=False, path_type=Path),
    help="Extra directory to resolve recipe/profile/scenario names in (repeatable).",
)
_STYLE = {"error": "bold red", "warning": "bold yellow", "note": "bold cyan"}


# --------------------------------------------------------------------------- helpers


def diagnostic_json(d: Diagnostic) -> dict[str, Any]:
    """A diagnostic as the JSON object of schemas/diagnostics.schema.json (all keys present)."""
    return {
        "code": d.code, "severity": d.severity, "message": d.message, "file": d.file,
        "line": d.line, "col": d.col, "end_line": d.end_line, "end_col": d.end_col,
        "hint": d.hint, "pointer": d.pointer, "notes": list(d.notes),
        "fix": d.fix.to_json() if d.fix is not None else None,
    }


def print_diagnostics(diags: Iterable[Diagnostic], sources: dict[str | None, str | None]) -> None:
    """Render diagnostics on stderr with their source lines (Rust/Elm style)."""
    for d in diags:
        lines = d.render(sources.get(d.file)).split("\n")
        stderr.print(Text(lines[0], style=_STYLE.get(d.severity, "bold")))
        if len(lines) > 1:
            stderr.print(Text("\n".join(lines[1:])))


def _expand(args: Sequence[str], search_paths: Sequence[Path]) -> list[Path]:
    """Command-line arguments -> files: files, directories (every .ag file inside), or names."""
    out: list[Path] = []
    for arg in args:
        path = resolve_argument(arg, search_paths)
        if path.is_dir():
            found = sorted(p for p in path.rglob("*.ag") if p.is_file())
            if not found:  # F-EXIT-CODES: nothing checked is not "valid"
                fail(f"{arg}: a directory without .ag files", EXIT_USAGE)
            out += found
        else:
            out.append(path)
    return out


def _exit_code(docs: Sequence[Document], diags: Sequence[Diagnostic]) -> int:
    if any(d.code == "AG000" for d in diags):
        return EXIT_INTERNAL
    # F-EXIT-CODES: a file that is missing or not a readable regular file, or of an unknown type, is a
    # usage/I/O error; anything wrong with its content (encoding, limits, syntax, ...) is invalid input
    if any(io_fault(doc, diags) for doc in docs):
        return EXIT_USAGE
    if any(d.severity == "error" for d in diags):
        return EXIT_INVALID
    return EXIT_OK


def _count(diags: Iterable[Diagnostic], severity: str) -> int:
    return sum(1 for d in diags if d.severity == severity)


def _load_checked(target: str, search_paths: Sequence[Path]) -> tuple[Document, list[Diagnostic]]:
    path = resolve_argument(target, search_paths)
    doc = load_document(path)
    return doc, check_document(doc, Resolver(search_paths))


# --------------------------------------------------------------------------- validate


@click.command("validate")
@click.argument("files", nargs=-1, required=True)
@FORMAT_OPTION
@SEARCH_PATH_OPTION
@click.option("--no-semantic", is_flag=True, help="Only syntax, build and schema checks.")
def validate(files: tuple[str, ...], fmt: str, search_paths: tuple[Path, ...], no_semantic: bool) -> None:
    """Check .ag / .json documents, directories of .ag files, or scenario names.

    Runs syntax, build, schema, reference and semantic checks and reports every diagnostic.
    """
    resolver = Resolver(search_paths)
    docs: list[Document] = []
    all_diags: list[Diagnostic] = []
    rows = []
    for path in _expand(files, search_paths):
        doc = load_document(path)
        diags = check_document(doc, resolver, semantic=not no_semantic)
        docs.append(doc)
        all_diags += diags
        errors, warnings = _count(diags, "error"), _count(diags, "warning")
        status = "unreadable" if doc.text is None else ("invalid" if errors else "valid")
        rows.append((doc.file or "<input>", doc.kind or "-", errors, warnings, status))
    if fmt == "json":
        emit_json([diagnostic_json(d) for d in all_diags], "diagnostics")
    else:
        print_diagnostics(all_diags, {doc.file: doc.text for doc in docs})
        # diagnostics (stderr) then the summary (stdout): flushed in that order, so `2>&1 | less` keeps it
        sys.stderr.flush()
        table = Table(box=box.SIMPLE_HEAD, title=None)
        for col in ("file", "kind", "errors", "warnings", "status"):
            table.add_column(col, justify="right" if col in ("errors", "warnings") else "left",
                             no_wrap=True)
        style = {"valid": "green", "invalid": "red", "unreadable": "red"}
        for file, kind, errors, warnings, status in rows:
            table.add_row(Text(file), kind, str(errors), str(warnings), Text(status, style=style[status]))
        needed = max((len(r[0]) for r in rows), default=0) + 48
        # long paths: widen the table rather than truncating file names
        out = stdout if needed <= stdout.width else Console(width=needed, highlight=False, soft_wrap=True)
        out.print(table)
        valid = sum(1 for r in rows if r[4] == "valid")
        stdout.print(f"{valid}/{len(rows)} valid")
        sys.stdout.flush()
    raise SystemExit(_exit_code(docs, all_diags))


# --------------------------------------------------------------------------- compile


@click.command("compile")
@click.argument("file")
@click.option("--pretty/--compact", default=True, show_default=True, help="Indented or single-line JSON.")
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Write the IR to FILE instead of stdout.")
@SEARCH_PATH_OPTION
def compile_cmd(file: str, pretty: bool, output: Path | None, search_paths: tuple[Path, ...]) -> None:
    """Compile a .ag document (or check a .json one) and print its IR as JSON."""
    doc, diags = _load_checked(file, search_paths)
    print_diagnostics(diags, {doc.file: doc.text})
    code = _exit_code([doc], diags)
    if code != EXIT_OK or doc.ir is None:
        raise SystemExit(code or EXIT_INVALID)
    if pretty:
        text = json.dumps(doc.ir, indent=2, ensure_ascii=False) + "\n"
    else:
        text = json.dumps(doc.ir, separators=(",", ":"), ensure_ascii=False) + "\n"
    if output is None:
        sys.stdout.write(text)
        sys.stdout.flush()
    else:
        write_text(output, text)  # F-OUTPUT-FAILURES
        stderr.print(Text(f"wrote {output}"))


# --------------------------------------------------------------------------- fmt


def _canonical(doc: Document, search_paths: Sequence[Path]) -> tuple[str | None, list[Diagnostic], int]:
    """Canonical DSL text of a loaded document, its diagnostics and the number of lost comments.

    Only a document free of syntax, build and schema errors has a canonical form (for any
    other the DSL -> IR -> DSL fixpoint does not hold).
    """
    diags = check_document(doc, Resolver(search_paths), semantic=False)
    if doc.text is None or doc.ir is None or any(d.severity == "error" for d in diags):
        return None, diags, 0
    if doc.kind not in ("recipe", "profile", "scenario"):
        return None, diags + [Diagnostic(code="AG004", message=f"a {doc.kind} document has no DSL form",
                                         file=doc.file, hint="fmt writes recipes, profiles and scenarios")], 0
    if doc.path is not None and doc.path.suffix == ".ag":
        result = format_source(doc.text, doc.file)
        return result.text, diags, result.dropped_comments
    return format_ir(doc.ir), diags, 0


@click.command("fmt")
@click.argument("file")
@click.option("--check", is_flag=True, help="Exit 1 if FILE is not in canonical form (prints a diff).")
@click.option("-w", "--write", is_flag=True, help="Rewrite FILE in canonical form.")
@SEARCH_PATH_OPTION
def fmt(file: str, check: bool, write: bool, search_paths: tuple[Path, ...]) -> None:
    """Print the canonical DSL text of FILE (.ag, or a .json recipe/profile/scenario IR)."""
    if check and write:
        stderr.print(Text("error: give --check or --write, not both", style="bold red"))
        raise SystemExit(EXIT_USAGE)
    doc = load_document(resolve_argument(file, search_paths))
    text, diags, dropped = _canonical(doc, search_paths)
    print_diagnostics(diags, {doc.file: doc.text})
    if text is None:
        raise SystemExit(_exit_code([doc], diags) or EXIT_INVALID)
    if dropped:
        stderr.print(Text(f"warning: {dropped} comment(s) after the header are not kept by fmt",
                          style="bold yellow"))
    is_dsl = doc.path is not None and doc.path.suffix == ".ag"
    if check:
        if is_dsl and text == doc.text:
            raise SystemExit(EXIT_OK)
        stderr.print(Text(f"{doc.file}: not in canonical form (run `agspec fmt --write {doc.file}`)",
                          style="bold red"))
        if is_dsl:
            diff = difflib.unified_diff((doc.text or "").splitlines(True), text.splitlines(True),
                                        fromfile=f"{doc.file}", tofile=f"{doc.file} (canonical)")
            stderr.print(Text("".join(diff)))
        raise SystemExit(EXIT_INVALID)
    if write:
        if not is_dsl:
            stderr.print(Text("error: --write needs a .ag file (print the DSL of a .json with `fmt FILE`)",
                              style="bold red"))
            raise SystemExit(EXIT_USAGE)
        if text != doc.text:
            write_text(Path(file if doc.path is None else doc.path), text)  # F-OUTPUT-FAILURES
            stderr.print(Text(f"formatted {doc.file}"))
        raise SystemExit(EXIT_OK)
    sys.stdout.write(text)
    sys.stdout.flush()
