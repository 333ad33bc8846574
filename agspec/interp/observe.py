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
from agspec.interp.model import Model
from agspec.interp.state import Cell, Product, State, cell_id


class SlotOverflow(RuntimeError):
    """O-ACTION-ENCODING: more options than action slots; v1 raises instead of truncating."""


@dataclass(frozen=True)
class Options:
    """The option lists of one robot at one epoch: what its pick and operation slots mean."""

    picks: tuple[dict[str, Any], ...]
    operations: tuple[Candidate, ...]
    supports: tuple[float, ...]  # support fraction of each operation option


NO_OPTIONS = Options(picks=(), operations=(), supports=())


def support_fraction(state: State, model: Model, cand: Candidate) -> float:
    """O-SUPPORT-FRACTION: recorded supporters / required robots (0 without a proposal or when hidden)."""
    if not model.support_visible:
        return 0.0
    proposal = state.proposals.get(cand.cid)
    return len(proposal.votes) / cand.size if proposal else 0.0


def pickable_tokens(state: State, model: Model) -> list[tuple[Product, str, int, int]]:
    """O-PICK-OPTIONS, the part that does not depend on the robot: (product, token, shelf row, stock)
    of every raw token an open product still needs, has not taken and finds in stock."""
    out = []
    for product in state.products:
        if product.delivered:
            continue
        recipe = model.recipes[product.recipe]
        if not product.xor_choice:  # no alternative is closed (RC-XOR): every input is needed
            needed = recipe.input_tokens
        else:
            needed = {tok for op in recipe.operations if not xor_closed(product, op) for tok in op.inputs}
        for token in recipe.raw:
            if token in product.raw_taken or token not in needed:
                continue
            row = product.source_rows[token]
            stock = state.shelves[row].get(token, 0)
            if stock > 0:
                out.append((product, token, row, stock))
    return out


def pick_options(state: State, model: Model, cell: Cell,
                 pickable: list[tuple[Product, str, int, int]] | None = None) -> list[dict[str, Any]]:
    """O-PICK-OPTIONS: picks open to an input-column robot that is free, empty and not supporting:
    the pickable tokens whose shelf row this robot may access and reach.  ``pickable`` is
    :func:`pickable_tokens` of this state when the caller already has it."""
    robot = state.robots[cell]
    if cell[1] != 0 or not robot.free(state.t) or robot.holding is not None or robot.supports is not None:
        return []
    spacing = float(model.profile["spacing"])
    reach = float(model.profile["reach"])
    out = []
    for product, token, row, stock in pickable_tokens(state, model) if pickable is None else pickable:
        if cell[0] not in state.shelf_access.get(row, ()):
            continue
        if not geometry.reachable(cell, geometry.shelf_point(row, spacing), reach, spacing):
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


def build_options(state: State, model: Model, candidates: list[Candidate],
                  last: dict[Cell, Options] | None = None) -> dict[Cell, Options]:
    """O-OPERATION-OPTIONS: each robot's operation options ordered by (-support, candidate id).

    ``last`` (the previous epoch's): a robot's Options equal to its previous ones are the previous
    object, so that consumers which test identity (the all-agents encoder) skip them."""
    per_robot: dict[Cell, list[tuple[float, str, Candidate]]] = {}  # robots in no candidate are absent
    for cand in candidates:
        frac = support_fraction(state, model, cand)
        for m in cand.members:
            per_robot.setdefault(m, []).append((frac, cand.cid, cand))
    # most robots, most epochs, have no option: they share NO_OPTIONS (Options are immutable)
    out = dict.fromkeys(model.cells, NO_OPTIONS)
    pickable = pickable_tokens(state, model)
    # only input-column robots can pick (O-PICK-OPTIONS); pick_options says so too
    pickers = model.input_column if pickable else ()
    for cell in sorted({*per_robot, *pickers}):
        ops = sorted(per_robot[cell], key=lambda x: (-x[0], x[1])) if cell in per_robot else []
        picks = pick_options(state, model, cell, pickable) if pickable else []
        if len(ops) > OP_SLOTS or len(picks) > PICK_SLOTS:
            raise SlotOverflow(
                f"robot {cell_id(cell)} at t={state.t}: {len(picks)} pick options (limit {PICK_SLOTS}), "
                f"{len(ops)} operation options (limit {OP_SLOTS})"
            )
        if ops or picks:
            opts = Options(picks=tuple(picks), operations=tuple(c for _, _, c in ops),
                           supports=tuple(f for f, _, _ in ops))
            kept = last.get(cell) if last is not None else None
            out[cell] = kept if opts == kept else opts
    return out


