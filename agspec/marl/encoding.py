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
from functools import lru_cache
from typing import Any, Iterable, Mapping

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


@lru_cache(maxsize=65536)  # pure; the same ids and labels are hashed for every agent of every step
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


def _unit(x: float) -> float:
    return min(max(float(x), 0.0), 1.0)


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

    @property
    def spans(self) -> tuple[int, int]:
        return max(self.rows - 1, 1), max(self.cols - 1, 1)


def token_class(item: Mapping[str, Any] | None, pub: PublicInfo) -> int:
    """0 nothing held, 1 raw token, 2 intermediate, 3 terminal (final) token."""
    if item is None:
        return 0
    if item.get("final"):
        return 3
    return 1 if item["token"] in pub.raw_tokens else 2


# The features of one robot, one pick slot and one operation slot.  Both encoders (the per-record
# encode_observation and the all-agents encoder of agspec.marl.batch) build their slots with these
# functions, so the two cannot drift apart.


def robot_features(item_class: int, product: int | None, busy: bool, failed: bool, op: str | None,
                   role: str | None) -> list[float]:
    """A neighbour slot (NEIGHBOUR_DIM): present, held-item class one-hot (4), product, busy, failed,
    hashed activity and role labels; its entries 1..6 are also the self block's first six values."""
    row = [1.0, 0.0, 0.0, 0.0, 0.0, (product % 256) / 255.0 if product is not None else 0.0,
           float(busy), float(failed), str_hash(op), str_hash(role)]
    row[1 + item_class] = 1.0
    return row


def pick_features(option: Mapping[str, Any], span_r: int) -> list[float]:
    """A pick slot (PICK_DIM)."""
    return [1.0, str_hash(option["token"]), _frac(option["shelf_row"], span_r), _unit(option["stock"]),
            (int(option["product"]) % 256) / 255.0, str_hash(option["recipe"])]


