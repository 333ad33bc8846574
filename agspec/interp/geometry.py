"""Abstract task-space geometry and motion (spec chapter "Geometry", rules G-*).

The paper ("Abstract geometric feasibility", "Task selection and geometric execution") fixes the
shape of the model: robots have a base point and a reach radius, an activity is a set of member
motion segments plus a common target point, its realized duration is approach + process + retreat,
and two activities conflict when their segments or targets come closer than rho_conf plus the
largest member clearance.  The numbers the paper leaves open (target points, role offsets, the
joint-space proxy that produces the paper's "4 + 3 + 1") are the original release's, adopted as
marked resolutions.  Every function is pure; points are ``(x, y)`` float pairs with x = column and
y = row (G-BASE); cells are ``(row, col)`` int pairs.

Float operations follow the original release on purpose (norms via ``math.hypot``, ``math.atan2``
without angle normalisation, ``math.ceil`` without epsilon): tick counts are ceilings of floats,
so "simplifying" an expression can change a duration.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from operator import sub
from typing import Any, Iterable, Mapping, Sequence

from agspec.ir import variants

Cell = tuple[int, int]  # (row, col), row-major order = tuple order (R-IDS)
Point = tuple[float, float]  # (x, y) = (column direction, row direction) in task-space units
Segment = tuple[Point, Point]
JointVector = tuple[float, float, float, float, float, float]

REACH_TOLERANCE = 1e-9  # G-REACH: ||x - b|| <= reach + 1e-9
DIRECTION_EPSILON = 1e-12  # G-ROLE-TARGET / G-MOTION: "zero vector" threshold
CONFLICT_TOLERANCE = 1e-12  # G-CONFLICT: distance < c - 1e-12
SEGMENT_TOLERANCE = 1e-12  # G-SEGMENT-DISTANCE: orientation / bounding-box tolerance
JOINT_LIMIT = math.pi  # G-MOTION: joint proxy components are clipped to [-pi, pi]
ZERO_JOINTS: JointVector = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


# --------------------------------------------------------------------------------------------
# Points (G-BASE, G-SHELF-POINT, G-OUTPUT-POINT, G-HANDOFF-POINT, G-SITE, G-ROLE-TARGET)
# --------------------------------------------------------------------------------------------


def base(cell: Cell, spacing: float) -> Point:
    """G-BASE: the base point of the robot at (row i, column j) is (j*s, i*s)."""
    row, col = cell
    return (col * spacing, row * spacing)


def distance(a: Point, b: Point) -> float:
    """Euclidean distance ||a - b||_2 (``math.hypot``, as the original release)."""
    return math.hypot(a[0] - b[0], a[1] - b[1])


def reachable(cell: Cell, point: Point, reach: float, spacing: float) -> bool:
    """G-REACH: robot at ``cell`` can serve ``point`` iff ||point - base|| <= reach + 1e-9."""
    return distance(point, base(cell, spacing)) <= reach + REACH_TOLERANCE


def shelf_point(row: int, spacing: float) -> Point:
    """G-SHELF-POINT: the pick target of shelf row r is (-0.5*s, r*s), half a cell left of column 0."""
    return (-0.5 * spacing, row * spacing)


def output_point(row: int, cols: int, spacing: float) -> Point:
    """G-OUTPUT-POINT: the delivery target of row i is (N*s, i*s), one cell right of the last column."""
    return (cols * spacing, row * spacing)


def handoff_point(a: Cell, b: Cell, spacing: float) -> Point:
    """G-HANDOFF-POINT: a handoff happens at the midpoint of the two bases (no role offset)."""
    (ax, ay), (bx, by) = base(a, spacing), base(b, spacing)
    return ((ax + bx) / 2.0, (ay + by) / 2.0)


def centroid(points: Sequence[Point]) -> Point:
    """Arithmetic mean of ``points``, summed in the given order."""
    if not points:
        raise ValueError("centroid of no points")
    n = len(points)
    return (sum(p[0] for p in points) / n, sum(p[1] for p in points) / n)


def operation_site(
    holder_cells: Iterable[Cell], all_member_cells: Iterable[Cell], spacing: float
) -> Point:
    """G-SITE: the operation site ("common target") of an operation candidate.

    It is the centroid of the bases of the *input holders*, taken in row-major order; helpers do
    not move it.  An operation without input holders uses the centroid of all members.  A
    single-holder operation therefore sits on the holder's own base.
    """
    cells = sorted(set(holder_cells)) or sorted(set(all_member_cells))
    return centroid([base(c, spacing) for c in cells])


def role_targets(
    site: Point,
    members_with_roles: Iterable[tuple[Cell, str]],
    offset: float,
    spacing: float,
) -> dict[Cell, Point]:
    """G-ROLE-TARGET: per-member targets of an operation candidate around its site.

    * With at most one member, or ``offset <= 0``, every member targets the site itself.
    * Otherwise members are ordered by (role name, cell).  A member whose base differs from the
      site (norm > 1e-12) targets ``site + offset * unit(base - site)`` — it approaches from its
      own side.  A member whose base coincides with the site targets
      ``site + offset * (cos phi, sin phi)``, phi = -pi/2 + 2*pi*k/n, where k is the member's
      index in the (role, cell) order and n the coalition size.
    """
    ordered = sorted(members_with_roles, key=lambda mr: (mr[1], mr[0]))
    n = len(ordered)
    if n <= 1 or offset <= 0:
        return {cell: site for cell, _ in ordered}
    targets: dict[Cell, Point] = {}
    for k, (cell, _role) in enumerate(ordered):
        bx, by = base(cell, spacing)
        dx, dy = bx - site[0], by - site[1]
        norm = math.hypot(dx, dy)
        if norm > DIRECTION_EPSILON:
            ux, uy = dx / norm, dy / norm
        else:
            phi = -math.pi / 2 + 2 * math.pi * k / n
            ux, uy = math.cos(phi), math.sin(phi)
        targets[cell] = (site[0] + offset * ux, site[1] + offset * uy)
    return targets


# --------------------------------------------------------------------------------------------
# Poses and motion plans (G-MOTION, G-DURATION, G-END-EFFECTOR)
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class RobotPose:
    """G-END-EFFECTOR: a robot's end-effector point and 6-component joint proxy."""

    ee: Point
    q: JointVector = ZERO_JOINTS

    def __hash__(self) -> int:
        # poses are keys of the plan and realization memos, hashed many times per epoch: hashed once
        h = self.__dict__.get("_hash")
        if h is None:
            h = hash((self.ee, self.q))
            object.__setattr__(self, "_hash", h)
        return h


