"""A-PZ-RENDER: a plain-text picture of the global state (for people; not part of any observation).

    t=12  released 3  delivered 0  WIP 3  activities 2  proposals 1
    shelf |  A 5/6 B 6/6 |  [A  *] [    ] [    ] [    ] | out
    ...

Each robot shows its held token (up to 4 characters) and a flag: ``*`` busy, ``?`` pending support.
"""

from __future__ import annotations

from agspec.interp.model import Model
from agspec.interp.state import State


def _robot(state: State, cell: tuple[int, int]) -> str:
    r = state.robots[cell]
    token = r.holding[1][:4] if r.holding else ""
    flag = "*" if not r.free(state.t) else ("?" if r.supports is not None else " ")
    return f"[{token:<4}{flag}]"


def render_text(state: State, model: Model) -> str:
    head = (f"t={state.t}  released {state.released}  delivered {state.delivered}  WIP {state.wip}  "
            f"activities {len(state.activities)}  proposals {len(state.proposals)}")
    lines = [head]
    for i in range(model.rows):
        stock = " ".join(f"{tok} {n}/{model.shelf_capacity}" for tok, n in sorted(state.shelves[i].items()))
        robots = " ".join(_robot(state, (i, j)) for j in range(model.cols))
        lines.append(f"shelf | {stock:<24} | {robots} | out")
    return "\n".join(lines)