def operation_features(operation: str, op_type: str, kmin: int, size: int, role: str, duration: float,
                       margin: float, support: float, product: int, recipe: str, pending: bool,
                       members: Iterable[tuple[int, int]], me: tuple[int, int], pub: PublicInfo) -> list[float]:
    """An operation slot (OP_DIM); members are offsets relative to the robot, 0.5 = same row/column."""
    span_r, span_c = pub.spans
    row = [1.0, str_hash(operation), str_hash(op_type), _frac(kmin, 4), _frac(size, 4), str_hash(role),
           _saturate(float(duration)), _frac(float(margin), pub.reach), _unit(support), (int(product) % 256) / 255.0,
           str_hash(recipe), float(pending), 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    for m, (mi, mj) in enumerate(list(members)[:4]):
        row[12 + 2 * m] = 0.5 + (mi - me[0]) / (2 * span_r)
        row[13 + 2 * m] = 0.5 + (mj - me[1]) / (2 * span_c)
    return row


def _cell(robot_id: str) -> tuple[int, int]:
    i, j = robot_id.split(",")
    return int(i), int(j)


def _held_features(item: Mapping[str, Any] | None, pub: PublicInfo) -> tuple[int, int | None]:
    return token_class(item, pub), (int(item["product"]) if item is not None else None)


def encode_observation(obs: Mapping[str, Any], pub: PublicInfo) -> np.ndarray:
    """A-OBS-VECTOR: the structured observation of one robot as OBS_DIM float32 values in [0, 1]."""
    out = np.zeros(OBS_DIM, dtype=np.float32)
    me = _cell(obs["robot"])
    span_r, span_c = pub.spans
    # self block (12)
    own = robot_features(*_held_features(obs["holding"], pub), obs["busy"], obs["failed"], None, None)
    out[0:7] = own[1:8]
    out[7] = float(obs["supports"] is not None)
    out[8] = str_hash(obs["supports"])
    out[9] = _frac(me[0], span_r)
    out[10] = _frac(me[1], span_c)
    out[11] = _saturate(float(obs["t"]))
    # neighbour slots (8 x 10), in direction order
    base = SELF_DIM
    for nb in obs["neighbours"]:
        at = base + DIRECTION_INDEX[nb["dir"]] * NEIGHBOUR_DIM
        out[at:at + NEIGHBOUR_DIM] = robot_features(*_held_features(nb["holding"], pub), nb["busy"], nb["failed"],
                                                    nb["op"], nb["role"])
    # option counts (2)
    base += 8 * NEIGHBOUR_DIM
    picks, ops = obs["pick_options"], obs["operation_options"]
    out[base] = len(picks) / PICK_SLOTS
    out[base + 1] = len(ops) / OP_SLOTS
    # pick slots (32 x 6)
    base += COUNTS_DIM
    for k, p in enumerate(picks):
        out[base + k * PICK_DIM:base + (k + 1) * PICK_DIM] = pick_features(p, span_r)
    # operation slots (64 x 20)
    base += PICK_SLOTS * PICK_DIM
    for k, o in enumerate(ops):
        out[base + k * OP_DIM:base + (k + 1) * OP_DIM] = operation_features(
            o["operation"], o["type"], o["kmin"], o["size"], o["role"], o["duration"], o["min_reach_margin"],
            o["support"], o["product"], o["recipe"], o["id"] == obs["supports"], map(_cell, o["members"]), me, pub)
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


class StateEncoder:
    """A-STATE-VECTOR of one model's states, kept in one array between epochs.

    The layout depends on the model only; a robot's 19 values depend on its own fields and on t only
    through the ticks it has left and its switch lock, so a robot's row is rewritten only when those
    inputs change (most robots, most epochs, are at rest).  :func:`encode_state` is a fresh encoder's
    first epoch, so the two cannot disagree.
    """

    def __init__(self, model: Model):
        self.model = model
        self.ops, self.tokens, self.raws = _vocabulary(model)
        self.span_r, self.span_c = max(model.rows - 1, 1), max(model.cols - 1, 1)
        self.spacing = float(model.profile["spacing"])
        self.product_dim = PRODUCT_FIXED_DIM + len(self.ops) + 3 * len(self.tokens)
        self.products_at = ROBOT_STATE_DIM * len(model.cells)
        self.global_at = self.products_at + model.wip_cap * self.product_dim
        # a held token's place: 0.5 + half its row and column fractions (0 when nobody holds it)
        self.place = {c: (0.5 + 0.5 * _frac(c[0], self.span_r), 0.5 + 0.5 * _frac(c[1], self.span_c))
                      for c in model.cells}
        self.out = np.zeros(state_dim(model), dtype=np.float32)
        self._robot_keys: list[tuple | None] = [None] * len(model.cells)
        self._product_rows: list[list[float] | None] = [None] * model.wip_cap
        self._shelves: list[float] | None = None

    def reset(self) -> None:
        """A new episode: a product id may name another recipe, so no remembered row is trusted."""
        self._robot_keys = [None] * len(self._robot_keys)

    @staticmethod
    def robot_key(r: Any, t: int) -> tuple:
        """Everything a robot's 19 values read at epoch t (its cell is fixed; its held product's recipe is
        fixed for the episode): equal keys, equal rows."""
        left = r.busy_until - t
        return (r.holding, left if left > 0 else 0, r.incoming, r.supports, r.op_label, r.role_label, r.pose.ee,
                t < r.switch_lock, r.activity is not None, r.team_participations)

    def _robot_row(self, state: State, cell: tuple[int, int], r: Any, t: int) -> list[float]:
        model, spacing = self.model, self.spacing
        row = [0.0] * ROBOT_STATE_DIM
        if r.holding is not None:
            recipe = model.recipes[state.products[r.holding[0]].recipe]
            row[3 if r.holding[1] == recipe.terminal else (1 if r.holding[1] in recipe.raw else 2)] = 1.0
            row[4] = (r.holding[0] % 256) / 255.0
        else:
            row[0] = 1.0
        row[5] = float(not r.free(t))
        row[6] = _saturate(max(r.busy_until - t, 0))
        row[7] = float(r.incoming is not None)
        row[8] = float(r.supports is not None)
        row[9] = str_hash(r.supports)
        row[10] = str_hash(r.op_label)
        row[11] = str_hash(r.role_label)
        row[12] = _frac(cell[0], self.span_r)
        row[13] = _frac(cell[1], self.span_c)
        ee = r.pose.ee
        row[14] = _frac(float(ee[0]) / spacing + 1.0, model.cols + 1)
        row[15] = _frac(float(ee[1]) / spacing + 1.0, model.rows + 1)
        row[16] = float(t < r.switch_lock)
        row[17] = float(r.activity is not None)
        row[18] = _saturate(r.team_participations)
        return row

    def _product_row(self, state: State, p: Any, t: int) -> list[float]:
        recipe = self.model.recipes[p.recipe]
        n_ops = len(recipe.operations)
        row = [1.0, (p.pid % 256) / 255.0, str_hash(p.recipe), _saturate(t - p.spawn_time),
               _frac(len(p.completed), n_ops), _frac(len(p.in_progress), n_ops)]
        row += [1.0 if op in p.completed else (0.5 if op in p.in_progress else 0.0) for op in self.ops]
        holders, place, pid, taken = state.item_holder, self.place, p.pid, p.raw_taken
        for tok in self.tokens:
            holder = holders.get((pid, tok))
            row.append(float(tok in taken))
            row += (0.0, 0.0) if holder is None else place[holder]
        return row

    def encode(self, state: State) -> np.ndarray:
        """The A-STATE-VECTOR of ``state`` (a copy, the caller's to keep)."""
        model, out, t = self.model, self.out, state.t
        keys, robot_key = self._robot_keys, self.robot_key
        for k, cell in enumerate(model.cells):
            r = state.robots[cell]
            key = robot_key(r, t)
            if key != keys[k]:
                at = k * ROBOT_STATE_DIM
                out[at:at + ROBOT_STATE_DIM] = self._robot_row(state, cell, r, t)
                keys[k] = key
        open_products = [p for p in state.products if not p.delivered][: model.wip_cap]
        for slot in range(model.wip_cap):
            row = self._product_row(state, open_products[slot], t) if slot < len(open_products) else None
            if row != self._product_rows[slot]:
                at = self.products_at + slot * self.product_dim
                out[at:at + self.product_dim] = row if row is not None else 0.0
                self._product_rows[slot] = row
        at = self.global_at
        out[at:at + GLOBAL_STATE_DIM] = [
            _frac(t, model.horizon), _frac(state.wip, model.wip_cap), _saturate(state.released),
            _saturate(state.delivered), _saturate(len(state.proposals)), _saturate(len(state.activities))]
        shelves = [_frac(state.shelves[row].get(tok, 0), model.shelf_capacity)
                   for row in range(model.rows) for tok in self.raws]
        if shelves != self._shelves:
            out[at + GLOBAL_STATE_DIM:] = shelves
            self._shelves = shelves
        return out.copy()


def encode_state(state: State, model: Model) -> np.ndarray:
    """A-STATE-VECTOR: the privileged global state (for centralized critics, never for actors)."""
    return StateEncoder(model).encode(state)
