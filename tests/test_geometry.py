"""Abstract geometry and motion (spec rules G-*): the paper's deterministic cases, the worked
values of the motion rule, and properties of the segment distance."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from agspec.interp.geometry import (
    RobotPose,
    base,
    handoff_point,
    joint_target,
    operation_site,
    output_point,
    plan_activity,
    plans_conflict,
    point_segment_distance,
    reachable,
    rest_pose,
    role_targets,
    segment_distance,
    shelf_point,
)

# Resolved profile abstract-v1 (only the keys geometry reads).
PROFILE = {
    "spacing": 1.0,
    "reach": 1.5,
    "rho_conf": 0.25,
    "clearance": 0.1,
    "role_target_offset": 0.12,
    "retreat_fraction": 0.25,
    "speed": 1.0,
    "joint_speed": 1.0,
    "motion_planning": True,
    "trajectory_conflicts": True,
}
S = PROFILE["spacing"]


def plan_from_rest(targets, process, profile=PROFILE, **kw):
    """Plan with every member at rest (end effector on its base, q = 0)."""
    members = [(cell, rest_pose(cell, profile["spacing"]), point) for cell, point in targets]
    return plan_activity(members, process, profile, **kw)


def timing(plan):
    return (plan.approach, plan.process, plan.retreat, plan.duration)


# ---------------------------------------------------------------- points


def test_base_is_column_then_row():  # G-BASE
    assert base((2, 3), 1.0) == (3.0, 2.0)
    assert base((2, 3), 0.75) == (2.25, 1.5)


def test_special_points():  # G-SHELF-POINT, G-OUTPUT-POINT, G-HANDOFF-POINT
    assert shelf_point(3, 1.25) == (-0.625, 3.75)
    assert output_point(2, 6, 1.0) == (6.0, 2.0)
    assert handoff_point((0, 0), (1, 1), 1.0) == (0.5, 0.5)


def test_shelf_reachable_only_from_adjacent_rows():  # G-REACH, G-SHELF-POINT
    assert reachable((2, 0), shelf_point(1, S), 1.5, S)
    assert reachable((2, 0), shelf_point(3, S), 1.5, S)
    assert not reachable((2, 0), shelf_point(0, S), 1.5, S)


def test_site_is_centroid_of_holders_in_row_major_order():  # G-SITE
    assert operation_site([(1, 1), (0, 0)], [(0, 0), (0, 1), (1, 1)], S) == (0.5, 0.5)
    assert operation_site([(2, 3)], [(2, 3), (2, 4)], S) == (3.0, 2.0)  # single holder: own base
    assert operation_site([], [(0, 0), (0, 1)], S) == (0.5, 0.0)  # no holders: all members


def test_role_targets_approach_from_own_side():  # G-ROLE-TARGET
    site = (0.5, 0.0)
    targets = role_targets(site, [((0, 1), "holder_B"), ((0, 0), "holder_A")], 0.12, S)
    assert targets == {(0, 0): (0.38, 0.0), (0, 1): (0.62, 0.0)}


def test_role_targets_without_offset():  # G-ROLE-TARGET
    site = (0.5, 0.0)
    members = [((0, 0), "a"), ((0, 1), "b")]
    assert role_targets(site, members, 0.0, S) == {(0, 0): site, (0, 1): site}
    assert role_targets((3.0, 2.0), [((2, 3), "a")], 0.12, S) == {(2, 3): (3.0, 2.0)}


def test_role_target_angular_fallback_for_member_on_site():  # G-ROLE-TARGET
    site = base((1, 1), S)  # single holder: site on its base
    members = [((1, 1), "holder_A"), ((1, 2), "helper")]
    targets = role_targets(site, members, 0.12, S)
    # (role, cell) order: "helper" (k=0) < "holder_A" (k=1); n = 2; phi_1 = -pi/2 + pi.
    phi = -math.pi / 2 + 2 * math.pi * 1 / 2
    assert targets[(1, 1)] == (1.0 + 0.12 * math.cos(phi), 1.0 + 0.12 * math.sin(phi))
    assert targets[(1, 1)] == pytest.approx((1.0, 1.12))
    assert targets[(1, 2)] == pytest.approx((1.12, 1.0))
    # Three members: the holder is third in (role, cell) order -> phi = -pi/2 + 4pi/3.
    trio = [((1, 1), "z_holder"), ((1, 2), "helper"), ((0, 1), "helper")]
    phi = -math.pi / 2 + 2 * math.pi * 2 / 3
    assert role_targets(site, trio, 0.12, S)[(1, 1)] == (1.0 + 0.12 * math.cos(phi), 1.0 + 0.12 * math.sin(phi))


# ---------------------------------------------------------------- motion: paper cases


def test_paper_pair_at_midpoint_without_offsets():  # G-MOTION, G-DURATION (paper case)
    a, b = (0, 0), (0, 1)
    mid = handoff_point(a, b, S)
    plan = plan_from_rest([(a, mid), (b, mid)], 3)
    assert plan is not None
    assert timing(plan) == (4, 3, 1, 8)
    assert plan.min_reach_margin == 1.0


def test_paper_pair_with_role_offsets():  # G-ROLE-TARGET, G-MOTION, G-DURATION (paper case)
    a, b = (0, 0), (0, 1)
    site = operation_site([a, b], [a, b], S)
    targets = role_targets(site, [(a, "holder_A"), (b, "holder_B")], 0.12, S)
    plan = plan_from_rest([(a, targets[a]), (b, targets[b])], 3, common_target=site)
    assert plan is not None
    assert timing(plan) == (4, 3, 1, 8)
    assert plan.min_reach_margin == pytest.approx(1.12, abs=1e-12)
    assert plan.common_target == site


def test_paper_singleton_out_of_reach_is_rejected():  # G-REACH (paper case)
    assert plan_from_rest([((0, 0), (2.0, 0.0))], 3) is None


def test_reach_tolerance():  # G-REACH
    assert plan_from_rest([((0, 0), (1.5 + 5e-10, 0.0))], 1) is not None
    assert plan_from_rest([((0, 0), (1.5 + 2e-9, 0.0))], 1) is None


# ---------------------------------------------------------------- motion: worked values table


@pytest.mark.parametrize(
    "name, targets, process, expected, margin",
    [
        ("pick own-row shelf", [((2, 0), shelf_point(2, S))], 2, (4, 2, 1, 7), 1.0),
        ("pick adjacent-row shelf", [((2, 0), shelf_point(1, S))], 2, (3, 2, 1, 6), 1.5 - math.hypot(0.5, 1.0)),
        ("delivery", [((2, 5), output_point(2, 6, S))], 2, (2, 2, 1, 5), 0.5),
        ("unary op at own base", [((2, 3), base((2, 3), S))], 5, (0, 5, 0, 5), 1.5),
        ("horizontal handoff", [((1, 1), handoff_point((1, 1), (1, 2), S)), ((1, 2), handoff_point((1, 1), (1, 2), S))], 1, (4, 1, 1, 6), 1.0),
        ("vertical handoff", [((0, 0), handoff_point((0, 0), (1, 0), S)), ((1, 0), handoff_point((0, 0), (1, 0), S))], 1, (2, 1, 1, 4), 1.0),
    ],
)
def test_worked_values(name, targets, process, expected, margin):  # G-MOTION, G-DURATION
    plan = plan_from_rest(targets, process)
    assert plan is not None, name
    assert timing(plan) == expected, name
    assert plan.min_reach_margin == pytest.approx(margin, abs=1e-12), name


def test_adjacent_row_margin_rounds_to_0382():  # G-MOTION (worked values table)
    plan = plan_from_rest([((2, 0), shelf_point(1, S))], 2)
    assert round(plan.min_reach_margin, 3) == 0.382


def test_unary_op_role_target_is_site():  # G-ROLE-TARGET + G-MOTION: singleton gets no offset
    cell = (2, 3)
    site = operation_site([cell], [cell], S)
    target = role_targets(site, [(cell, "holder_A")], 0.12, S)[cell]
    plan = plan_from_rest([(cell, target)], 4)
    assert timing(plan) == (0, 4, 0, 4)
    assert plan.min_reach_margin == 1.5


def test_theta_wrap_from_plus_pi_to_minus_pi_costs_7_ticks():  # G-MOTION (no angle normalisation)
    cell = (0, 0)
    pick = plan_from_rest([(cell, shelf_point(0, S))], 2)
    pose = pick.final_poses()[cell]
    assert pose.ee == (-0.5, 0.0) and pose.q[0] == math.pi  # atan2(+0.0, -0.5) = +pi
    # The same spot seen from just below the row line: atan2(-tiny, -0.5) = -pi.
    noisy = (-0.5, -1e-17)
    assert joint_target(cell, noisy, 1.5, S)[0] == -math.pi
    plan = plan_activity([(cell, pose, noisy)], 2, PROFILE)
    assert plan.member_travel == (7,)  # ceil(2*pi / 1.0)
    assert plan.approach == 7 and plan.retreat == 2 and plan.duration == 11
    # ... whereas returning to exactly the same point costs nothing.
    same = plan_activity([(cell, pose, (-0.5, 0.0))], 2, PROFILE)
    assert timing(same) == (0, 2, 0, 2)


def test_end_effectors_stay_at_target():  # G-END-EFFECTOR
    cell = (2, 0)
    pick = plan_from_rest([(cell, shelf_point(2, S))], 2)
    pose = pick.final_poses()[cell]
    assert pose == RobotPose(ee=(-0.5, 2.0), q=joint_target(cell, (-0.5, 2.0), 1.5, S))
    assert pick.segments == (((0.0, 2.0), (-0.5, 2.0)),)
    # History matters: handing off east from the shelf pose takes longer than from rest.
    mid = handoff_point(cell, (2, 1), S)
    after = plan_activity([(cell, pose, mid), ((2, 1), rest_pose((2, 1), S), mid)], 1, PROFILE)
    assert after.member_travel[0] == 4  # |0 - pi| -> 4 ticks back
    assert after.path_length == pytest.approx(1.0 + 0.5)


def test_motion_planning_off():  # G-DURATION
    off = dict(PROFILE, motion_planning=False)
    plan = plan_from_rest([((2, 0), shelf_point(2, S))], 2, profile=off)
    assert timing(plan) == (0, 2, 0, 2)
    assert plan_from_rest([((0, 0), base((0, 0), S))], 0, profile=off).duration == 1
    assert plan_from_rest([((0, 0), (2.0, 0.0))], 3, profile=off) is None  # reach still applies


def test_members_with_different_targets_need_a_common_target():  # G-CONFLICT x(e)
    with pytest.raises(ValueError):
        plan_from_rest([((0, 0), (0.38, 0.0)), ((0, 1), (0.62, 0.0))], 3)


# ---------------------------------------------------------------- conflicts


def test_crossing_approach_segments_conflict():  # G-SEGMENT-DISTANCE, G-CONFLICT (paper case)
    # Two single-member activities whose approach segments cross, targets 1.0 apart.
    p1 = plan_activity([((0, 0), RobotPose(ee=(0.0, 0.0)), (1.0, 1.0))], 1, PROFILE)
    p2 = plan_activity([((0, 1), RobotPose(ee=(1.0, 0.0)), (0.0, 1.0))], 1, PROFILE)
    assert segment_distance(p1.segments[0], p2.segments[0]) == 0.0
    assert math.dist(p1.common_target, p2.common_target) == 1.0
    assert plans_conflict(p1, p2, 0.25, 0.1)
    assert not plans_conflict(p1, p2, 0.25, 0.1, segments=False)


def test_separated_segments_do_not_conflict():  # G-CONFLICT (paper case)
    # Deliveries in rows 0 and 2: parallel segments 2.0 apart.
    p1 = plan_from_rest([((0, 5), output_point(0, 6, S))], 2)
    p2 = plan_from_rest([((2, 5), output_point(2, 6, S))], 2)
    assert segment_distance(p1.segments[0], p2.segments[0]) == 2.0
    assert not plans_conflict(p1, p2, 0.25, 0.1)


def test_conflict_threshold_uses_largest_member_clearance():  # G-CONFLICT
    # Targets exactly 0.4 apart, segments parallel 0.4 apart.
    p1 = plan_activity([((0, 0), RobotPose(ee=(0.0, 0.0)), (0.0, 1.0))], 1, PROFILE)
    p2 = plan_activity([((0, 1), RobotPose(ee=(0.4, 0.0)), (0.4, 1.0))], 1, PROFILE)
    assert not plans_conflict(p1, p2, 0.25, 0.1)  # c = 0.35
    assert plans_conflict(p1, p2, 0.25, {(0, 0): 0.1, (0, 1): 0.2})  # c = 0.45
    assert not plans_conflict(p1, p2, 0.30, 0.1)  # c = 0.40: 0.4 < 0.4 - 1e-12 is false


def test_common_targets_too_close_conflict():  # G-CONFLICT (target clause)
    # Two handoffs at the same midpoint region: identical common targets.
    p1 = plan_from_rest([((0, 0), (0.5, 0.5))], 1)
    p2 = plan_activity([((1, 1), RobotPose(ee=(0.7, 0.5)), (0.7, 0.5))], 1, PROFILE)
    assert plans_conflict(p1, p2, 0.25, 0.1, segments=False)


# ---------------------------------------------------------------- segment distance properties

coord = st.floats(min_value=-2.0, max_value=2.0, allow_nan=False, allow_infinity=False)
point = st.tuples(coord, coord)
segment = st.tuples(point, point)


@settings(max_examples=300, deadline=None)
@given(segment, segment)
def test_segment_distance_symmetric_and_nonnegative(s1, s2):  # G-SEGMENT-DISTANCE
    d = segment_distance(s1, s2)
    assert d >= 0.0
    assert d == pytest.approx(segment_distance(s2, s1), abs=1e-12)
    assert d == pytest.approx(segment_distance((s1[1], s1[0]), s2), abs=1e-12)


@settings(max_examples=200, deadline=None)
@given(point, point, point, st.floats(min_value=0.0, max_value=1.0))
def test_segments_sharing_a_point_have_distance_zero(shared, a, b, t):  # G-SEGMENT-DISTANCE
    assert segment_distance((shared, a), (b, shared)) == 0.0
    on_segment = (a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]))
    assert segment_distance((a, b), (on_segment, shared)) <= 1e-9


def _sampled_distance(s1, s2, n=80):
    def samples(s):
        (ax, ay), (bx, by) = s
        return [(ax + (bx - ax) * k / (n - 1), ay + (by - ay) * k / (n - 1)) for k in range(n)]

    pts2 = samples(s2)
    return min(math.dist(p, q) for p in samples(s1) for q in pts2)


@settings(max_examples=80, deadline=None)
@given(segment, segment)
def test_segment_distance_matches_dense_sampling(s1, s2):  # G-SEGMENT-DISTANCE
    exact = segment_distance(s1, s2)
    sampled = _sampled_distance(s1, s2)
    # The exact minimum never exceeds a sampled pair; sampling overestimates by at most half a
    # sampling step on each segment.
    step = (math.dist(*s1) + math.dist(*s2)) / (2 * (80 - 1))
    assert exact <= sampled + 1e-9
    assert sampled <= exact + step + 1e-9


def test_degenerate_segments_are_points():  # G-SEGMENT-DISTANCE
    p = ((1.0, 1.0), (1.0, 1.0))
    assert segment_distance(p, ((0.0, 0.0), (2.0, 0.0))) == 1.0
    assert segment_distance(p, p) == 0.0
    assert point_segment_distance((3.0, 0.0), ((0.0, 0.0), (2.0, 0.0))) == 1.0
    assert segment_distance(((0.0, 0.0), (1.0, 0.0)), ((2.0, 0.0), (3.0, 0.0))) == 1.0  # collinear, apart
