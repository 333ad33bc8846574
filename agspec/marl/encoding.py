"""Fixed-size numeric encodings for learning code (spec/12-adapters.md, A-OBS-VECTOR, A-STATE-VECTOR).

The benchmark's observation is the structured O-OBSERVATION record; a neural policy needs a vector.
:func:`encode_observation` is a pure function of that record and of public benchmark information
(grid size, reach, the instance's raw tokens), so a vector can never carry more than the robot is
allowed to see (C-INFORMATION).  :func:`encode_state` is the privileged global state for centralized
critics and mixers (A-STATE-VECTOR); it reads the interpreter's state and is never shown to actors.

Every feature lies in [0, 1].  String features are hashed with the original release's
``(acc·131 + ord(ch)) mod 1009`` fold, divided by 1008 (0 for a missing string).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from agspec.formats.actions import DIRECTION_NAMES, N_ACTIONS, OP_SLOTS, PICK_SLOTS
from agspec.interp.model import Model
from agspec.interp.state import State

# A-OBS-VECTOR block sizes: self, 8 neighbour slots, option counts, pick slots, operation slots.
SELF_DIM, NEIGHBOUR_DIM, COUNTS_DIM, PICK_DIM, OP_DIM = 12, 10, 2, 6, 20
OBS_DIM = SELF_DIM + 8 * NEIGHBOUR_DIM + COUNTS_DIM + PICK_SLOTS * PICK_DIM + OP_SLOTS * OP_DIM  # 1566
DIRECTION_INDEX = {name: d for d, name in enumerate(DIRECTION_NAMES)}
ROBOT_STATE_DIM, GLOBAL_STATE_DIM, PRODUCT_FIXED_DIM = 19, 6, 6

assert N_ACTIONS == 114


def str_hash(text: str | None) -> float:
    """The original release's string feature: a polynomial fold modulo 1009, scaled to [0, 1]."""
    if not text:
        return 0.0
    acc = 0
    for ch in text:
        acc = (acc * 131 + ord(ch)) % 1009
    return acc / 1008.0


def _frac(x: float, denominator: float) -> float:
    return min(max(x / denominator, 0.0), 1.0) if denominator > 0 else 0.0


def _saturate(x: float) -> float:
    """x / (1 + x) for x >= 0: an unbounded count squeezed into [0, 1)."""
    return x / (1.0 + x) if x > 0 else 0.0


@dataclass(frozen=True)
class PublicInfo:
    """Public benchmark information the encoding may use (O-OBSERVATION: recipes, profile, grid)."""

    rows: int
    cols: int
    reach: float
    raw_tokens: frozenset[str]

    @staticmethod
    def of(model: Model) -> "PublicInfo":
        raw = frozenset(tok for r in model.recipes.values() for tok in r.raw)
        return PublicInfo(model.rows, model.cols, float(model.profile["reach"]), raw)


def token_class(item: Mapping[str, Any] | None, pub: PublicInfo) -> int:
    """0 nothing held, 1 raw token, 2 intermediate, 3 terminal (final) token."""
    if item is None:
        return 0
    if item.get("final"):
        return 3
    return 1 if item["token"] in pub.raw_tokens else 2


def _item_features(out: np.ndarray, at: int, item: Mapping[str, Any] | None, pub: PublicInfo) -> None:
    out[at + token_class(item, pub)] = 1.0
    if item is not None:
        out[at + 4] = (int(item["product"]) % 256) / 255.0


def _cell(robot_id: str) -> tuple[int, int]:
    i, j = robot_id.split(",")
    return int(i), int(j)


