"""Shared CLI plumbing: exit codes, consoles, JSON output, and the no-traceback guard."""

from __future__ import annotations

import json
import re
import sys
from typing import Any, NoReturn

import click
from rich.console import Console
from rich.text import Text

from agspec.formats.schemas import self_check
from agspec.suggest import closest

# Exit codes (spec/09-formats.md, F-EXIT-CODES). Categorical, never counts.
EXIT_OK = 0
EXIT_INVALID = 1  # invalid input / nonconformant implementation / failed check
EXIT_USAGE = 2  # usage or I/O error
EXIT_HARNESS = 3  # harness or protocol error (conformance)
EXIT_INTERNAL = 4  # a bug in agspec itself

stdout = Console(highlight=False, soft_wrap=True)
stderr = Console(stderr=True, highlight=False, soft_wrap=True)


class Choice(click.Choice):
    """click's Choice whose error names the closest choice (F-SUGGEST), like every other unknown name."""

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        try:
            return super().convert(value, param, ctx)
        except click.BadParameter as exc:
            match = closest(value, [str(c) for c in self.choices])
            if not match:
                raise
            self.fail(f"{exc.message.rstrip('.')}; did you mean {match[0]!r}?", param, ctx)


def emit_json(data: Any, schema: str) -> None:
    """Print machine-readable JSON on stdout (no rich markup); ``schema`` names its schema in
    ``schemas/`` (every ``--format json`` output has one, F-SCHEMAS-SELF)."""
    self_check(schema, data)
    sys.stdout.write(json.dumps(data, indent=2, sort_keys=False, ensure_ascii=False) + "\n")
    sys.stdout.flush()


def print_table(table: Any, console: Console | None = None) -> None:
    """Print a rich table whole: its cells fold in a terminal; elsewhere (a file, a pipe, CI) it is printed
    at its natural width, so no cell is ever cut to "…"."""
    console = console or stdout
    for column in table.columns:
        column.overflow = "fold"
    if table.title:  # a title is wrapped to the table's width: make the table as wide as its title
        table.min_width = max(table.min_width or 0, Text.from_markup(str(table.title)).cell_len + 4)
    if console.is_terminal:
        console.print(table)
        return
    width = console.measure(table, options=console.options.update_width(10**5)).maximum
    Console(file=console.file, width=max(width, console.width), highlight=False).print(table)


# the head of a rendered diagnostic (agspec.formats.diagnostics.Diagnostic.header): `FILE:LINE:COL: error[AG416]: `
DIAGNOSTIC_HEAD = re.compile(r"^[^\n]*?\b(?:error|warning)\[[A-Z]+\d+\]: ")


def error(message: str) -> None:
    """Print ``error: MESSAGE`` to stderr (the message literally: file names and ids may contain brackets).

    A message that is a rendered diagnostic already names its severity (``FILE:L:C: error[AGnnn]: ...``,
    F-DIAGNOSTICS): it is printed as it is, never as ``error: FILE:L:C: error[AGnnn]``."""
    if DIAGNOSTIC_HEAD.match(message):
        stderr.print(Text(message), highlight=False)
    else:
        stderr.print(Text.assemble(("error", "bold red"), ": ", message))


def fail(message: str, code: int = EXIT_USAGE) -> NoReturn:
    """:func:`error`, then exit with ``code`` (F-EXIT-CODES)."""
    error(message)
    raise SystemExit(code)


# Seeds and suite indices (F-LIMITS-SEEDS): non-negative integers that JSON and the RFC 8785 canonical form
# hold exactly (F-FINGERPRINT), i.e. below 2**53, so a seed always survives into a fingerprinted instance.
SEED_MAX = 2**53 - 1
SEED_RANGE = click.IntRange(0, SEED_MAX)


FORMAT_OPTION = click.option(
    "--format",
    "fmt",
    type=Choice(["table", "json"]),
    default="table",
    show_default=True,
    help="Output as a rich table or machine-readable JSON.",
)
