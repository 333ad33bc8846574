"""`agspec report`: a results bundle as the paper's table (Markdown, LaTeX) or figure (F-POLICY-TABLE/FIGURE);
training run directories as the paper's training curves (T-RECORD)."""

from __future__ import annotations

from pathlib import Path

import click

from agspec.cli.common import EXIT_INVALID, EXIT_USAGE, Choice, fail, stdout
from agspec.cli.run_cmds import METRICS
from agspec.formats.output import atomic_path, write_text

FORMATS = ("markdown", "latex", "svg", "png", "pdf")


@click.command("report")
@click.argument("bundles", nargs=-1, required=True, type=click.Path(path_type=Path), metavar="BUNDLE…|RUN_DIR…")
@click.option("--to", "to", type=Choice(FORMATS), default="markdown", show_default=True)
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Output file (default: stdout for markdown/latex, BUNDLE.<format> for figures).")
@click.option("--metric", "metric_keys", multiple=True, type=Choice(METRICS),
              help="Metrics of the tables (default delivered and completion_rate).")
@click.option("--no-published", is_flag=True, help="Leave out the paper's published MARL rows.")
@click.option("--allow-incomplete", is_flag=True,
              help="Render rows with errors or missing episodes, marked ‡ with their n of N (F-POLICY-COVERAGE); "
                   "without it they are refused. Either way such rows make the exit status 1.")
def report(bundles: tuple[Path, ...], to: str, output: Path | None, metric_keys: tuple[str, ...],
           no_published: bool, allow_incomplete: bool) -> None:
    """Write results bundles (agspec evaluate --out) as the paper's table or family figure, or training run
    directories (agspec train --out) as training curves (--to svg|png|pdf).

    Every table and figure states n per row and the instance set ("10 of 50 final-test instances");
    a row with errors or missing episodes is refused unless --allow-incomplete, and exits 1.
    """
    if any(p.is_dir() for p in bundles):
        _training_curves(bundles, to, output)
        return
    from agspec.cli.evaluate_view import refuse_incomplete
    from agspec.controllers import CONTROLLERS
    from agspec.extras import MissingExtra
    from agspec.policy.bundle import BundleError, combine, read_bundle
    from agspec.policy.coverage import describe_sets, final_test_only, incomplete
    from agspec.policy.stats import compare
    from agspec.policy.tables import latex, layout, markdown

    try:
        data = combine([(str(p), read_bundle(p)) for p in bundles])
    except BundleError as exc:
        fail(str(exc))
    episodes = data["episodes"]
    planned = data["planned"]
    labels = list(dict.fromkeys([ep["controller"] for ep in episodes] + [lab for lab, _ in planned]))
    scenarios = list(dict.fromkeys([ep["scenario"] for ep in episodes] + [s for _, s in planned]))
    metrics = metric_keys or ("delivered", "completion_rate")
    figure = to in ("svg", "png", "pdf")
    if figure:
        from agspec.policy.figure import SCENARIOS

        scenarios = [s for s in scenarios if s in SCENARIOS]
    problems = incomplete(episodes, planned, labels, scenarios)
    refuse_incomplete(problems, allow_incomplete, "figure" if figure else "report")
    shown = {k: v for k, v in planned.items() if k[1] in scenarios}
    instances = describe_sets(shown, scenarios, data.get("split"))
    with_published = not no_published and final_test_only(shown)  # F-POLICY-PUBLISHED: final-test numbers
    try:
        if figure:
            from agspec.policy.figure import draw

            target = output or bundles[0].with_suffix("." + to)
            with atomic_path(target) as tmp:  # F-OUTPUT-FAILURES
                draw(episodes, labels, tmp, with_published=with_published, planned=planned, instances=instances,
                     fmt=to, policies=data["policies"])
            stdout.print(f"figure written to {target}")
            raise SystemExit(EXIT_INVALID if problems else 0)
        refs = [lab for lab in CONTROLLERS if lab in labels]
        mine = [lab for lab in labels if lab not in CONTROLLERS]
        parts = []
        for metric in metrics:
            rows = layout(episodes, labels, scenarios, metric, with_published, planned, data["policies"])
            if to == "latex":
                parts.append(latex(rows, scenarios, metric, instances=instances))
            else:
                comps = [c for p in mine for c in compare(episodes, p, refs, scenarios, metric)]
                parts.append(markdown(rows, scenarios, metric, comps, instances=instances))
            parts.append(_checkpoint_rows(data, metric, to))
    except MissingExtra as exc:
        fail(str(exc), EXIT_USAGE)
    text = "\n".join(parts)
    if output is None:
        click.echo(text, nl=False)
    else:
        write_text(output, text)  # F-OUTPUT-FAILURES
        stdout.print(f"{to} written to {output}")
    if problems:  # F-EXIT-CODES: rendered on request, still not a complete result
        raise SystemExit(EXIT_INVALID)


def _checkpoint_rows(data: dict, metric: str, to: str) -> str:
    """T-CHECKPOINT-ROW: trained checkpoints of one method and scenario as the paper's held-out row."""
    from agspec.train import heldout

    table = heldout.rows(data["policies"], data["episodes"], metric)
    return heldout.latex(table) if to == "latex" else heldout.markdown(table)


def _training_curves(dirs: tuple[Path, ...], to: str, output: Path | None) -> None:
    """Training run directories -> the paper's training curves (median and IQR over seeds)."""
    from agspec.checkpoint.rundir import RunDirError
    from agspec.extras import MissingExtra
    from agspec.train.curves import draw, load_runs

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
        with atomic_path(target) as tmp:  # F-OUTPUT-FAILURES
            draw(runs, tmp, fmt=to)
    except MissingExtra as exc:
        fail(str(exc), EXIT_USAGE)
    stdout.print(f"training curves of {len(runs)} run(s) written to {target}")