def rest_pose(cell: Cell, spacing: float) -> RobotPose:
    """G-END-EFFECTOR: the initial pose — end effector on the base, joint proxy all zeros."""
    return RobotPose(ee=base(cell, spacing), q=ZERO_JOINTS)


def _clip(value: float, lo: float = -JOINT_LIMIT, hi: float = JOINT_LIMIT) -> float:
    return max(lo, min(hi, value))


def joint_target(cell: Cell, target: Point, reach: float, spacing: float) -> JointVector:
    """G-MOTION step 3: the joint proxy of a robot whose end effector is at ``target``.

    With (dx, dy) = target - base: theta = atan2(dy, dx) if |dx| + |dy| > 1e-12 else 0, clipped to
    [-pi, pi] (never normalised, so +pi and -pi are far apart); rho = ||target - base||;
    q = (theta, clip(rho/reach * pi/2), -0.35*theta, 0.25*theta, 0, 0).
    The second component uses the same [-pi, pi] clip (it is at most ~pi/2 for a reachable target).
    """
    bx, by = base(cell, spacing)
    dx, dy = target[0] - bx, target[1] - by
    theta = math.atan2(dy, dx) if abs(dx) + abs(dy) > DIRECTION_EPSILON else 0.0
    theta = _clip(theta)
    rho = math.hypot(dx, dy)
    return (theta, _clip((rho / reach) * (math.pi / 2)), -0.35 * theta, 0.25 * theta, 0.0, 0.0)