def encode_observation(obs: Mapping[str, Any], pub: PublicInfo) -> np.ndarray:
    """A-OBS-VECTOR: the structured observation of one robot as OBS_DIM float32 values in [0, 1]."""
    out = np.zeros(OBS_DIM, dtype=np.float32)
    me = _cell(obs["robot"])
    span_r, span_c = max(pub.rows - 1, 1), max(pub.cols - 1, 1)
    # self block (12)
    _item_features(out, 0, obs["holding"], pub)
    out[5] = float(obs["busy"])
    out[6] = float(obs["failed"])
    out[7] = float(obs["supports"] is not None)
    out[8] = str_hash(obs["supports"])
    out[9] = _frac(me[0], span_r)
    out[10] = _frac(me[1], span_c)
    out[11] = _saturate(float(obs["t"]))
    # neighbour slots (8 x 10), in direction order
    base = SELF_DIM
    for nb in obs["neighbours"]:
        at = base + DIRECTION_INDEX[nb["dir"]] * NEIGHBOUR_DIM
        out[at] = 1.0
        _item_features(out, at + 1, nb["holding"], pub)
        out[at + 6] = float(nb["busy"])
        out[at + 7] = float(nb["failed"])
        out[at + 8] = str_hash(nb["op"])
        out[at + 9] = str_hash(nb["role"])
    # option counts (2)
    base += 8 * NEIGHBOUR_DIM
    picks, ops = obs["pick_options"], obs["operation_options"]
    out[base] = len(picks) / PICK_SLOTS
    out[base + 1] = len(ops) / OP_SLOTS
    # pick slots (32 x 6)
    base += COUNTS_DIM
    for k, p in enumerate(picks):
        at = base + k * PICK_DIM
        out[at] = 1.0
        out[at + 1] = str_hash(p["token"])
        out[at + 2] = _frac(p["shelf_row"], span_r)
        out[at + 3] = min(max(float(p["stock"]), 0.0), 1.0)
        out[at + 4] = (int(p["product"]) % 256) / 255.0
        out[at + 5] = str_hash(p["recipe"])
    # operation slots (64 x 20)
    base += PICK_SLOTS * PICK_DIM
    for k, o in enumerate(ops):
        at = base + k * OP_DIM
        out[at] = 1.0
        out[at + 1] = str_hash(o["operation"])
        out[at + 2] = str_hash(o["type"])
        out[at + 3] = _frac(o["kmin"], 4)
        out[at + 4] = _frac(o["size"], 4)
        out[at + 5] = str_hash(o["role"])
        out[at + 6] = _saturate(float(o["duration"]))
        out[at + 7] = _frac(float(o["min_reach_margin"]), pub.reach)
        out[at + 8] = min(max(float(o["support"]), 0.0), 1.0)
        out[at + 9] = (int(o["product"]) % 256) / 255.0
        out[at + 10] = str_hash(o["recipe"])
        out[at + 11] = float(o["id"] == obs["supports"])
        for m, member in enumerate(o["members"][:4]):  # offsets relative to the robot, 0.5 = same
            mi, mj = _cell(member)
            out[at + 12 + 2 * m] = 0.5 + (mi - me[0]) / (2 * span_r)
            out[at + 13 + 2 * m] = 0.5 + (mj - me[1]) / (2 * span_c)
    return out


def mask_vector(mask: list[bool]) -> np.ndarray:
    """O-MASK as PettingZoo's ``action_mask`` convention: int8, 1 = legal."""
    return np.asarray(mask, dtype=np.int8)


# --------------------------------------------------------------------------- privileged state


def _vocabulary(model: Model) -> tuple[list[str], list[str], list[str]]:
    """The instance's operation ids, tokens and raw tokens, sorted: the state vector's slots."""
    ops = sorted({op.id for r in model.recipes.values() for op in r.operations})
    tokens = sorted({tok for r in model.recipes.values() for tok in (*r.raw, *(op.output for op in r.operations))})
    raws = sorted({tok for r in model.recipes.values() for tok in r.raw})
    return ops, tokens, raws