IDLE_ONLY = (True,) + (False,) * (N_ACTIONS - 1)  # O-MASK of a robot with no other legal action

Mask = tuple[bool, ...]  # immutable, so the common masks are shared templates (IDLE_ONLY, Model.direction_masks)


def action_mask(state: State, model: Model, cell: Cell, options: Options) -> Mask:
    """O-MASK: remove only locally detectable impossibilities; idle is always legal (INV-MASKING)."""
    robot = state.robots[cell]
    if not robot.free(state.t):
        return IDLE_ONLY
    n_ops = len(options.operations)
    if robot.supports is not None:
        mask = list(IDLE_ONLY)
        if state.t < robot.switch_lock:
            for k, cand in enumerate(options.operations):  # R-SWITCH-LOCK: only the pending candidate
                if cand.cid == robot.supports:
                    mask[OP0 + k] = True
            return tuple(mask)
        for k in range(n_ops):
            mask[OP0 + k] = True
        return tuple(mask)  # a supporting robot may only keep or switch its support (R-HELD-MATERIAL)
    receive, handoff = model.direction_masks[cell]  # idle and the receive / handoff slots of G_handoff neighbours
    if robot.holding is None:
        if not options.picks and not n_ops:
            return receive
        mask = list(receive)
        for k in range(len(options.picks)):
            mask[PICK0 + k] = True
    else:
        product = state.products[robot.holding[0]]
        spacing = float(model.profile["spacing"])
        deliver = (
            robot.holding[1] == model.recipes[product.recipe].terminal
            and cell[1] == model.cols - 1
            and geometry.reachable(cell, geometry.output_point(cell[0], model.cols, spacing), float(model.profile["reach"]), spacing)
        )
        if not deliver and not n_ops:
            return handoff
        mask = list(handoff)
        mask[DELIVER] = deliver
    for k in range(n_ops):
        mask[OP0 + k] = True
    return tuple(mask)


def action_masks(state: State, model: Model, options: dict[Cell, Options],
                 last: dict[Cell, Mask] | None = None) -> dict[Cell, Mask]:
    """O-MASK of every robot, row-major: :func:`action_mask`, with its commonest answers (a busy robot;
    a free robot that supports nothing, has no option and cannot deliver: its receive or handoff
    template) found without the call.

    ``last`` (the previous epoch's): a mask equal to the robot's previous one is the previous object
    (the shared templates are always the same objects)."""
    t = state.t
    out = {}
    # the state's robots and the option lists are keyed by every cell in row-major order (R-IDS)
    for (cell, receive, handoff, output_column), robot, opts in zip(model.mask_rows, state.robots.values(),
                                                                      options.values()):
        if robot.busy_until > t or robot.incoming is not None:  # not free (R-EXECUTION)
            out[cell] = IDLE_ONLY
        elif opts is NO_OPTIONS and robot.supports is None and (robot.holding is None or not output_column):
            out[cell] = receive if robot.holding is None else handoff  # R-DELIVERY: output column only
        else:
            mask = action_mask(state, model, cell, opts)
            kept = last.get(cell) if last is not None else None
            out[cell] = kept if mask == kept else mask
    return out


def _kind(action: int) -> tuple[str, int | None]:
    """O-ACTION-ENCODING: the kind of an integer action and its slot or direction."""
    if action == IDLE:
        return ("idle", None)
    if action == DELIVER:
        return ("deliver", None)
    if PICK0 <= action < PICK0 + PICK_SLOTS:
        return ("pick", action - PICK0)
    if HANDOFF0 <= action < HANDOFF0 + 8:
        return ("handoff", action - HANDOFF0)
    if RECEIVE0 <= action < RECEIVE0 + 8:
        return ("receive", action - RECEIVE0)
    return ("support", action - OP0)


