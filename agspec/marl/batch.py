"""All agents' A-OBS-VECTOR and O-MASK at once, straight from the interpreter's decision snapshot.

:func:`agspec.marl.encoding.encode_observation` defines the vector from one structured observation
record; building 30-50 such records per step and encoding them one by one was most of the
PettingZoo env's step time.  :class:`BatchEncoder` produces the same bytes for every agent without
the records: the grid's neighbour slots are a precomputed index array, so the self and neighbour
blocks of all agents are one NumPy gather over a per-robot feature table built once per step; only
the option slots (usually few) are filled per agent, with the same slot functions as
``encode_observation`` (tests/test_pettingzoo_golden.py holds both to recorded digests).
It reads only what the robot's observation contains (C-INFORMATION).
"""

from __future__ import annotations

import numpy as np

from agspec.interp.model import Model
from agspec.interp.state import State
from agspec.marl.encoding import (
    COUNTS_DIM,
    NEIGHBOUR_DIM,
    OBS_DIM,
    OP_DIM,
    PICK_DIM,
    SELF_DIM,
    PublicInfo,
    _frac,
    _saturate,
    operation_features,
    pick_features,
    robot_features,
    str_hash,
)
from agspec.interp.observe import IDLE_ONLY, N_ACTIONS, NO_OPTIONS, OP_SLOTS, PICK_SLOTS

_PICKS_AT = SELF_DIM + 8 * NEIGHBOUR_DIM + COUNTS_DIM
_OPS_AT = _PICKS_AT + PICK_SLOTS * PICK_DIM
_ZERO_ROW = [0.0] * NEIGHBOUR_DIM
_MEMO_LIMIT = 4096  # entries per memo before it starts over (product ids grow over an episode)


class BatchEncoder:
    """A-OBS-VECTOR of every robot (row-major) for one instance; static geometry precomputed."""

    def __init__(self, model: Model, pub: PublicInfo):
        self.model, self.pub = model, pub
        self.cells = model.cells
        n = len(self.cells)
        index = {c: k for k, c in enumerate(self.cells)}
        # neighbour slot d of robot k reads row neighbours[k, d] of the feature table; row n is all zeros
        self.neighbours = np.full((n, 8), n, dtype=np.intp)
        for k, c in enumerate(self.cells):
            for d, _, nc in model.observation_slots[c]:  # G_obs neighbours (O-OBSERVATION)
                self.neighbours[k, d] = index[nc]
        span_r, span_c = pub.spans
        self.position = np.array([[_frac(i, span_r), _frac(j, span_c)] for i, j in self.cells], dtype=np.float64)
        # the slot functions are pure and their inputs rarely change between steps: remembered per input
        self._rows: dict[tuple, list[float]] = {}
        self._slots: dict[tuple, tuple[object, list[float]]] = {}
        # most O-MASK values are the model's shared templates: their bytes once, found by identity (the
        # templates live as long as the model)
        shared = [IDLE_ONLY, *(m for pair in model.direction_masks.values() for m in pair)]
        self._template_bytes = {id(m): (m, bytes(m)) for m in shared}

    def _robot_table(self, state: State) -> np.ndarray:
        """Per robot: the features its neighbours see of it (robot_features), plus a zero row."""
        model, t, memo = self.model, state.t, self._rows
        if len(memo) > _MEMO_LIMIT:
            memo.clear()
        rows = []
        for c in self.cells:
            robot = state.robots[c]
            item = robot.holding
            if item is None:
                cls, product = 0, None
            else:
                terminal = model.recipes[state.products[item[0]].recipe].terminal
                cls = 3 if item[1] == terminal else (1 if item[1] in self.pub.raw_tokens else 2)
                product = item[0]
            key = (cls, product, not robot.free(t), robot.op_label, robot.role_label)
            row = memo.get(key)
            if row is None:
                row = memo[key] = robot_features(cls, product, key[2], False, robot.op_label, robot.role_label)
            rows.append(row)
        rows.append(_ZERO_ROW)
        return np.array(rows, dtype=np.float64)

    def _operation_slot(self, cand, cell, frac: float, pending: bool) -> list[float]:
        """operation_features of one option slot, remembered per candidate object: candidates are immutable
        and the interpreter hands out the same object while its realization is unchanged.  The entry keeps
        the candidate alive, so its id is never reused while the entry exists."""
        key = (id(cand), cell, frac, pending)
        entry = self._slots.get(key)
        if entry is not None and entry[0] is cand:
            return entry[1]
        if len(self._slots) > _MEMO_LIMIT:
            self._slots.clear()
        row = operation_features(cand.op.id, cand.op.type, cand.op.kmin, cand.size,
                                 next(r for m, r in cand.roles if m == cell), cand.plan.duration,
                                 cand.plan.min_reach_margin, frac, cand.pid, cand.recipe, pending, cand.members,
                                 cell, self.pub)
        self._slots[key] = (cand, row)
        return row

    def _mask_bytes(self, mask) -> bytes:
        """bytes() of a tuple of bools is its 0/1 bytes."""
        entry = self._template_bytes.get(id(mask))
        return entry[1] if entry is not None and entry[0] is mask else bytes(mask)

    def encode(self, state: State, options, masks) -> tuple[np.ndarray, np.ndarray]:
        """(observations float32 [robots, OBS_DIM], action masks int8 [robots, N_ACTIONS]).

        ``options`` and ``masks`` are the decision snapshot's per-cell Options and O-MASK tuples.
        """
        n = len(self.cells)
        table = self._robot_table(state)
        out = np.zeros((n, OBS_DIM), dtype=np.float32)
        out[:, 0:7] = table[:n, 1:8]
        supports = [state.robots[c].supports for c in self.cells]
        out[:, 7] = [float(s is not None) for s in supports]
        out[:, 8] = [str_hash(s) for s in supports]
        out[:, 9:11] = self.position
        out[:, 11] = _saturate(float(state.t))
        out[:, SELF_DIM:SELF_DIM + 8 * NEIGHBOUR_DIM] = table[self.neighbours].reshape(n, 8 * NEIGHBOUR_DIM)
        counts = SELF_DIM + 8 * NEIGHBOUR_DIM
        span_r = self.pub.spans[0]
        for k, c in enumerate(self.cells):
            opts = options[c]
            if opts is NO_OPTIONS:  # most robots, most steps: counts and slots stay zero
                continue
            out[k, counts] = len(opts.picks) / PICK_SLOTS
            out[k, counts + 1] = len(opts.operations) / OP_SLOTS
            if opts.picks:
                out[k, _PICKS_AT:_PICKS_AT + PICK_DIM * len(opts.picks)] = [
                    v for p in opts.picks for v in pick_features(p, span_r)]
            if opts.operations:
                out[k, _OPS_AT:_OPS_AT + OP_DIM * len(opts.operations)] = [
                    v for cand, frac in zip(opts.operations, opts.supports)
                    for v in self._operation_slot(cand, c, frac, cand.cid == supports[k])]
        mask = np.frombuffer(bytearray(b"".join(self._mask_bytes(masks[c]) for c in self.cells)), dtype=np.int8)
        return out, mask.reshape(n, N_ACTIONS)
