"""Per-agent execution information I_t^u = (o_t^u, m_t^u) and action decoding (spec chapter 06).

Everything here is computed from the state *before* the actions of epoch t are applied
(O-SUPPORT-FRACTION).  Robot u is shown only the candidates that contain u, never filtered by
hidden remote conflicts (O-EXPOSURE).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from agspec.formats.actions import (  # O-ACTION-ENCODING
    DELIVER,
    HANDOFF0,
    IDLE,
    N_ACTIONS,
    OP0,
    OP_SLOTS,
    PICK0,
    PICK_SLOTS,
    RECEIVE0,
)
from agspec.interp import geometry
from agspec.interp.candidates import Candidate, xor_closed
from agspec.interp.model import DIRECTION_NAMES, DIRECTIONS, Model
from agspec.interp.state import Cell, State, cell_id



class SlotOverflow(RuntimeError):
    """O-ACTION-ENCODING: more options than action slots; v1 raises instead of truncating."""


@dataclass(frozen=True)
class Options:
    """The option lists of one robot at one epoch: what its pick and operation slots mean."""

    picks: tuple[dict[str, Any], ...]
    operations: tuple[Candidate, ...]
    supports: tuple[float, ...]  # support fraction of each operation option


def support_fraction(state: State, model: Model, cand: Candidate) -> float:
    """O-SUPPORT-FRACTION: recorded supporters / required robots (0 without a proposal or when hidden)."""
    if not model.support_visible:
        return 0.0
    proposal = state.proposals.get(cand.cid)
    return len(proposal.votes) / cand.size if proposal else 0.0


def pick_options(state: State, model: Model, cell: Cell) -> list[dict[str, Any]]:
    """O-PICK-OPTIONS: picks open to an input-column robot that is free, empty and not supporting."""
    robot = state.robots[cell]
    if cell[1] != 0 or not robot.free(state.t) or robot.holding is not None or robot.supports is not None:
        return []
    spacing = float(model.profile["spacing"])
    reach = float(model.profile["reach"])
    out = []
    for product in state.products:
        if product.delivered:
            continue
        recipe = model.recipes[product.recipe]
        needed = {tok for op in recipe.operations if not xor_closed(product, op) for tok in op.inputs}
        for token in recipe.raw:
            if token in product.raw_taken or token not in needed:
                continue
            row = product.source_rows[token]
            if cell[0] not in state.shelf_access.get(row, ()):
                continue
            stock = state.shelves[row].get(token, 0)
            if stock <= 0 or not geometry.reachable(cell, geometry.shelf_point(row, spacing), reach, spacing):
                continue
            out.append(
                {
                    "id": f"pick:{product.pid}:{token}:{row}",
                    "product": product.pid,
                    "recipe": product.recipe,
                    "token": token,
                    "shelf_row": row,
                    "stock": stock / model.shelf_capacity,
                    "_priority": product.spawn_time,
                }
            )
    out.sort(key=lambda o: (o["_priority"], o["id"]))  # FIFO priority, then id string
    return out


def build_options(state: State, model: Model, candidates: list[Candidate]) -> dict[Cell, Options]:
    """O-OPERATION-OPTIONS: each robot's operation options ordered by (-support, candidate id)."""
    per_robot: dict[Cell, list[tuple[float, str, Candidate]]] = {c: [] for c in model.cells}
    for cand in candidates:
        frac = support_fraction(state, model, cand)
        for m in cand.members:
            per_robot[m].append((frac, cand.cid, cand))
    out = {}
    for cell in model.cells:
        ops = sorted(per_robot[cell], key=lambda x: (-x[0], x[1]))
        picks = pick_options(state, model, cell)
        if len(ops) > OP_SLOTS or len(picks) > PICK_SLOTS:
            raise SlotOverflow(
                f"robot {cell_id(cell)} at t={state.t}: {len(picks)} pick options (limit {PICK_SLOTS}), "
                f"{len(ops)} operation options (limit {OP_SLOTS})"
            )
        out[cell] = Options(picks=tuple(picks), operations=tuple(c for _, _, c in ops), supports=tuple(f for f, _, _ in ops))
    return out


