"""`agspec train`: one training run of IPPO, MAPPO or QMIX as tab:marlconfig gives them (T-CLI).

Exit codes (F-EXIT-CODES): 1 for a scenario or settings file whose content is invalid; 2 for a bad
option or setting, a file that cannot be reached, an unusable run directory and a missing extra; 130
when interrupted (the run resumes from its last checkpoint); 4 for a bug in agspec.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping

import click

from agspec.cli.common import EXIT_INVALID, EXIT_USAGE, SEED_RANGE, Choice, emit_json, fail, stderr, stdout
from agspec.cli.executor_opts import JOBS_HELP, executor_options
from agspec.cli.grammar import output_option

ALGORITHMS = ("ippo", "mappo", "qmix")
IDENTITY = ("algorithm", "scenario", "seed")


def _settings_file(path: Path, options: Mapping[str, Any]) -> dict[str, Any]:
    """--config FILE: a JSON or YAML mapping of settings; identity keys must agree with the options."""
    from agspec.formats.limits import InputError, load_json, parse_yaml, read_text

    try:
        data = load_json(path) if path.suffix.lower() == ".json" else parse_yaml(read_text(path), str(path))
    except InputError as exc:
        fail(str(exc), exc.exit_code)
    if not isinstance(data, dict):
        fail(f"{path}: a settings file must hold a mapping of settings, e.g. {{ppo: {{clip: 0.2}}}}", EXIT_INVALID)
    data = dict(data)
    for key in (*IDENTITY, "schema"):
        if key in data:
            value = data.pop(key)
            if key in options and value != options[key]:
                fail(f"{path}: {key} is {value!r} but the command line says {options[key]!r}", EXIT_INVALID)
    return data


@click.command("train")
@click.option("--algorithm", type=Choice(ALGORITHMS), default=None, help="The MARL reference to train.")
@click.option("--scenario", default=None, metavar="NAME|FILE.ag", help="Official scenario name or a scenario file.")
@click.option("--seed", type=SEED_RANGE, default=None, help="Algorithm seed (the paper used 0-9).")
@output_option("Run directory (new or empty; with --resume, the cut run's); with --campaign, the campaign's.",
               file=False)
@click.option("--campaign", "campaign_plan", default=None, metavar="paper|PLAN.json|PLAN.yaml",
              help="Run a campaign instead of one run: the paper's 270 runs, or a plan of algorithms x scenarios "
                   "x seeds (schemas/training-plan.schema.json); resumable, each run evaluated on final-test.")
@click.option("-j", "--jobs", type=click.IntRange(1, 256), default=None, help="With --campaign: " + JOBS_HELP)
@click.option("--gpus-per-run", type=click.FloatRange(0, 64), default=0.0, show_default=True,
              help="With --campaign --executor ray: GPUs each run holds (0.5 shares one GPU by two runs); "
                   "runs then train on cuda.")
@click.option("--steps", type=click.IntRange(1), default=None,
              help="Training budget in environment steps (default the paper's 1,536,000; divisible by 5).")
@click.option("--envs", type=click.IntRange(1), default=None, help="Environment copies stepped together (default 1).")
@click.option("--device", default=None, metavar="cpu|cuda", help="Torch device (default cpu).")
@click.option("--threads", type=click.IntRange(1), default=None,
              help="Torch intra-op threads of each run (default: the budget, CAMP-THREADS).")
@click.option("--config", "config_file", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="JSON/YAML file of settings (sections or dotted keys), applied before --set.")
@click.option("--set", "sets", multiple=True, metavar="KEY=VALUE",
              help="Override one setting, e.g. --set ppo.clip=0.2 (repeatable; see spec/16-training.md).")
@click.option("--resume", is_flag=True, help="Continue the cut run in -o/--output from its last checkpoint.")
@click.option("--print-config", is_flag=True, help="Print the resolved configuration and exit without training.")
@click.option("--format", "fmt", type=Choice(["table", "json"]), default="table", show_default=True,
              help="Final summary as a table or run.json's JSON.")
@executor_options
def train(algorithm: str | None, scenario: str | None, seed: int | None, output: str | None, campaign_plan: str | None,
          jobs: int | None, gpus_per_run: float, steps: int | None, envs: int | None, device: str | None,
          threads: int | None, config_file: Path | None, sets: tuple[str, ...], resume: bool, print_config: bool,
          fmt: str, campaign: Any) -> None:
    """Train IPPO, MAPPO or QMIX on one scenario with the paper's configuration (tab:marlconfig).

    Writes the resolved configuration, the training record (JSON Lines, as it goes), checkpoints and
    the final policy into -o/--output; `agspec evaluate --policy OUT` evaluates it, `agspec report OUT --to
    svg` draws its curves.  Needs the extra agspec[train] (PyTorch).
    """
    from agspec.extras import MissingExtra
    from agspec.train.api import scenario_family
    from agspec.train.config import ConfigError, flatten_settings, paper_defaults, parse_override, resolve

    if campaign_plan is not None:
        from agspec.cli.train_campaign import run_plan

        if algorithm or scenario or seed is not None or config_file or resume or print_config:
            fail("--campaign takes the runs from its plan: drop --algorithm, --scenario, --seed, --config, "
                 "--resume and --print-config (a campaign resumes by itself)")
        settings = dict(parse_override(text) for text in sets)
        for key, value in (("budget.env_steps", steps), ("rollout.envs", envs), ("runtime.device", device),
                           ("runtime.threads", threads)):
            if value is not None:
                settings[key] = value
        if output is None:
            fail("missing -o/--output DIRECTORY: the campaign directory")
        run_plan(campaign_plan, Path(output), settings, campaign, gpus_per_run, fmt)
        return
    missing = [f"--{name}" for name, value in (("algorithm", algorithm), ("scenario", scenario), ("seed", seed))
               if value is None]
    if missing:
        fail(f"missing {', '.join(missing)} (or give --campaign paper|PLAN)")
    if output is None:
        fail("missing -o/--output DIRECTORY: the run directory")
    out = Path(output)
    try:
        family = scenario_family(scenario)
    except ConfigError as exc:  # an invalid scenario file is invalid input; an unknown or unreadable one, usage
        fail(str(exc), EXIT_INVALID if exc.invalid_input else EXIT_USAGE)
    overrides: dict[str, Any] = {}
    if config_file is not None:
        data = _settings_file(config_file, {"algorithm": algorithm, "scenario": scenario, "seed": seed})
        overrides = flatten_settings(data, paper_defaults(algorithm))
        try:
            resolve(algorithm, scenario, seed, family, overrides)
        except ConfigError as exc:  # a setting of the file: the file's content is invalid
            fail(f"{config_file}: {exc}", EXIT_INVALID)
    try:
        for text in sets:
            key, value = parse_override(text)
            overrides[key] = value
        for key, value in (("budget.env_steps", steps), ("rollout.envs", envs), ("runtime.device", device),
                           ("runtime.threads", threads)):
            if value is not None:
                overrides[key] = value
        config = resolve(algorithm, scenario, seed, family, overrides)
    except ConfigError as exc:
        fail(str(exc), EXIT_USAGE)
    if print_config:
        emit_json(config, "training-config")
        return
    try:
        summary = _run(config, out, resume)
    except MissingExtra as exc:
        fail(str(exc), EXIT_USAGE)
    if fmt == "json":
        emit_json(summary, "training-run")
        return
    _show(summary, out)


def _run(config: dict[str, Any], out: Path, resume: bool) -> dict[str, Any]:
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

    from agspec.checkpoint.rundir import CHECKPOINT, RunDirError, is_complete, refuse_foreign

    try:  # before the extra is needed: a directory that is not a run is refused whatever is installed
        refuse_foreign(out)
    except RunDirError as exc:
        fail(str(exc), EXIT_USAGE)
    if resume and not (out / CHECKPOINT).is_file() and not is_complete(out):  # T-RESUME: said, not silent
        stderr.print(f"--resume: {out} holds no checkpoint to continue; a new run starts from step 0", markup=False)
    try:
        from agspec.checkpoint.files import CheckpointError
        from agspec.train.api import train as train_run
    except ImportError as exc:  # the extra is missing: say how to install it (F-EXIT-CODES: usage)
        fail(f"agspec train needs PyTorch ({exc}): pip install 'agspec[train]'", EXIT_USAGE)
    from agspec.train.config import ConfigError
    total = config["budget"]["env_steps"]
    with Progress(TextColumn("[bold]train {task.fields[label]}"), BarColumn(), TextColumn("{task.completed:,}/{task.total:,} steps"),
                  TextColumn("{task.description}"), TimeElapsedColumn(), TimeRemainingColumn(), console=stderr,
                  transient=False) as bar:
        task = bar.add_task("", total=total, label=f"{config['algorithm']} {config['scenario']} seed {config['seed']}")

        def progress(row: Mapping[str, Any]) -> None:
            if row.get("phase") == "train":
                text = f"delivered/episode {row['delivered']:.2f}" if row.get("delivered") is not None else ""
                bar.update(task, completed=row["steps"], description=text)
            else:
                bar.update(task, completed=row["steps"],
                           description=f"validation {row['phase']}: delivered {row['delivered_mean']:.2f}")

        try:
            return train_run(config, out, resume=resume, progress=progress)
        except (ConfigError, RunDirError, CheckpointError) as exc:
            bar.stop()
            fail(str(exc), EXIT_USAGE)


def _show(summary: Mapping[str, Any], out: Path) -> None:
    from rich.table import Table

    table = Table(title=f"{summary['algorithm']} · {summary['scenario']} · seed {summary['seed']} · {summary['status']}")
    table.add_column("field")
    table.add_column("value")
    val = summary.get("validation") or {}
    rows = [("environment steps", f"{summary['steps']:,} of {summary['budget']:,}"), ("updates", str(summary["updates"])),
            ("validation delivered (200-204)", f"{val['delivered_mean']:.2f} {val['delivered']}" if val else "—"),
            ("policy", f"{out / 'policy.pt'} sha256 {summary['policy']['sha256'][:16]}…" if summary.get("policy") else "—"),
            ("config sha256", summary["config_sha256"][:16] + "…"), ("wall time", f"{summary['wall_time_s']:.1f} s"),
            ("resumed", str(summary["resumed"]))]
    for key, value in rows:
        table.add_row(key, value)
    stdout.print(table)
