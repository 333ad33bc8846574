"""One command-line grammar (docs/cli.md): one name per concept across every command.

* :data:`CONCEPTS` — every option name any command has, with the one concept it stands for; a test
  walks every command and fails on an option that is not here, on two names for one concept, and on
  one name with two types;
* the option factories below — the options several commands share are declared once, so their
  type, range and wording cannot drift apart;
* :data:`RENAMED` — the spellings of earlier releases, still accepted as hidden aliases: the group
  rewrites them before a command parses its arguments (:func:`rewrite`) and prints a deprecation note.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import click

# ----------------------------------------------------------------------------- the concepts

CONCEPTS: dict[str, str] = {
    # what a command writes and prints
    "--output": "where the command writes its principal result: a file, or a directory where the command says so",
    "--format": "the form of what is printed on stdout: a rich table, or JSON valid against the command's schema",
    "--to": "the target format of a conversion (export, report)",
    "--trace": "also write the episode's trace (F-TRACE) to this file",
    "--repro-dir": "the directory where reproducers of failures are written",
    "--title": "the page title",
    # what runs
    "--impl": "the implementation under test: reference, a command line, or python:module:factory",
    "--policy": "a policy to run: PATH.py:NAME, module:NAME or a command line",
    "--controller": "a reference controller (spec/11)",
    "--scenario": "a scenario: an official name, a .ag file or an instance .json",
    "--index": "one suite index of the scenario's instances (S-SEEDS)",
    "--indices": "several suite indices, e.g. 1000-1049 or 1000,1003 (S-SPLITS)",
    "--split": "a named set of suite indices (S-SPLITS)",
    "--generation-seed": "an instance from an explicit generation seed instead of a suite index (S-SEEDS)",
    "--execution-seed": "override the instance's execution seed (S-SEEDS)",
    "--seed": "the seed of the random choices the command itself makes while it works (diff's exploration, a training run)",
    "--horizon": "episode length: stop after this many ticks (default: the scenario's horizon)",
    "--episodes": "episodes per catalogue scenario (greedy, then seeded random controllers)",
    "--repeat": "episodes per scenario each policy runs",
    "--timeout": "seconds the implementation or policy under test may take to answer one request or decision",
    "--load-timeout": "seconds a policy may take to load (import and factory)",
    "--observations": "include every robot's observation",
    "--masks": "include every robot's action mask",
    "--strict": "a masked action is an error instead of idle (F-POLICY-ILLEGAL)",
    # selection and stopping
    "-k": "select items by id, title, tag, rule or glob (and/or/not)",
    "--exitfirst": "stop at the first failure (-x; --keep-going runs everything)",
    "--max-fail": "stop after this many failures or errors",
    # where work runs (spec/14)
    "--jobs": "workers running items in parallel (-j)",
    "--executor": "where items run: local processes or Ray",
    "--address": "the Ray cluster to join",
    "--retries": "re-dispatch an item whose worker died at most this many times",
    "--dispatch-seed": "dispatch items in an order shuffled with this seed (results keep item order)",
    "--runtime-env": "a Ray runtime environment",
    "--gpus-per-run": "GPUs each training run asks its worker for",
    # documents
    "--search-path": "an extra directory to resolve `use` and names (-I)",
    "--pretty": "indented or single-line JSON",
    "--check": "exit 1 if the file is not in canonical form, writing nothing",
    "--write": "rewrite the file in canonical form (-w)",
    "--no-semantic": "only syntax, build and schema checks",
    "--catalogue": "the catalogue directory to check",
    "--lock": "the lock file",
    "--update": "rewrite the lock from the catalogue",
    # conform
    "--expect": "an expected-failures file (F-EXPECT)",
    "--validate-protocol": "validate every protocol message against its full schema",
    "--coverage": "print what the suite covers (F-CONFORM-COVERAGE) and exit",
    "--replay": "re-run a reproducer file (F-REPRO)",
    "--no-suite": "skip the conformance suite (catalogue episodes only)",
    "--suite": "the suite root directory",
    "--require": "fail unless the run proves this level (F-CONFORM-LEVELS)",
    "--float-tolerance": "compare floats with this absolute tolerance",
    "--golden-cache": "where golden reference traces are kept (F-GOLDEN), or off",
    # diff
    "--small": "small generated instances per scenario",
    "--hypothesis-examples": "hypothesis-generated action sequences per episode",
    "--illegal-rate": "the share of generated actions that are illegal or out of range (F-DIFF-ACTIONS)",
    "--shrink-budget": "at most this many replays while shrinking",
    "--shrink-seconds": "the time limit of shrinking",
    "--any-divergence": "while shrinking, accept any divergence, not only the first one's kind",
    # evaluate and report
    "--from": "read results bundles instead of (or before) running",
    "--name": "the label of the --policy of the same position",
    "--policy-version": "the version recorded for the --policy of the same position",
    "--metric": "a metric to show",
    "--diagnostics": "also show the mechanism diagnostics",
    "--no-published": "leave out the paper's published MARL rows",
    "--paper": "run what the paper's tables report and write the reproduction report",
    "--allow-incomplete": "render rows with errors or missing episodes, marked (F-POLICY-COVERAGE)",
    # render
    "--diff": "show a conformance report's first divergence side by side",
    "--case": "the failing item of the report to show",
    "--rerun": "re-run the reproducer's implementation instead of drawing the recorded reply",
    "--keyframe": "a full state every this many ticks",
    # train
    "--algorithm": "the learning algorithm (ippo, mappo, qmix)",
    "--steps": "the training budget in environment steps",
    "--device": "the torch device (cpu, cuda)",
    "--resume": "continue a cut-short run from its last checkpoint",
    "--set": "override one setting of the training configuration (key=value)",
    "--config": "a file of training settings",
    "--print-config": "print the resolved training configuration and exit",
    "--envs": "environment copies stepped in parallel",
    "--threads": "torch intra-op threads of each process that runs torch (CAMP-THREADS)",
    "--campaign": "a training campaign: `paper` or a plan file",
}


# ----------------------------------------------------------------------------- shared options

TIMEOUT_RANGE = click.FloatRange(0.001, 3600)
HORIZON_RANGE = click.IntRange(1, 10**6)


def output_option(help: str, *, default: str | None = None, file: bool = True) -> Callable:
    """``-o/--output``: the principal result of the command (CONCEPTS)."""
    return click.option("-o", "--output", "output", type=click.Path(dir_okay=not file, file_okay=file),
                        default=default, show_default=default is not None, metavar="FILE" if file else "DIRECTORY",
                        help=help)


def horizon_option(help: str = "Stop after this many ticks (default: the scenario's horizon).",
                   default: int | None = None) -> Callable:
    return click.option("--horizon", "horizon", type=HORIZON_RANGE, default=default,
                        show_default=default is not None, help=help)


def timeout_option(help: str, default: float) -> Callable:
    return click.option("--timeout", "timeout", type=TIMEOUT_RANGE, default=default, show_default=True,
                        metavar="SECONDS", help=help)


def exitfirst_option(default: bool) -> Callable:
    return click.option("-x", "--exitfirst/--keep-going", "exitfirst", default=default, show_default=True,
                        help="Stop at the first failure (--keep-going: run everything).")


# ----------------------------------------------------------------------------- earlier spellings


@dataclass(frozen=True)
class Renamed:
    """An earlier spelling of an option: ``old`` in ``commands`` is now ``new``; ``convert`` maps its
    value (None: the value is kept); ``flag``: the old option took no value."""

    commands: tuple[str, ...]
    old: str
    new: str
    convert: Callable[[str], str] | None = None
    flag: bool = False


def _indices_of_count(value: str) -> str:
    """diff's old ``--episodes N`` meant suite indices 0..N-1."""
    n = int(value)
    return f"0-{n - 1}" if n > 1 else "0"