def action_mask(state: State, model: Model, cell: Cell, options: Options) -> list[bool]:
    """O-MASK: remove only locally detectable impossibilities; idle is always legal (INV-MASKING)."""
    mask = [False] * N_ACTIONS
    mask[IDLE] = True
    robot = state.robots[cell]
    if not robot.free(state.t):
        return mask
    n_ops = len(options.operations)
    if robot.supports is not None and state.t < robot.switch_lock:
        for k, cand in enumerate(options.operations):  # R-SWITCH-LOCK: only the pending candidate
            if cand.cid == robot.supports:
                mask[OP0 + k] = True
        return mask
    for k in range(n_ops):
        mask[OP0 + k] = True
    if robot.supports is not None:
        return mask  # a supporting robot may only keep or switch its support (R-HELD-MATERIAL)
    in_grid = [(d, (cell[0] + di, cell[1] + dj)) for d, (di, dj) in enumerate(DIRECTIONS)]
    in_grid = [(d, c) for d, c in in_grid if c in state.robots]
    if robot.holding is None:
        for k in range(len(options.picks)):
            mask[PICK0 + k] = True
        for d, _ in in_grid:
            mask[RECEIVE0 + d] = True
    else:
        for d, _ in in_grid:
            mask[HANDOFF0 + d] = True
        product = state.products[robot.holding[0]]
        spacing = float(model.profile["spacing"])
        if (
            robot.holding[1] == model.recipes[product.recipe].terminal
            and cell[1] == model.cols - 1
            and geometry.reachable(cell, geometry.output_point(cell[0], model.cols, spacing), float(model.profile["reach"]), spacing)
        ):
            mask[DELIVER] = True
    return mask


def decode(action: int, options: Options) -> tuple[str, Any]:
    """O-ACTION-ENCODING: integer action -> (kind, argument)."""
    if action == IDLE:
        return ("idle", None)
    if action == DELIVER:
        return ("deliver", None)
    if PICK0 <= action < PICK0 + PICK_SLOTS:
        return ("pick", options.picks[action - PICK0])
    if HANDOFF0 <= action < HANDOFF0 + 8:
        return ("handoff", action - HANDOFF0)
    if RECEIVE0 <= action < RECEIVE0 + 8:
        return ("receive", action - RECEIVE0)
    return ("support", options.operations[action - OP0])


def _held(state: State, model: Model, cell: Cell) -> dict[str, Any] | None:
    """Held item as observed: product, token and whether it is its recipe's terminal output."""
    item = state.robots[cell].holding
    if item is None:
        return None
    terminal = model.recipes[state.products[item[0]].recipe].terminal
    return {"product": item[0], "token": item[1], "final": item[1] == terminal}


def observation(state: State, model: Model, cell: Cell, options: Options, mask: list[bool]) -> dict[str, Any]:
    """O-OBSERVATION: own state, Moore neighbours' task-level state, options, mask, own support.

    No global state, no remote robots, no due dates or values, no supporter identities.
    """
    robot = state.robots[cell]
    neighbours = []
    for d, (di, dj) in enumerate(DIRECTIONS):
        nc = (cell[0] + di, cell[1] + dj)
        if nc not in state.robots:
            continue
        nb = state.robots[nc]
        neighbours.append(
            {
                "dir": DIRECTION_NAMES[d],
                "robot": cell_id(nc),
                "holding": _held(state, model, nc),
                "busy": not nb.free(state.t),
                "failed": False,
                "op": nb.op_label,
                "role": nb.role_label,
            }
        )
    ops = []
    for cand, frac in zip(options.operations, options.supports):
        role = next(r for m, r in cand.roles if m == cell)
        ops.append(
            {
                "id": cand.cid,
                "product": cand.pid,
                "recipe": cand.recipe,
                "operation": cand.op.id,
                "type": cand.op.type,
                "kmin": cand.op.kmin,
                "size": cand.size,
                "role": role,
                "members": [cell_id(m) for m in cand.members],
                "duration": cand.plan.duration,
                "min_reach_margin": cand.plan.min_reach_margin,
                "support": frac,
            }
        )
    return {
        "robot": cell_id(cell),
        "t": state.t,
        "grid": [model.rows, model.cols],
        "holding": _held(state, model, cell),
        "busy": not robot.free(state.t),
        "failed": False,
        "supports": robot.supports,
        "neighbours": neighbours,
        "pick_options": [{k: v for k, v in p.items() if not k.startswith("_")} for p in options.picks],
        "operation_options": ops,
        "mask": mask,
    }