def target_pose(cell: Cell, target: Point, reach: float, spacing: float) -> tuple[float, RobotPose]:
    """G-REACH and G-MOTION step 3 for one member: the distance rho from its base to ``target`` and
    the pose it ends in (G-END-EFFECTOR: the effector on the target, the joint proxy of
    :func:`joint_target`).  A pure function of the cell and the target, whatever the current pose."""
    target = (float(target[0]), float(target[1]))
    return distance(target, base(cell, spacing)), RobotPose(ee=target, q=joint_target(cell, target, reach, spacing))


def cartesian_ticks(ee: Point, target: Point, speed: float) -> int:
    """G-MOTION step 2: ceil(||target - ee|| / speed)."""
    return math.ceil(distance(target, ee) / speed)


def joint_ticks(q_current: Sequence[float], q_target: Sequence[float], joint_speed: float) -> int:
    """G-MOTION step 3: ceil(max_k |q_target[k] - q_current[k]| / joint_speed)."""
    return math.ceil(max(map(abs, map(sub, q_target, q_current))) / joint_speed)


@dataclass(frozen=True)
class Plan:
    """G-MOTION / G-DURATION: the abstract motion plan of one activity.

    ``members``, ``segments``, ``target_poses`` and ``member_travel`` are parallel tuples in the
    caller's member order.  ``segments[k]`` is member k's straight approach segment from its
    current end effector to its target; ``target_poses[k]`` is its pose once the activity
    completes (G-END-EFFECTOR: end effectors stay at their target).  ``common_target`` is the
    activity's target point x(e) used by G-CONFLICT (operation site, shelf, output or handoff
    point — never a per-role target).
    """

    members: tuple[Cell, ...]
    approach: int
    process: int
    retreat: int
    duration: int
    segments: tuple[Segment, ...]
    target_poses: tuple[RobotPose, ...]
    member_travel: tuple[int, ...]
    common_target: Point
    min_reach_margin: float
    path_length: float

    @property
    def geometry_delay(self) -> int:
        """Approach + retreat ticks (the metric geometry_delay_ticks sums these)."""
        return self.approach + self.retreat

    @property
    def segment_bounds(self) -> tuple[float, float, float, float]:
        """(min x, min y, max x, max y) over all member segments: a cheap lower bound on segment
        distances that lets :func:`plans_conflict` skip far-apart plans (it never decides a near case).

        Computed once per plan and kept in the instance dict, like RobotPose's hash (a cached_property
        takes a lock on every first computation, and most plans are tested only a few times)."""
        bounds = self.__dict__.get("_segment_bounds")
        if bounds is None:
            xs = [p[0] for seg in self.segments for p in seg]
            ys = [p[1] for seg in self.segments for p in seg]
            bounds = (min(xs), min(ys), max(xs), max(ys))
            object.__setattr__(self, "_segment_bounds", bounds)
        return bounds

    def final_poses(self) -> dict[Cell, RobotPose]:
        """G-END-EFFECTOR: each member's pose after completion (no return to base)."""
        return dict(zip(self.members, self.target_poses))