def state_dim(model: Model) -> int:
    """A-STATE-VECTOR length: 19 per robot, one slot per WIP place, 6 global values, shelf stock."""
    ops, tokens, raws = _vocabulary(model)
    product = PRODUCT_FIXED_DIM + len(ops) + 3 * len(tokens)
    return ROBOT_STATE_DIM * model.rows * model.cols + model.wip_cap * product + GLOBAL_STATE_DIM + model.rows * len(raws)


def encode_state(state: State, model: Model) -> np.ndarray:
    """A-STATE-VECTOR: the privileged global state (for centralized critics, never for actors)."""
    ops, tokens, raws = _vocabulary(model)
    out = np.zeros(state_dim(model), dtype=np.float32)
    t = state.t
    span_r, span_c = max(model.rows - 1, 1), max(model.cols - 1, 1)
    spacing = float(model.profile["spacing"])
    at = 0
    for cell in model.cells:  # robots, row-major
        r = state.robots[cell]
        if r.holding is not None:
            recipe = model.recipes[state.products[r.holding[0]].recipe]
            cls = 3 if r.holding[1] == recipe.terminal else (1 if r.holding[1] in recipe.raw else 2)
            out[at + cls] = 1.0
            out[at + 4] = (r.holding[0] % 256) / 255.0
        else:
            out[at] = 1.0
        out[at + 5] = float(not r.free(t))
        out[at + 6] = _saturate(max(r.busy_until - t, 0))
        out[at + 7] = float(r.incoming is not None)
        out[at + 8] = float(r.supports is not None)
        out[at + 9] = str_hash(r.supports)
        out[at + 10] = str_hash(r.op_label)
        out[at + 11] = str_hash(r.role_label)
        out[at + 12] = _frac(cell[0], span_r)
        out[at + 13] = _frac(cell[1], span_c)
        ee = r.pose.ee
        out[at + 14] = _frac(float(ee[0]) / spacing + 1.0, model.cols + 1)
        out[at + 15] = _frac(float(ee[1]) / spacing + 1.0, model.rows + 1)
        out[at + 16] = float(t < r.switch_lock)
        out[at + 17] = float(r.activity is not None)
        out[at + 18] = _saturate(r.team_participations)
        at += ROBOT_STATE_DIM
    open_products = [p for p in state.products if not p.delivered][: model.wip_cap]
    product_dim = PRODUCT_FIXED_DIM + len(ops) + 3 * len(tokens)
    for slot in range(model.wip_cap):
        if slot < len(open_products):
            p = open_products[slot]
            recipe = model.recipes[p.recipe]
            out[at] = 1.0
            out[at + 1] = (p.pid % 256) / 255.0
            out[at + 2] = str_hash(p.recipe)
            out[at + 3] = _saturate(t - p.spawn_time)
            out[at + 4] = _frac(len(p.completed), len(recipe.operations))
            out[at + 5] = _frac(len(p.in_progress), len(recipe.operations))
            for k, op in enumerate(ops):
                out[at + 6 + k] = 1.0 if op in p.completed else (0.5 if op in p.in_progress else 0.0)
            for k, tok in enumerate(tokens):
                base = at + 6 + len(ops) + 3 * k
                out[base] = float(tok in p.raw_taken)
                holder = state.item_holder.get((p.pid, tok))
                if holder is not None:
                    out[base + 1] = 0.5 + 0.5 * _frac(holder[0], span_r)
                    out[base + 2] = 0.5 + 0.5 * _frac(holder[1], span_c)
        at += product_dim
    out[at] = _frac(t, model.horizon)
    out[at + 1] = _frac(state.wip, model.wip_cap)
    out[at + 2] = _saturate(state.released)
    out[at + 3] = _saturate(state.delivered)
    out[at + 4] = _saturate(len(state.proposals))
    out[at + 5] = _saturate(len(state.activities))
    at += GLOBAL_STATE_DIM
    for row in range(model.rows):
        for tok in raws:
            out[at] = _frac(state.shelves[row].get(tok, 0), model.shelf_capacity)
            at += 1
    return out
