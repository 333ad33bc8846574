"""The simulator: ``reset`` and ``step`` executing the rules in R-TICK-ORDER.

``Simulator.step`` runs the fifteen steps of R-TICK-ORDER (spec/05-transition.md) in order; each
step is marked ``# step N: IDs`` with the spec IDs it implements, exactly the IDs the spec's list
names for that step (tests/test_spec_guard.py parses both and compares them).  Step 1's candidate
set, option lists and masks are built when s_t is entered (``_enter_epoch``, at the end of the
previous step or at reset); its capacity and ready/feasible samples are taken at the top of ``step``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from itertools import compress
from typing import Any, Mapping, Sequence

from agspec.interp import geometry, rules
from agspec.interp.candidates import Candidate, build_candidates, inputs_present, logically_ready_occurrences
from agspec.interp.candidates import surviving_candidates
from agspec.interp.metrics import Compatibility, MetricsAccumulator, capacity_snapshot, compatibility
from agspec.interp.model import Model, OperationSpec
from agspec.interp.observe import ACTION_KINDS, IDLE, N_ACTIONS, Mask, Options, action_masks, build_options
from agspec.interp.observe import epoch_views, observation
from agspec.interp.state import Cell, Product, Robot, State, cell_id


@dataclass
class Decision:
    """The pre-action snapshot of one decision epoch (R-TICK-ORDER step 1)."""

    candidates: list[Candidate]
    by_id: dict[str, Candidate]
    options: dict[Cell, Options]  # every cell, row-major (the all-agents encoder reads the values in order)
    masks: dict[Cell, Mask]  # every cell, row-major
    rejected: int
    compatibility: Compatibility | None = None  # M-CAPACITY's weight-free part, once it is needed
    ready: list[tuple[Product, OperationSpec]] | None = None  # R-READY's logically ready occurrences, once needed


@dataclass
class StepResult:
    t: int  # the epoch the actions were applied at
    events: list[dict[str, Any]] = field(default_factory=list)
    applied: dict[str, int] = field(default_factory=dict)  # robot id -> action actually applied
    terminated: bool = False
    truncated: bool = False


def initial_state(model: Model) -> State:
    """S-INSTANCE: robots at rest, shelves stocked and access as recorded in the realization."""
    spacing = float(model.profile["spacing"])
    real = model.instance["realization"]
    shelves = [dict() for _ in range(model.rows)]
    for entry in real["shelves"]:
        shelves[int(entry["row"])] = {tok: int(n) for tok, n in entry["stock"].items()}
    access = {int(e["shelf_row"]): tuple(int(r) for r in e["robot_rows"]) for e in real["shelf_access"]}
    # keyed in row-major order (R-IDS): the snapshot functions read the robots in that order
    robots = {c: Robot(cell=c, pose=geometry.rest_pose(c, spacing)) for c in model.cells}
    return State(t=0, rows=model.rows, cols=model.cols, robots=robots, shelves=shelves, shelf_access=access)


class Simulator:
    """The reference interpreter of AssemblyGrid v1 for one instance.

    Deterministic: the same instance, execution seed and joint actions give the same states
    (D-DETERMINISM).  In v1 no rule draws from the execution stream, so the seed is recorded only.
    """

    def __init__(self, instance: Mapping[str, Any], *, capacity: bool = True):
        self.model = Model.from_instance(dict(instance))
        # A-PZ-CAPACITY: step 1's M-CAPACITY and M-RF-BR samples are taken for the consumers of the
        # chapter 7 measures (evaluation, traces, conformance); an adapter may leave them out
        self.capacity = capacity
        self.state: State
        self.decision: Decision
        self.metrics: MetricsAccumulator
        self.execution_seed: int | None = None
        self.reset()

    # ------------------------------------------------------------------ reset / observe

    def reset(self, execution_seed: int | None = None) -> None:
        seeds = self.model.instance.get("seeds", {})
        self.execution_seed = execution_seed if execution_seed is not None else seeds.get("execution")
        self.state = initial_state(self.model)
        self.metrics = MetricsAccumulator(self.model, capacity=self.capacity)
        self.reset_events: list[dict[str, Any]] = []
        rules.release_product(self.state, self.model, self.reset_events, forced=True)  # R-RELEASE at t = 0
        self._enter_epoch()

    def _enter_epoch(self, candidates_unchanged: bool = False, only_commitments: bool = False,
                     ready_unchanged: bool = False) -> None:
        """R-TICK-ORDER step 1 of the epoch being entered: the decision snapshot of its state.

        ``candidates_unchanged``: the transition into this epoch started, completed and released
        nothing, so every input of R-CANDIDATES (logical readiness, the holders of items, which robots
        are free and hold nothing, their poses) is the previous epoch's, and so are its candidates.
        ``only_commitments``: it started picks, handoffs or deliveries but completed, released and
        admitted nothing, so the candidates are the previous ones whose members are all still free
        (:func:`~agspec.interp.candidates.surviving_candidates`), when the previous epoch rejected no
        realization as motion-infeasible (those would have to be counted again).
        ``ready_unchanged``: it admitted, released and completed no operation or delivery (picks and
        handoffs move material only), so R-READY's logically ready occurrences are the previous ones.
        Option lists and masks equal to the previous epoch's are handed out as the previous objects,
        so that consumers which test identity (the all-agents encoder) skip them.
        """
        state, model = self.state, self.model
        last = getattr(self, "decision", None)
        ready = last.ready if ready_unchanged and last is not None else None
        if candidates_unchanged:
            candidates, by_id, rejected = last.candidates, last.by_id, last.rejected
        else:
            if only_commitments and last.rejected == 0:
                candidates, rejected = surviving_candidates(state, last.candidates), 0
            else:
                if ready is None:
                    ready = logically_ready_occurrences(state, model)
                candidates, rejected = build_candidates(state, model, ready)
            by_id = {c.cid: c for c in candidates}
        options = build_options(state, model, candidates, last.options if last is not None else None)
        masks = action_masks(state, model, options, last.masks if last is not None else None)
        self.decision = Decision(candidates, by_id, options, masks, rejected, ready=ready)
        rules.bump(state, "reject_motion_infeasible", rejected)

    def compatibility(self) -> Compatibility:
        """M-CAPACITY's weight-free part for the decision epoch (the capacity sample of step 1 and the
        centralized reference both need it; computed once per epoch)."""
        d = self.decision
        if d.compatibility is None:
            d.compatibility = compatibility(self.state, self.model, d.candidates)
        return d.compatibility

    @property
    def t(self) -> int:
        return self.state.t

    def agents(self) -> list[str]:
        return list(self.model.cell_ids)

    def observe(self, robot: str | None = None) -> dict[str, dict[str, Any]] | dict[str, Any]:
        """O-OBSERVATION for one robot, or for all robots keyed by robot id."""
        d = self.decision
        if robot is not None:
            cell = tuple(int(x) for x in robot.split(","))
            return observation(self.state, self.model, cell, d.options[cell], d.masks[cell])
        views = epoch_views(self.state, self.model, d.candidates)
        return {cell_id(c): observation(self.state, self.model, c, d.options[c], d.masks[c], views)
                for c in self.model.cells}

    def masks(self) -> dict[str, list[bool]]:
        return {cell_id(c): list(m) for c, m in self.decision.masks.items()}

    @property
    def done(self) -> bool:
        return self.terminated or self.truncated

    @property
    def terminated(self) -> bool:
        m, s = self.model, self.state
        return m.mode == "batch" and s.released >= (m.batch_size or 0) and s.delivered >= (m.batch_size or 0)

    @property
    def truncated(self) -> bool:
        return self.state.t >= self.model.horizon and not self.terminated

    # ------------------------------------------------------------------ step

    def step(self, joint_action: Mapping[str, int] | Sequence[int]) -> StepResult:
        """Apply one joint action (robot id -> action int, or a list in row-major order)."""
        state, model, d = self.state, self.model, self.decision
        cells, n = model.cells, len(model.cells)
        if type(joint_action) is list and len(joint_action) == n and set(map(type, joint_action)) == {int}:
            actions = joint_action  # already one plain int per robot, row-major (read, never changed)
        elif isinstance(joint_action, Mapping):
            actions = [int(joint_action.get(r, IDLE)) for r in model.cell_ids]
        else:
            actions = [int(a) for _, a in zip(cells, joint_action)]
            if len(actions) < n:
                raise KeyError(cells[len(actions)])  # one action per robot, row-major
        result = StepResult(t=state.t)
        events = result.events
        # what R-CANDIDATES reads changes only with these (and completions)
        seq, released, teams = state.next_seq, state.released, state.next_team

        # step 1: R-READY, R-CANDIDATES, R-ROLE-ASSIGNMENT, M-CAPACITY, M-RF-BR (snapshot: _enter_epoch)
        if self.capacity:  # A-PZ-CAPACITY: only where the measures are asked for
            self._sample_capacity()

        # step 2: R-ACTION-VALIDATION, R-IDLE (an idle or coerced action decodes to no activity)
        # the decoded actions of the robots that start something, by kind
        picks: list[tuple[Cell, dict[str, Any]]] = []
        sends: dict[Cell, int] = {}
        receives: dict[Cell, int] = {}
        supports: dict[Cell, Candidate] = {}
        deliverers: list[Cell] = []
        masks, options = list(d.masks.values()), d.options  # masks: row-major, as the actions
        result.applied = applied = dict(zip(model.cell_ids, actions))  # idle is always legal (INV-MASKING)
        for k in compress(range(n), actions):  # the robots that did not idle, row-major
            a = actions[k]
            if not (0 <= a < N_ACTIONS) or not masks[k][a]:
                rules.bump(state, "invalid_attempts")
                rules.bump(state, "reject_locally_invalid")
                rules.bump(state, "unmasked_invalid_attempts")  # a != IDLE here
                events.append({"type": "action_coerced", "robot": model.cell_ids[k], "action": a})
                applied[model.cell_ids[k]] = IDLE
                continue
            # O-ACTION-ENCODING: the action's kind and slot or direction, from the decoding table
            c, (kind, slot) = cells[k], ACTION_KINDS[a]
            if kind == "receive":
                receives[c] = slot
            elif kind == "handoff":
                sends[c] = slot
            elif kind == "support":
                supports[c] = options[c].operations[slot]  # slots name the robot's options
            elif kind == "pick":
                picks.append((c, options[c].picks[slot]))
            else:  # deliver
                deliverers.append(c)

        progress = 0  # R-NO-PROGRESS: admissions and completions of this tick
        # step 3: R-PICK
        rules.start_picks(state, model, picks, events)
        # step 4: R-HANDOFF
        rules.start_handoffs(state, model, sends, receives, events)
        # step 5: R-SUPPORT, R-SUPPORT-LIFECYCLE, R-SWITCH-LOCK, R-ADMISSION, R-JOINT-ADMISSIBLE, R-BLOCKING,
        # R-XOR-CLOSURE, R-EXPIRY
        rules.record_supports(state, model, supports, events)
        progress += rules.admit_candidates(state, model, d.by_id, events)
        rules.expire_invalid_proposals(state, set(d.by_id), events)
        # step 6: R-DELIVERY
        rules.start_deliveries(state, model, deliverers, events)
        # step 7: M-SAMPLING
        self.metrics.sample(state)
        # step 8: R-CLOCK
        state.t += 1
        # step 9: R-COMPLETION
        material_only = all(a.kind in ("pick", "handoff") for a in state.activities if a.end <= state.t)
        completed = rules.complete_activities(state, model, events)
        progress += completed
        # step 10: R-REPLENISH
        rules.replenish_shelves(state, model, events)
        # step 11: (no disturbances in v1)
        # step 12: R-RELEASE
        rules.release_product(state, model, events)
        # step 13: R-EXPIRY
        rules.expire_proposals(state, events)
        rules.drop_finished_reservations(state)
        # step 14: M-MEAN-WIP, R-NO-PROGRESS
        self.metrics.post_advance(state, progress)
        # step 15: R-TERMINATION
        result.terminated, result.truncated = self.terminated, self.truncated
        # step 1 of the next epoch; a robot becomes free only when its activity completes (R-EXECUTION)
        kept = state.released == released and state.next_team == teams  # R-RELEASE; R-ADMISSION: next_team
        quiet = kept and not completed
        self._enter_epoch(candidates_unchanged=quiet and state.next_seq == seq, only_commitments=quiet,
                          ready_unchanged=kept and material_only)
        return result

    def _sample_capacity(self) -> None:
        """R-TICK-ORDER step 1's M-CAPACITY and M-RF-BR samples of the decision epoch."""
        state, model, d = self.state, self.model, self.decision
        capacity = capacity_snapshot(state, model, d.candidates, self.compatibility())
        if d.ready is None:
            d.ready = logically_ready_occurrences(state, model)
        ready = d.ready  # M-RF-BR: R_t (paper: logical readiness)
        with_material = [(p, op) for p, op in ready if inputs_present(state, p, op)]  # DIV-BR-READY-SET
        feasible = {c.group for c in capacity.compatible}  # F_t: >= 1 candidate compatible with commitments
        n_feasible = sum(1 for p, op in ready if (p.pid, op.id) in feasible)
        self.metrics.pre_action(capacity, len(ready), len(with_material), n_feasible)

    def final_metrics(self) -> dict[str, Any]:
        return self.metrics.final(self.state)