def plan_activity(
    members: Sequence[tuple[Cell, RobotPose, Point]],
    process: int,
    profile: Mapping[str, Any],
    *,
    common_target: Point | None = None,
    targets: dict[tuple[Cell, Point], tuple[float, RobotPose]] | None = None,
) -> Plan | None:
    """G-MOTION, G-DURATION: plan an activity; ``None`` means MotionInfeasible.

    ``members`` lists (cell, current pose, target point) per member robot; ``process`` is the
    declared process duration d (pick/handoff/deliver duration or the operation's duration);
    ``profile`` is a resolved profile IR (spacing, reach, speed, joint_speed, retreat_fraction,
    motion_planning are read).  ``common_target`` is the activity's x(e); it may be omitted when
    all members share one target (picks, handoffs, deliveries, offset-free operations).

    1. If some target is farther than reach + 1e-9 from its member's base, the activity is
       MotionInfeasible (G-REACH) — also with motion planning off.
    2. Per member: Cartesian ticks ceil(||x - e|| / speed), joint ticks from the joint proxy,
       travel = max of the two; reach margin = reach - ||x - b||.
    3. A = max travel, R = ceil(retreat_fraction * A), D = max(1, A + P + R).
       With ``motion_planning`` false: A = R = 0 and D = max(1, P) (segments, poses and margins
       are still computed).

    ``targets`` (optional): a memo of :func:`target_pose` by (cell, target) that the caller keeps
    (:class:`PlanMemo`); the member's current pose is not part of it.
    """
    if not members:
        raise ValueError("an activity needs at least one member")
    spacing = float(profile["spacing"])
    reach = float(profile["reach"])
    speed = float(profile["speed"])
    joint_speed = float(profile["joint_speed"])

    cells: list[Cell] = []
    segments: list[Segment] = []
    poses: list[RobotPose] = []
    travel: list[int] = []
    margins: list[float] = []
    path_length = 0.0
    for cell, pose, target in members:
        if targets is None:
            rho, end = target_pose(cell, target, reach, spacing)
        else:
            part = targets.get((cell, target))
            if part is None:
                part = targets[(cell, target)] = target_pose(cell, target, reach, spacing)
            rho, end = part
        if rho > reach + REACH_TOLERANCE:  # G-REACH
            return None
        target = end.ee
        ticks = max(cartesian_ticks(pose.ee, target, speed), joint_ticks(pose.q, end.q, joint_speed))
        cells.append(cell)
        segments.append((pose.ee, target))
        poses.append(end)
        travel.append(ticks)
        margins.append(reach - rho)
        path_length += distance(target, pose.ee)

    if common_target is None:
        distinct = {p.ee for p in poses}
        if len(distinct) != 1:
            raise ValueError("members have different targets: pass common_target explicitly")
        common_target = poses[0].ee

    if variants.enabled("motion_planning", profile):
        approach = max(travel)
        retreat = math.ceil(float(profile["retreat_fraction"]) * approach)
    else:
        approach = retreat = 0
    return Plan(
        members=tuple(cells),
        approach=approach,
        process=process,
        retreat=retreat,
        duration=max(1, approach + process + retreat),  # G-DURATION
        segments=tuple(segments),
        target_poses=tuple(poses),
        member_travel=tuple(travel),
        common_target=(float(common_target[0]), float(common_target[1])),
        min_reach_margin=min(margins),
        path_length=path_length,
    )


class PlanMemo:
    """Plans of one profile by (members with their current poses and targets, process, common target).

    A plan is a pure function of those inputs (G-MOTION), and an instance's candidates are planned
    again every epoch while most poses have not changed (as are picks, handoffs and deliveries that
    were blocked and are tried again), so the interpreter looks them up here.
    MotionInfeasible (None) is remembered too.  A plan that is not remembered (a member moved) is
    planned with the members' target poses remembered here (:func:`target_pose`: the few targets of an
    instance recur far more often than pose combinations).  Bounded: each memo starts over past
    ``limit`` entries.
    """

    def __init__(self, profile: Mapping[str, Any], limit: int = 20_000):
        self.profile, self.limit = profile, limit
        self._plans: dict[tuple, Plan | None] = {}
        self._targets: dict[tuple[Cell, Point], tuple[float, RobotPose]] = {}

    def plan(self, members: Sequence[tuple[Cell, RobotPose, Point]], process: int, common_target: Point) -> Plan | None:
        key = (tuple(members), process, common_target)
        if key in self._plans:
            return self._plans[key]
        if len(self._plans) >= self.limit:
            self._plans.clear()
        if len(self._targets) >= self.limit:
            self._targets.clear()
        plan = plan_activity(members, process, self.profile, common_target=common_target, targets=self._targets)
        self._plans[key] = plan
        return plan


# --------------------------------------------------------------------------------------------
# Segment distance and conflicts (G-SEGMENT-DISTANCE, G-CONFLICT)
# --------------------------------------------------------------------------------------------


def _orientation(a: Point, b: Point, c: Point) -> int:
    """Sign of the cross product (b - a) x (c - a); values within 1e-12 of zero count as 0."""
    value = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
    if abs(value) <= SEGMENT_TOLERANCE:
        return 0
    return 1 if value > 0 else -1


def _within_box(p: Point, a: Point, b: Point) -> bool:
    """p lies in the bounding box of segment ab (tolerance 1e-12)."""
    tol = SEGMENT_TOLERANCE
    return (
        min(a[0], b[0]) - tol <= p[0] <= max(a[0], b[0]) + tol
        and min(a[1], b[1]) - tol <= p[1] <= max(a[1], b[1]) + tol
    )


