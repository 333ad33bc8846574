"""Real examples that end every command's ``--help`` (attached as the click epilog).

Kept in one table so that tests/test_help_examples.py can parse every one of them (and run the quick
ones from a clone of the repository); paths are relative to the top of a clone.
"""

from __future__ import annotations

import click

# command path (space-separated) -> example command lines, without the leading `agspec`
EXAMPLES: dict[str, tuple[str, ...]] = {
    "validate": ("validate catalogue/recipes/pair_assembly.ag", "validate catalogue/ --format json"),
    "compile": ("compile catalogue/recipes/pair_assembly.ag --pretty",),
    "fmt": ("fmt catalogue/recipes/pair_assembly.ag", "fmt --check catalogue/scenarios/flow-easy.ag"),
    "instance": ("instance coalition-medium --index 3 -o inst.json",),
    "fingerprint": ("fingerprint catalogue/recipes/pair_assembly.ag coalition-medium",),
    "export": ("export flow-easy --index 0",),
    "catalogue": ("catalogue list", "catalogue verify --catalogue catalogue"),
    "catalogue list": ("catalogue list --format json",),
    "catalogue verify": ("catalogue verify", "catalogue verify --catalogue ./catalogue"),
    "catalogue lock": ("catalogue lock --lock /tmp/lock.json",),
    "run": ("run coalition-medium --controller greedy", "run flow-easy --index 2 --trace flow.jsonl --horizon 50"),
    "evaluate": ("evaluate --scenario flow-easy --controller greedy --indices 1000-1004",
                 "evaluate --policy examples/policies/heuristic.py:make_policy --name heuristic "
                 "--scenario coalition-medium --indices 1000-1004 -o results.json",
                 "evaluate --from results.json more.json",
                 "evaluate --paper -j 2 --executor ray"),
    "report": ("report results.json --to latex -o table.tex", "report results.json --to svg -o families.svg",
               "report runs/mappo-coalition-medium-s0 runs/mappo-coalition-medium-s1 --to png -o curves.png"),
    "diff": ("diff --impl reference --impl 'python sim.py --agspec' --scenario flow-easy --horizon 40",
             "diff --impl reference --impl 'python my_sim.py' --indices 0-7 -j 2 --format json"),
    "conform": ("conform --impl reference -x", "conform --impl './sim --agspec' -o report.jsonl"),
    "serve": ("serve --no-observations",),
    "check": ("check flow.jsonl", "check flow.jsonl --format json", "check runs/ -j 2 -o check.jsonl"),
    "trace": ("trace validate flow.jsonl",),
    "trace validate": ("trace validate flow.jsonl --format json",),
    "explain": ("explain M-RF-BR", "explain RES-TOPOLOGY-LINE AG305", "explain M- --format json"),
    "train": ("train --algorithm mappo --scenario coalition-medium --seed 0 -o runs/mappo-coalition-medium-s0",
              "train --algorithm ippo --scenario flow-easy --seed 1 --steps 16000 --set ppo.clip=0.2 -o runs/ippo-s1",
              "train --algorithm mappo --scenario coalition-medium --seed 0 -o runs/mappo-coalition-medium-s0 --resume",
              "train --campaign paper -o campaign/ --executor ray --address auto --gpus-per-run 0.5"),
    "render": ("render flow.jsonl -o replay.html",
               "render --impl reference --scenario coalition-medium --horizon 60 -o replay.html"),
}


def epilog(path: str) -> str | None:
    lines = EXAMPLES.get(path)
    if not lines:
        return None
    # "\b" keeps click from re-wrapping the block
    return "\b\nExamples:\n" + "\n".join(f"  agspec {line}" for line in lines)


def attach(command: click.Command, path: str) -> click.Command:
    """Give ``command`` (and the subcommands of a group) its examples, unless it already has an epilog."""
    if command.epilog is None:
        command.epilog = epilog(path)
    if isinstance(command, click.Group):
        for name, sub in command.commands.items():
            attach(sub, f"{path} {name}")
    return command


def all_commands(root: click.Group, ctx: click.Context) -> dict[str, click.Command]:
    """Every command path of the CLI -> its command (groups included)."""
    out: dict[str, click.Command] = {}

    def walk(group: click.Group, prefix: str) -> None:
        for name in group.list_commands(ctx):
            cmd = group.get_command(ctx, name)
            if cmd is None:
                continue
            path = f"{prefix}{name}"
            out[path] = cmd
            if isinstance(cmd, click.Group):
                walk(cmd, path + " ")

    walk(root, "")
    return out
