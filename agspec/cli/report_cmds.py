"""`agspec report`: a results bundle as the paper's table (Markdown, LaTeX) or figure (F-POLICY-TABLE/FIGURE);
training run directories as the paper's training curves (T-RECORD)."""

from __future__ import annotations

from pathlib import Path

import click

from agspec.cli.common import EXIT_USAGE, fail, stdout
from agspec.cli.run_cmds import METRICS

FORMATS = ("markdown", "latex", "svg", "png", "pdf")


@click.command("report")
@click.argument("bundles", nargs=-1, required=True, type=click.Path(path_type=Path), metavar="BUNDLE…|RUN_DIR…")
@click.option("--to", "to", type=click.Choice(FORMATS), default="markdown", show_default=True)
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Output file (default: stdout for markdown/latex, BUNDLE.<format> for figures).")
@click.option("--metric", "metric_keys", multiple=True, type=click.Choice(METRICS),
              help="Metrics of the tables (default delivered and completion_rate).")
@click.option("--no-published", is_flag=True, help="Leave out the paper's published MARL rows.")
def report(bundles: tuple[Path, ...], to: str, output: Path | None, metric_keys: tuple[str, ...],
           no_published: bool) -> None:
    """Write results bundles (agspec evaluate --out) as the paper's table or family figure, or training run
    directories (agspec train --out) as training curves (--to svg|png|pdf)."""
    if any(p.is_dir() for p in bundles):
        _training_curves(bundles, to, output)
        return
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
            parts.append(_checkpoint_rows(data, metric, to))
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


def _checkpoint_rows(data: dict, metric: str, to: str) -> str:
    """T-CHECKPOINT-ROW: trained checkpoints of one method and scenario as the paper's held-out row."""
    from agspec.train import heldout

    table = heldout.rows(data["policies"], data["episodes"], metric)
    return heldout.latex(table) if to == "latex" else heldout.markdown(table)


def _training_curves(dirs: tuple[Path, ...], to: str, output: Path | None) -> None:
    """Training run directories -> the paper's training curves (median and IQR over seeds)."""
    from agspec.policy.stats import MissingExtra
    from agspec.train.curves import draw, load_runs
    from agspec.train.rundir import RunDirError

    if not all(p.is_dir() for p in dirs):
        fail("give either results bundles or training run directories, not both")
    if to not in ("svg", "png", "pdf"):
        fail(f"training run directories are drawn as curves: use --to svg, png or pdf (not {to})")
    try:
        runs = load_runs(dirs)
    except RunDirError as exc:
        fail(str(exc))
    target = output or Path(f"{dirs[0].resolve().name}-curves.{to}")
    try:
        draw(runs, target)
    except MissingExtra as exc:
        fail(str(exc), EXIT_USAGE)
    except OSError as exc:
        fail(f"cannot write {target}: {exc.strerror or exc}")
    stdout.print(f"training curves of {len(runs)} run(s) written to {target}")
