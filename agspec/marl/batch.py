"""All agents' A-OBS-VECTOR and O-MASK at once, from the interpreter's state and decision snapshot
straight into two preallocated arrays.

:func:`agspec.marl.encoding.encode_observation` defines the vector from one structured observation
record.  :class:`BatchEncoder` writes the same bytes for every agent without the records, into a
float32 ``[robots, OBS_DIM]`` and an int8 ``[robots, N_ACTIONS]`` array it keeps for the
environment's instance.  Between two epochs little of either changes, so each epoch rewrites only
what did:

* a robot's public features (held item, busy, activity and role labels: what its neighbours see,
  and the self block's first values) are one row of a per-robot table, rewritten when its inputs
  change; the neighbour blocks of all agents are then one gather through a precomputed index of
  each robot's G_obs neighbour slots;
* an agent's option counts and slots are rewritten when its options are a different object (the
  interpreter shares one empty ``Options`` among robots without options) or its pending support
  changed, with the same slot functions as ``encode_observation``;
* a mask row is rewritten when the O-MASK is a different object (busy robots and robots with only
  idle, receive and handoff slots share the model's templates).

:meth:`BatchEncoder.encode` hands out copies, so what a caller kept from an earlier epoch never
changes; the PettingZoo environment's per-agent dicts are row views of them.  It reads only what
the robot's observation contains (C-INFORMATION).  tests/test_pettingzoo_golden.py holds the arrays
to recorded digests and to ``encode_observation`` of every record, on generated scenarios too.
"""

from __future__ import annotations

from itertools import compress
from operator import is_not, ne

import numpy as np

from agspec.interp.model import Model
from agspec.interp.observe import IDLE_ONLY, N_ACTIONS, NO_OPTIONS, OP_SLOTS, PICK_SLOTS
from agspec.interp.state import State
from agspec.marl.encoding import COUNTS_DIM, NEIGHBOUR_DIM, OBS_DIM, OP_DIM, PICK_DIM, SELF_DIM, PublicInfo, _frac
from agspec.marl.encoding import _saturate, operation_features, pick_features, robot_features, str_hash

_COUNTS_AT = SELF_DIM + 8 * NEIGHBOUR_DIM
_PICKS_AT = _COUNTS_AT + COUNTS_DIM
_OPS_AT = _PICKS_AT + PICK_SLOTS * PICK_DIM
_MEMO_LIMIT = 4096  # entries per memo before it starts over (product ids grow over an episode)


