"""CLI: `explain` — print the spec entry of any ID (rules, metrics, invariants, formats, resolutions,
divergences, diagnostic codes), so every label agspec prints can be looked up without the paper."""

from __future__ import annotations

import click
from rich import box
from rich.markdown import Markdown
from rich.markup import escape
from rich.panel import Panel
from rich.table import Table

from agspec.cli.common import EXIT_INVALID, FORMAT_OPTION, emit_json, fail, stdout
from agspec.spec_index import Entry, similar_ids, spec_entries, spec_entry


def _as_json(entry: Entry) -> dict:
    return {"id": entry.id, "kind": entry.kind, "title": entry.title, "file": f"spec/{entry.file}",
            "line": entry.line, "text": entry.text}


def _listing(prefix: str) -> list[Entry]:
    """Entries whose ID starts with ``prefix`` (e.g. `M-`, `RES-`, `AG4`), first declaration each."""
    seen: dict[str, Entry] = {}
    for entry in spec_entries():
        if entry.id.startswith(prefix):
            seen.setdefault(entry.id, entry)
    return list(seen.values())


def _show(entry: Entry) -> None:
    title = f"[bold]{escape(entry.id)}[/] — {escape(entry.title)}"
    stdout.print(Panel(Markdown(entry.text or "_(no text)_"), title=title, title_align="left",
                       subtitle=f"spec/{entry.file}:{entry.line}", subtitle_align="right", box=box.ROUNDED),
                 soft_wrap=False)


@click.command("explain")
@click.argument("ids", nargs=-1, required=True, metavar="ID...")
@FORMAT_OPTION
def explain(ids: tuple[str, ...], fmt: str) -> None:
    """Print the spec entry of each ID: a rule (R-), metric (M-), invariant (INV-), format (F-),
    resolution (RES-), divergence (DIV-, DEV-), definition (D-), or diagnostic code (AG305).

    An ID prefix (`M-`, `RES-`, `AG4`) lists the matching entries. Every measure, invariant,
    check and error agspec prints carries such an ID. Exit 1 if an ID is not in the spec.
    """
    found: list[Entry] = []
    listings: list[tuple[str, list[Entry]]] = []
    for raw in ids:
        entry = spec_entry(raw)
        if entry is not None:
            found.append(entry)
            continue
        matches = _listing(raw.strip().upper())
        if matches:
            listings.append((raw, matches))
            continue
        hint = similar_ids(raw)
        fail(f"`{raw}` is not an ID of the spec" + (f"; did you mean {', '.join(hint)}?" if hint else
             "; `agspec explain M-` lists the metrics, `R-` the rules, `AG` the diagnostic codes"), EXIT_INVALID)
    if fmt == "json":
        emit_json({"entries": [_as_json(e) for e in found],
                   "listings": [{"prefix": p, "entries": [_as_json(e) for e in es]} for p, es in listings]}, "explain")
        return
    for entry in found:
        _show(entry)
    for prefix, entries in listings:
        table = Table(title=f"spec entries starting with {escape(prefix.upper())}", box=box.SIMPLE_HEAD,
                      show_edge=False, caption="agspec explain ID prints one entry")
        for col in ("ID", "title", "where"):
            table.add_column(col, overflow="fold")
        for e in entries:
            table.add_row(escape(e.id), escape(e.title), f"spec/{e.file}:{e.line}")
        stdout.print(table)
