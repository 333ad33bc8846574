"""G-CONFLICT with the bounding-box prefilter decides exactly as the plain pairwise segment test.

plans_conflict skips the segment-distance loop when the plans' segment bounding boxes are farther
apart than the conflict distance; segment distances are never below that gap, so the answer
must be the one of the definition (every member segment against every other).
"""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from agspec.interp.geometry import CONFLICT_TOLERANCE, Plan, RobotPose, distance, plans_conflict, segment_distance

coord = st.floats(min_value=-3.0, max_value=8.0, allow_nan=False).map(lambda v: round(v, 3))
point = st.tuples(coord, coord)
segments = st.lists(st.tuples(point, point), min_size=1, max_size=3)


def _plan(segs, target) -> Plan:
    n = len(segs)
    return Plan(members=tuple((0, k) for k in range(n)), approach=1, process=1, retreat=0, duration=2,
                segments=tuple(segs), target_poses=tuple(RobotPose(ee=s[1]) for s in segs),
                member_travel=(1,) * n, common_target=target, min_reach_margin=0.0, path_length=0.0)


def by_definition(p1: Plan, p2: Plan, c: float) -> bool:
    limit = c - CONFLICT_TOLERANCE
    return distance(p1.common_target, p2.common_target) < limit or any(
        segment_distance(a, b) < limit for a in p1.segments for b in p2.segments)


@settings(max_examples=400, deadline=None)
@given(segments, point, segments, point, st.sampled_from([0.0, 0.3, 0.55, 1.0, 2.5]))
def test_prefiltered_conflict_equals_the_definition(s1, t1, s2, t2, clearance):  # G-CONFLICT
    p1, p2 = _plan(s1, t1), _plan(s2, t2)
    assert plans_conflict(p1, p2, 0.25, clearance) == by_definition(p1, p2, 0.25 + clearance)


def test_touching_boxes_still_compute_the_segment_distance():  # G-CONFLICT: the prefilter never decides near cases
    # boxes 0.5 apart, conflict distance 0.6: the prefilter must not skip, and the segments do conflict
    p1 = _plan([((0.0, 0.0), (1.0, 0.0))], (10.0, 10.0))
    p2 = _plan([((1.5, 0.0), (2.0, 0.0))], (-10.0, -10.0))
    assert plans_conflict(p1, p2, 0.3, 0.3)
    assert not plans_conflict(p1, p2, 0.2, 0.2)
