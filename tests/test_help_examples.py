"""Every command's --help ends with real examples (agspec/cli/examples.py): each parses against the
command it documents, and the quick read-only ones run successfully from the top of the clone."""

from __future__ import annotations

import shlex
from pathlib import Path

import click
import pytest
from click.testing import CliRunner

from agspec.cli.examples import EXAMPLES, all_commands
from agspec.cli.main import cli

ROOT = Path(__file__).resolve().parent.parent
COMMANDS = all_commands(cli, click.Context(cli))
RUNNABLE = ("validate catalogue/recipes/pair_assembly.ag", "validate catalogue/ --format json",
            "compile catalogue/recipes/pair_assembly.ag --pretty", "fmt catalogue/recipes/pair_assembly.ag",
            "fmt --check catalogue/scenarios/flow-easy.ag", "fingerprint catalogue/recipes/pair_assembly.ag coalition-medium",
            "export flow-easy --index 0", "catalogue list --format json")


def test_every_command_has_examples():
    assert set(COMMANDS) == set(EXAMPLES), "commands without examples, or examples of no command"


@pytest.mark.parametrize("path", sorted(EXAMPLES))
def test_help_ends_with_examples_that_parse(path):
    res = CliRunner().invoke(cli, [*path.split(), "--help"])
    assert res.exit_code == 0
    tail = res.output.rstrip().split("Examples:")[-1].strip().splitlines()
    assert [line.strip() for line in tail] == [f"agspec {e}" for e in EXAMPLES[path]]
    for example in EXAMPLES[path]:
        parse(shlex.split(example))


def parse(tokens: list[str]) -> None:
    """Parse a command line as click would, without running it (a UsageError on a bad example)."""
    ctx = click.Context(cli)
    command: click.Command = cli
    while isinstance(command, click.Group):  # the groups of agspec take no options
        name, tokens = tokens[0], tokens[1:]
        found = command.get_command(ctx, name)
        assert found is not None, f"no command {name!r}"
        command = found
    command.make_context(name, tokens, parent=ctx)


def test_a_bad_example_does_not_parse():
    with pytest.raises(click.UsageError):
        parse(["run", "flow-easy", "--no-such-option"])


@pytest.mark.parametrize("example", RUNNABLE)
def test_quick_examples_run(example, monkeypatch):
    assert any(example in lines for lines in EXAMPLES.values())
    monkeypatch.chdir(ROOT)
    res = CliRunner().invoke(cli, shlex.split(example))
    assert res.exit_code == 0, res.output