# O-ACTION-ENCODING, decoded: one entry per action integer, (kind, pick or operation slot, or handoff or
# receive direction); a pick or support slot names the robot's option in that slot (Options.picks, .operations)
ACTION_KINDS = tuple(_kind(a) for a in range(N_ACTIONS))


def _held(state: State, model: Model, cell: Cell) -> dict[str, Any] | None:
    """Held item as observed: product, token and whether it is its recipe's terminal output."""
    item = state.robots[cell].holding
    if item is None:
        return None
    terminal = model.recipes[state.products[item[0]].recipe].terminal
    return {"product": item[0], "token": item[1], "final": item[1] == terminal}


@dataclass(frozen=True)
class EpochViews:
    """What every observation of one epoch shares, built once per epoch instead of once per observer:
    each robot's public view (what its neighbours see) and each candidate's option record."""

    robots: dict[Cell, dict[str, Any]]
    options: dict[str, dict[str, Any]]


def public_view(state: State, model: Model, cell: Cell) -> dict[str, Any]:
    """O-OBSERVATION, neighbour part: robot id, held item, busy, current activity and role labels.

    The record of a neighbour entry; its direction ``dir`` is the observer's, set in each copy."""
    robot = state.robots[cell]
    return {"dir": None, "robot": cell_id(cell), "holding": _held(state, model, cell), "busy": not robot.free(state.t),
            "failed": False, "op": robot.op_label, "role": robot.role_label}


def option_record(cand: Candidate) -> dict[str, Any]:
    """O-OBSERVATION, operation option: the record without the observer's role and the support."""
    return {
        "id": cand.cid,
        "product": cand.pid,
        "recipe": cand.recipe,
        "operation": cand.op.id,
        "type": cand.op.type,
        "kmin": cand.op.kmin,
        "size": cand.size,
        "role": None,
        "members": [cell_id(m) for m in cand.members],
        "duration": cand.plan.duration,
        "min_reach_margin": cand.plan.min_reach_margin,
        "support": None,
    }


def epoch_views(state: State, model: Model, candidates: list[Candidate]) -> EpochViews:
    return EpochViews({c: public_view(state, model, c) for c in model.cells},
                      {cand.cid: option_record(cand) for cand in candidates})


def observation(state: State, model: Model, cell: Cell, options: Options, mask: Mask,
                views: EpochViews | None = None) -> dict[str, Any]:
    """O-OBSERVATION: own state, G_obs neighbours' task-level state, options, mask, own support.

    No global state, no remote robots, no due dates or values, no supporter identities.
    ``views`` (optional) are the epoch's shared parts; every record gets its own copies.
    """
    public = views.robots if views is not None else {
        nc: public_view(state, model, nc) for nc in (cell, *(nc for _, _, nc in model.observation_slots[cell]))}
    own = public[cell]
    neighbours = []
    for _, direction, nc in model.observation_slots[cell]:
        record = public[nc].copy()
        record["dir"] = direction
        if record["holding"] is not None:
            record["holding"] = dict(record["holding"])
        neighbours.append(record)
    ops = []
    for cand, frac in zip(options.operations, options.supports):
        record = dict(views.options[cand.cid]) if views is not None else option_record(cand)
        record["role"] = next(r for m, r in cand.roles if m == cell)
        record["members"] = list(record["members"])
        record["support"] = frac
        ops.append(record)
    return {
        "robot": own["robot"],
        "t": state.t,
        "grid": [model.rows, model.cols],
        "holding": None if own["holding"] is None else dict(own["holding"]),
        "busy": own["busy"],
        "failed": False,
        "supports": state.robots[cell].supports,
        "neighbours": neighbours,
        "pick_options": [{k: v for k, v in p.items() if not k.startswith("_")} for p in options.picks]
        if options.picks else [],
        "operation_options": ops,
        "mask": list(mask),
    }