RENAMED: tuple[Renamed, ...] = (
    Renamed(("conform", "diff", "render"), "--ticks", "--horizon"),
    Renamed(("conform", "check"), "--report", "--output"),
    Renamed(("evaluate", "diff", "train"), "--out", "--output"),
    Renamed(("evaluate",), "--out-dir", "--output"),
    Renamed(("conform", "diff", "render"), "--impl-timeout", "--timeout"),
    Renamed(("diff",), "--format", "--format", convert=lambda v: "table" if v == "text" else v),
    Renamed(("diff",), "--episodes", "--indices", convert=_indices_of_count),
    Renamed(("run", "instance", "export"), "--seed", "--generation-seed"),
    Renamed(("render",), "--replay", "--rerun", flag=True),
)


def rewrite(command: str, args: list[str]) -> tuple[list[str], list[str]]:
    """``args`` of ``command`` with every earlier spelling replaced, and one note per replacement.

    Only option positions are rewritten (``--name value`` and ``--name=value``); nothing after ``--``.
    """
    table = {r.old: r for r in RENAMED if command in r.commands}
    if not table:
        return list(args), []
    out: list[str] = []
    notes: list[str] = []
    i = 0
    while i < len(args):
        arg = args[i]
        if arg == "--":
            out += args[i:]
            break
        name, eq, inline = arg.partition("=")
        rule = table.get(name)
        if rule is None or (rule.old == rule.new and rule.convert is None):
            out.append(arg)
            i += 1
            continue
        if rule.flag:
            out.append(rule.new)
            i += 1
        else:
            value = inline if eq else (args[i + 1] if i + 1 < len(args) else None)
            if value is None:  # let the command report the missing value under its new name
                out.append(rule.new)
                i += 1
                continue
            converted = rule.convert(value) if rule.convert else value
            if rule.old == rule.new and converted == value:
                out.append(arg)
                if not eq:
                    out.append(value)
                i += 1 if eq else 2
                continue
            out += [rule.new, converted]
            i += 1 if eq else 2
            shown = f"{rule.new} {converted}"
            notes.append(f"`{arg if eq else name + ' ' + value}` is now `{shown}` "
                         f"(docs/cli.md); the old spelling will be removed")
            continue
        notes.append(f"`{name}` is now `{rule.new}` (docs/cli.md); the old spelling will be removed")
    return out, notes