def segments_intersect(s1: Segment, s2: Segment) -> bool:
    """G-SEGMENT-DISTANCE: proper crossing by orientation signs, or an endpoint of one segment
    collinear with and inside the bounding box of the other."""
    p1, p2 = s1
    q1, q2 = s2
    o1, o2 = _orientation(p1, p2, q1), _orientation(p1, p2, q2)
    o3, o4 = _orientation(q1, q2, p1), _orientation(q1, q2, p2)
    if o1 * o2 < 0 and o3 * o4 < 0:
        return True
    return (
        (o1 == 0 and _within_box(q1, p1, p2))
        or (o2 == 0 and _within_box(q2, p1, p2))
        or (o3 == 0 and _within_box(p1, q1, q2))
        or (o4 == 0 and _within_box(p2, q1, q2))
    )


def point_segment_distance(p: Point, s: Segment) -> float:
    """Distance from p to segment s by clamped projection; a degenerate segment is a point."""
    (ax, ay), (bx, by) = s
    vx, vy = bx - ax, by - ay
    length2 = vx * vx + vy * vy
    if length2 <= SEGMENT_TOLERANCE * SEGMENT_TOLERANCE:
        return math.hypot(p[0] - ax, p[1] - ay)
    t = ((p[0] - ax) * vx + (p[1] - ay) * vy) / length2
    t = max(0.0, min(1.0, t))
    return math.hypot(p[0] - (ax + t * vx), p[1] - (ay + t * vy))


def segment_distance(s1: Segment, s2: Segment) -> float:
    """G-SEGMENT-DISTANCE: minimum Euclidean distance between two closed segments.

    0 if they intersect (:func:`segments_intersect`); otherwise the minimum of the four
    endpoint-to-other-segment distances.
    """
    if segments_intersect(s1, s2):
        return 0.0
    return min(
        point_segment_distance(s1[0], s2),
        point_segment_distance(s1[1], s2),
        point_segment_distance(s2[0], s1),
        point_segment_distance(s2[1], s1),
    )


def conflict_distance(
    p1: Plan, p2: Plan, rho_conf: float, clearances: Mapping[Cell, float] | float
) -> float:
    """G-CONFLICT: c(e, e') = rho_conf + max clearance over the members of both activities.

    ``clearances`` maps cells to clearances, or is one number for a homogeneous population.
    """
    if isinstance(clearances, (int, float)):
        return rho_conf + float(clearances)
    return rho_conf + max(clearances[c] for c in (*p1.members, *p2.members))


# Segment distances are never below the gap between the segments' bounding boxes; a box gap this far
# beyond the limit cannot hide a conflict even after floating-point rounding of either computation.
BOUNDS_MARGIN = 1e-6


def _bounds_gap(a: tuple[float, float, float, float], b: tuple[float, float, float, float]) -> float:
    """Euclidean gap between two axis-aligned boxes (0 when they overlap)."""
    dx = max(0.0, a[0] - b[2], b[0] - a[2])
    dy = max(0.0, a[1] - b[3], b[1] - a[3])
    return math.hypot(dx, dy)


def plans_conflict(
    p1: Plan,
    p2: Plan,
    rho_conf: float,
    clearances: Mapping[Cell, float] | float,
    *,
    segments: bool = True,
) -> bool:
    """G-CONFLICT: two activities conflict geometrically iff, with c = :func:`conflict_distance`,
    some member segment of one is closer than c - 1e-12 to some member segment of the other, or
    their common targets are closer than c - 1e-12.

    Only the geometric part: sharing a robot or an exclusive resource is checked by the caller.
    ``segments=False`` drops the segment test and keeps the target test (for callers that turn
    trajectory conflicts off).
    """
    limit = conflict_distance(p1, p2, rho_conf, clearances) - CONFLICT_TOLERANCE
    if distance(p1.common_target, p2.common_target) < limit:
        return True
    if segments and _bounds_gap(p1.segment_bounds, p2.segment_bounds) < limit + BOUNDS_MARGIN:
        for s1 in p1.segments:
            for s2 in p2.segments:
                if segment_distance(s1, s2) < limit:
                    return True
    return False
