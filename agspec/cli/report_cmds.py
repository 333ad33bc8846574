"""`agspec report`: a results bundle as the paper's table (Markdown, LaTeX) or figure (F-POLICY-TABLE/FIGURE)."""

from __future__ import annotations

from pathlib import Path

import click

from agspec.cli.common import EXIT_USAGE, fail, stdout
from agspec.cli.run_cmds import METRICS

FORMATS = ("markdown", "latex", "svg", "png", "pdf")


@click.command("report")
@click.argument("bundles", nargs=-1, required=True, type=click.Path(dir_okay=False, path_type=Path))
@click.option("--to", "to", type=click.Choice(FORMATS), default="markdown", show_default=True)
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Output file (default: stdout for markdown/latex, BUNDLE.<format> for figures).")
@click.option("--metric", "metric_keys", multiple=True, type=click.Choice(METRICS),
              help="Metrics of the tables (default delivered and completion_rate).")
@click.option("--no-published", is_flag=True, help="Leave out the paper's published MARL rows.")
def report(bundles: tuple[Path, ...], to: str, output: Path | None, metric_keys: tuple[str, ...],
           no_published: bool) -> None:
    """Write results bundles (agspec evaluate --out) as the paper's table or family figure."""
    from agspec.controllers import CONTROLLERS
    from agspec.policy.bundle import BundleError, combine, read_bundle
    from agspec.policy.stats import MissingExtra, compare
    from agspec.policy.tables import latex, layout, markdown

    try:
        data = combine([(str(p), read_bundle(p)) for p in bundles])
    except BundleError as exc:
        fail(str(exc))
    episodes = data["episodes"]
    labels = list(dict.fromkeys(ep["controller"] for ep in episodes))
    scenarios = list(dict.fromkeys(ep["scenario"] for ep in episodes))
    metrics = metric_keys or ("delivered", "completion_rate")
    try:
        if to in ("svg", "png", "pdf"):
            from agspec.policy.figure import draw

            target = output or bundles[0].with_suffix("." + to)
            try:
                draw(episodes, labels, target, with_published=not no_published)
            except OSError as exc:
                fail(f"cannot write {target}: {exc.strerror or exc}")
            stdout.print(f"figure written to {target}")
            return
        refs = [lab for lab in CONTROLLERS if lab in labels]
        mine = [lab for lab in labels if lab not in CONTROLLERS]
        parts = []
        for metric in metrics:
            rows = layout(episodes, labels, scenarios, metric, not no_published)
            if to == "latex":
                parts.append(latex(rows, scenarios, metric))
            else:
                comps = [c for p in mine for c in compare(episodes, p, refs, scenarios, metric)]
                parts.append(markdown(rows, scenarios, metric, comps))
    except MissingExtra as exc:
        fail(str(exc), EXIT_USAGE)
    text = "\n".join(parts)
    if output is None:
        click.echo(text, nl=False)
        return
    try:
        output.write_text(text, encoding="utf-8")
    except OSError as exc:
        fail(f"cannot write {output}: {exc.strerror or exc}")
    stdout.print(f"{to} written to {output}")