class BatchEncoder:
    """A-OBS-VECTOR and O-MASK of every robot (row-major) for one instance, in preallocated arrays."""

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
        self.position = np.array([[_frac(i, span_r), _frac(j, span_c)] for i, j in self.cells], dtype=np.float32)
        self.obs = np.zeros((n, OBS_DIM), dtype=np.float32)  # the arrays each epoch is written into
        self.mask = np.zeros((n, N_ACTIONS), dtype=np.int8)
        self._table = np.zeros((n + 1, NEIGHBOUR_DIM), dtype=np.float32)
        self._flat_neighbours = self.neighbours.ravel()
        self._gathered = np.zeros((n * 8, NEIGHBOUR_DIM), dtype=np.float32)
        # the pure slot functions' rows, remembered per input (their inputs rarely change between steps)
        self._rows: dict[tuple, list[float]] = {}
        self._slots: dict[tuple, tuple[object, list[float]]] = {}
        # the model's shared O-MASK templates as int8 rows, found by identity (they live as long as the model)
        shared = [IDLE_ONLY, *(m for pair in model.direction_masks.values() for m in pair)]
        self._template_rows = {id(m): (m, np.frombuffer(bytes(m), dtype=np.int8)) for m in shared}
        self.reset()

    def reset(self) -> None:
        """Forget what the arrays hold: the next :meth:`encode` writes every part (a new episode)."""
        self.obs[:] = 0.0
        self.obs[:, 9:11] = self.position
        self.mask[:] = 0
        self._table[:] = 0.0
        self._rows.clear()  # a row's key names a product by id; ids start over with the episode
        n = len(self.cells)
        self._keys: list[tuple | None] = [None] * n
        self.supports: list[str | None] = [None] * n  # each robot's pending support (R-SUPPORT) at the last update
        self._options: list[object] = [None] * n
        self._used: list[tuple[int, int]] = [(0, 0)] * n  # option slots written per agent (picks, operations)
        self._masks: list[object] = [None] * n
        self._t: int | None = None
        self._state: State | None = None
        self._robots: list = []

    # ------------------------------------------------------------------ parts

    def _row(self, state: State, key: tuple) -> list[float]:
        """robot_features of a robot whose (held item, busy, activity label, role label) is ``key``."""
        row = self._rows.get(key)
        if row is None:
            if len(self._rows) > _MEMO_LIMIT:
                self._rows.clear()
            item, busy, op, role = key
            if item is None:
                cls, product = 0, None
            else:
                terminal = self.model.recipes[state.products[item[0]].recipe].terminal
                cls = 3 if item[1] == terminal else (1 if item[1] in self.pub.raw_tokens else 2)
                product = item[0]
            row = self._rows[key] = robot_features(cls, product, busy, False, op, role)
        return row

    def _operation_slot(self, cand, cell, frac: float, pending: bool) -> np.ndarray:
        """operation_features of one option slot as a float32 row, remembered per candidate object:
        candidates are immutable and the interpreter hands out the same object while its realization is
        unchanged.  The entry keeps the candidate alive, so its id is never reused while the entry exists."""
        key = (id(cand), cell, frac, pending)
        entry = self._slots.get(key)
        if entry is not None and entry[0] is cand:
            return entry[1]
        if len(self._slots) > _MEMO_LIMIT:
            self._slots.clear()
        row = np.array(operation_features(cand.op.id, cand.op.type, cand.op.kmin, cand.size,
                                          next(r for m, r in cand.roles if m == cell), cand.plan.duration,
                                          cand.plan.min_reach_margin, frac, cand.pid, cand.recipe, pending,
                                          cand.members, cell, self.pub), dtype=np.float32)
        self._slots[key] = (cand, row)
        return row

    def _write_options(self, k: int, opts, supports: str | None) -> None:
        """Agent k's option counts, pick slots and operation slots (zero past its options)."""
        out = self.obs[k]
        picks, ops = self._used[k]
        if picks:
            out[_PICKS_AT:_PICKS_AT + PICK_DIM * picks] = 0.0
        if ops:
            out[_OPS_AT:_OPS_AT + OP_DIM * ops] = 0.0
        self._used[k] = (len(opts.picks), len(opts.operations))
        out[_COUNTS_AT] = len(opts.picks) / PICK_SLOTS
        out[_COUNTS_AT + 1] = len(opts.operations) / OP_SLOTS
        if opts.picks:
            span_r = self.pub.spans[0]
            out[_PICKS_AT:_PICKS_AT + PICK_DIM * len(opts.picks)] = [
                v for p in opts.picks for v in pick_features(p, span_r)]
        if opts.operations:
            cell, at = self.cells[k], _OPS_AT
            for cand, frac in zip(opts.operations, opts.supports):
                out[at:at + OP_DIM] = self._operation_slot(cand, cell, frac, cand.cid == supports)
                at += OP_DIM

    def _mask_row(self, mask) -> np.ndarray | bytes:
        entry = self._template_rows.get(id(mask))
        if entry is not None and entry[0] is mask:
            return entry[1]
        return np.frombuffer(bytes(mask), dtype=np.int8)  # bytes() of a tuple of bools is its 0/1 bytes

    # ------------------------------------------------------------------ one epoch

    def update(self, state: State, options, masks) -> None:
        """Bring :attr:`obs` and :attr:`mask` to this epoch: ``options`` and ``masks`` are the decision
        snapshot's per-cell Options and O-MASK tuples."""
        t, cells, n = state.t, self.cells, len(self.cells)
        if state is not self._state:  # robots are mutated in place for the life of a state
            self._state, self._robots = state, [state.robots[c] for c in cells]
        robots = self._robots
        # public features: (held item, busy = not free (R-EXECUTION), activity label, role label)
        keys = [(r.holding, r.busy_until > t or r.incoming is not None, r.op_label, r.role_label) for r in robots]
        if keys != self._keys:
            table = self._table
            for k in compress(range(n), map(ne, keys, self._keys)):
                table[k] = self._row(state, keys[k])
            self._keys = keys
            self.obs[:, 0:7] = table[:n, 1:8]
            table.take(self._flat_neighbours, axis=0, out=self._gathered)  # every observer's 8 neighbour rows
            self.obs[:, SELF_DIM:_COUNTS_AT] = self._gathered.reshape(n, 8 * NEIGHBOUR_DIM)
        opts = list(options.values())  # the snapshot's dicts hold every cell in row-major order
        rewrite = set(compress(range(n), map(is_not, opts, self._options)))
        supports = [r.supports for r in robots]
        if supports != self.supports:
            for k in [k for k, s, last in zip(range(n), supports, self.supports) if s != last]:
                self.obs[k, 7] = float(supports[k] is not None)
                self.obs[k, 8] = str_hash(supports[k])
                if opts[k] is not NO_OPTIONS:  # the "is own pending support" flag of its operation slots
                    rewrite.add(k)
            self.supports = supports
        for k in rewrite:
            self._write_options(k, opts[k], supports[k])
        self._options = opts  # kept alive, so an identity seen here is never another object's
        if t != self._t:
            self.obs[:, 11] = _saturate(float(t))
            self._t = t
        ms = list(masks.values())
        for k in compress(range(n), map(is_not, ms, self._masks)):
            self.mask[k] = self._mask_row(ms[k])
        self._masks = ms

    def encode(self, state: State, options, masks) -> tuple[np.ndarray, np.ndarray]:
        """(observations float32 [robots, OBS_DIM], action masks int8 [robots, N_ACTIONS]) of this epoch:
        copies of the working arrays, the caller's to keep."""
        self.update(state, options, masks)
        return self.obs.copy(), self.mask.copy()
