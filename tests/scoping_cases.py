"""Items on a few small instances and the scripted simulator that fails on some of them, for the
generator of RES-GIVE-UP-SCOPE (tests/test_conform_scoping.py, benchmarks/fuzz_harness.py)."""

from __future__ import annotations

import json
import shlex
import sys
from pathlib import Path

from agspec.conform.items import Item

HERE = Path(__file__).resolve().parent
SIM = HERE / "fakes" / "scripted_sim.py"
INSTANCES = HERE / "mutants" / "instances"
NAMES = ("solo-1x2-flat", "pair-1x2-flat", "duo-1x2-flat")


def scripted(*args: str) -> str:
    return shlex.join([sys.executable, str(SIM), *args])


def small_items(names=NAMES, repeat: int = 1) -> list[Item]:
    out = []
    for k in range(repeat):
        for name in names:
            inst = json.loads((INSTANCES / f"{name}.json").read_text(encoding="utf-8"))
            out.append(Item(id=f"e-{name}-{k}", kind="episode", title=name, instance=inst,
                            execution_seed=inst["seeds"]["execution"], ticks=3,
                            controller={"name": "greedy", "seed": 1}))
    return out


__all__ = ["NAMES", "SIM", "scripted", "small_items"]
