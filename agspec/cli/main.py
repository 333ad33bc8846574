"""The ``agspec`` command line: a thin group; each command group lives in its own module."""

from __future__ import annotations

import importlib
import sys
import traceback

import click
from rich.text import Text

from agspec import __version__
from agspec.cli.common import EXIT_INTERNAL, EXIT_USAGE, stderr
from agspec.cli.examples import attach
from agspec.cli.grammar import rewrite
from agspec.formats.output import OutputError, guard_stdout, silence_stdout
from agspec.transport import reaper
from agspec.transport.teardown import exit_on_signals

# command name -> "module:function" (imported lazily so a broken module never breaks the CLI)
COMMANDS = {
    "validate": "agspec.cli.dsl_cmds:validate",
    "compile": "agspec.cli.dsl_cmds:compile_cmd",
    "fmt": "agspec.cli.dsl_cmds:fmt",
    "instance": "agspec.cli.instance_cmds:instance",
    "fingerprint": "agspec.cli.instance_cmds:fingerprint",
    "export": "agspec.cli.instance_cmds:export",
    "catalogue": "agspec.cli.instance_cmds:catalogue",
    "run": "agspec.cli.run_cmds:run",
    "evaluate": "agspec.cli.run_cmds:evaluate",
    "diff": "agspec.cli.diff_cmds:diff",
    "conform": "agspec.cli.conform_cmds:conform",
    "serve": "agspec.cli.conform_cmds:serve",
    "check": "agspec.cli.conform_cmds:check",
    "trace": "agspec.cli.conform_cmds:trace",
    "render": "agspec.cli.render_cmds:render",
    "report": "agspec.cli.report_cmds:report",
    "explain": "agspec.cli.explain_cmds:explain",
    "train": "agspec.cli.train_cmds:train",
}


class LazyGroup(click.Group):
    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(COMMANDS)

    def get_command(self, ctx: click.Context, name: str) -> click.Command | None:
        target = COMMANDS.get(name)
        if target is None:
            return None
        module, attr = target.split(":")
        return attach(getattr(importlib.import_module(module), attr), name)

    def resolve_command(self, ctx: click.Context, args: list[str]):
        # docs/cli.md: earlier spellings of options are hidden aliases, rewritten before the command parses
        name, command, rest = super().resolve_command(ctx, args)
        if name is not None:
            rest, notes = rewrite(name, rest)
            for note in notes:
                stderr.print(Text.assemble(("deprecated", "yellow"), ": ", note))
        return name, command, rest

    def invoke(self, ctx: click.Context) -> object:
        # F-EXIT-CODES: an interrupted run exits 130. click would turn the KeyboardInterrupt into
        # "Aborted!" and exit 1; the commands' finally blocks have torn their simulators down by now
        # (F-PROTOCOL-TEARDOWN).
        try:
            return super().invoke(ctx)
        except KeyboardInterrupt:
            stderr.print("interrupted")
            raise SystemExit(130) from None


@click.group(cls=LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="agspec")
def cli() -> None:
    """Executable specification and conformance toolkit for AssemblyGrid v1."""


def output_failed(exc: OutputError) -> SystemExit:
    """F-OUTPUT-FAILURES: a result that cannot be written is an I/O error (exit 2) with one located
    message; standard output read by a closed pipe (``| head -1``) ends the command quietly (exit 0)."""
    if exc.path == "<stdout>":
        silence_stdout()
    if exc.closed_pipe:
        return SystemExit(0)
    stderr.print(Text.assemble(("error", "bold red"), ": ", str(exc)))
    return SystemExit(EXIT_USAGE)


def main(argv: list[str] | None = None) -> None:
    """Entry point: click handles usage errors (exit 2); anything unexpected is an internal error.

    Every process the command starts is gone when it ends, on every exit path (F-PROCESS-TEARDOWN):
    SIGTERM and SIGHUP end the command through its ``finally`` blocks, and what escaped them is killed."""
    began = reaper.now_ticks()
    reaper.adopt_orphans()
    try:
        with exit_on_signals():
            _main(argv)
    finally:
        reaper.kill_descendants(began)


def _main(argv: list[str] | None) -> None:
    guard_stdout()
    try:
        cli.main(args=argv, prog_name="agspec", standalone_mode=True)
        sys.stdout.flush()
    except OutputError as exc:
        raise output_failed(exc) from None
    except SystemExit as exc:
        try:
            sys.stdout.flush()  # what is still buffered fails here, not at interpreter exit
        except OutputError as failed:
            raise output_failed(failed) from None
        raise exc
    except KeyboardInterrupt:
        stderr.print("interrupted")
        raise SystemExit(130)
    except BrokenPipeError:
        raise SystemExit(0)
    except Exception:  # pragma: no cover - only reached on agspec bugs
        stderr.print("[bold red]internal error[/]: agspec hit a bug; please file an issue with this report:")
        stderr.print(traceback.format_exc(), markup=False)
        raise SystemExit(EXIT_INTERNAL)


if __name__ == "__main__":  # pragma: no cover
    main(sys.argv[1:])
