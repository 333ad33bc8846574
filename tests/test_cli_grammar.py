"""One command-line grammar (docs/cli.md): every command's options are walked, and a second name for a
concept, one name with two types, an unregistered option or a stale alias fails here."""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path

import click
import pytest
from click.testing import CliRunner

from agspec.cli import run_cmds
from agspec.cli.examples import all_commands
from agspec.cli.grammar import CONCEPTS, RENAMED, rewrite
from agspec.cli.main import cli

COMMANDS = all_commands(cli, click.Context(cli))


def _options() -> list[tuple[str, click.Option]]:
    return [(path, p) for path, cmd in sorted(COMMANDS.items()) for p in cmd.params if isinstance(p, click.Option)]


def _long(option: click.Option) -> str:
    """The option's primary long name (`--observations` of `--observations/--no-observations`; `-k` alone)."""
    return next((o for o in option.opts if o.startswith("--")), option.opts[0])


def _type_key(option: click.Option) -> tuple:
    t = option.type
    if isinstance(t, click.Path):  # a file, a directory or either: one kind of value, a path
        return ("path", (), option.is_flag)
    bounds = (getattr(t, "min", None), getattr(t, "max", None)) if isinstance(t, click.types._NumberRangeBase) else ()
    return (t.name, bounds, option.is_flag)


def test_every_option_stands_for_a_registered_concept():  # F-CLI-GRAMMAR, docs/cli.md
    unknown = sorted({f"{path}: {_long(o)}" for path, o in _options()
                      if _long(o) not in CONCEPTS and o.name != "help"})
    assert unknown == [], "register these in agspec/cli/grammar.py CONCEPTS (and docs/cli.md): " + ", ".join(unknown)


def test_every_registered_concept_is_an_option_of_some_command():
    used = {_long(o) for _, o in _options()}
    assert sorted(set(CONCEPTS) - used) == []


def test_no_two_names_share_a_concept():  # F-CLI-GRAMMAR
    by_concept = defaultdict(list)
    for name, concept in CONCEPTS.items():
        by_concept[concept].append(name)
    assert [names for names in by_concept.values() if len(names) > 1] == []


def test_one_name_has_one_type_everywhere():
    kinds = defaultdict(set)
    for path, option in _options():
        kinds[_long(option)].add(_type_key(option))
    # --format chooses among each command's own outputs; --to among each conversion's targets
    mixed = {name: k for name, k in kinds.items() if len(k) > 1}
    assert mixed == {}, mixed


def test_a_short_name_means_one_long_name():
    short = defaultdict(set)
    for _, option in _options():
        for s in (o for o in option.opts if not o.startswith("--")):
            short[s].add(_long(option))
    assert {s: longs for s, longs in short.items() if len(longs) > 1} == {}
    assert short["-o"] == {"--output"} and short["-j"] == {"--jobs"} and short["-x"] == {"--exitfirst"}


def test_no_command_still_has_an_earlier_spelling():
    for rule in RENAMED:
        if rule.old == rule.new:
            continue
        for path in rule.commands:
            if path in COMMANDS:
                names = {n for p in COMMANDS[path].params if isinstance(p, click.Option) for n in p.opts}
                assert rule.old not in names, f"{path} {rule.old}: renamed to {rule.new}"


# minimal arguments that parse for each command with renamed options
BASE = {"conform": [], "diff": ["--impl", "reference", "--impl", "reference"], "render": [], "check": ["t.jsonl"],
        "evaluate": [], "run": ["flow-easy"], "instance": ["flow-easy"], "export": ["flow-easy"],
        "train": ["--algorithm", "ippo", "--scenario", "flow-easy", "--seed", "0"]}
VALUES = {"--ticks": "5", "--report": "r.jsonl", "--out": "o", "--out-dir": "d", "--impl-timeout": "2.5",
          "--format": "text", "--episodes": "3", "--seed": "7"}
CASES = [(path, rule) for rule in RENAMED for path in rule.commands if path in COMMANDS]


@pytest.mark.parametrize("path, rule", CASES, ids=[f"{p}{r.old}" for p, r in CASES])
def test_an_earlier_spelling_parses_as_the_new_one(path, rule):  # F-CLI-GRAMMAR, docs/cli.md, deprecated aliases
    old = [rule.old] if rule.flag else [rule.old, VALUES[rule.old]]
    rewritten, notes = rewrite(path, BASE[path] + old)
    assert notes and rule.new in notes[0]
    new = [rule.new] if rule.flag else [rule.new, rule.convert(VALUES[rule.old]) if rule.convert else VALUES[rule.old]]
    command = COMMANDS[path]
    parsed = command.make_context(path, list(rewritten)).params  # click consumes the list it parses
    assert parsed == command.make_context(path, BASE[path] + new).params
    # --opt=value is rewritten too
    if not rule.flag:
        assert rewrite(path, BASE[path] + [f"{rule.old}={VALUES[rule.old]}"])[0] == rewritten


def test_rewriting_leaves_values_and_what_follows_a_double_dash_alone():
    args = ["--impl", "python sim.py --ticks 5", "--", "--ticks", "3"]
    assert rewrite("conform", args) == (args, [])
    assert rewrite("conform", ["--horizon", "5"]) == (["--horizon", "5"], [])


def test_the_group_prints_a_deprecation_note_and_runs_the_command(tmp_path):
    result = CliRunner().invoke(cli, ["instance", "flow-easy", "--seed", "5", "-o", str(tmp_path / "i.json")])
    assert result.exit_code == 0, result.output
    assert "`--seed 5` is now `--generation-seed 5`" in result.stderr
    assert '"generation": 5' in (tmp_path / "i.json").read_text(encoding="utf-8")


@pytest.mark.parametrize("args, expected", [((), "paper-reproduction"), (("-o", "elsewhere"), "elsewhere"),
                                            (("--out-dir", "old"), "old")])
def test_evaluate_paper_never_writes_into_the_projects_docs_by_default(monkeypatch, args, expected):  # F-CLI-GRAMMAR
    seen = []
    monkeypatch.setattr(run_cmds, "_evaluate_paper", lambda campaign, out, fmt: seen.append(out))
    res = CliRunner().invoke(cli, ["evaluate", "--paper", *args])
    assert res.exit_code == 0, res.output
    assert seen == [Path(expected)]
