"""Geometry profile checks (spec chapter 03, PR-*; codes AG401-AG406): numeric ranges, logistics
durations, handoff reach and variant overrides."""

from __future__ import annotations

import math
from typing import Mapping

from agspec.formats.diagnostics import Issue
from agspec.ir import variants
from agspec.ir.validate.common import REACH_TOLERANCE, Json, _dict, _did_you_mean, _err, _is_int, _is_num, _ptr, _q

PROFILE_POSITIVE = ("spacing", "reach", "reference_reach", "reference_time", "speed", "joint_speed", "payload")
PROFILE_NON_NEGATIVE = ("rho_conf", "clearance", "role_target_offset")
PROFILE_FRACTIONS = ("retreat_fraction",)
PROFILE_DURATIONS = ("pick", "handoff", "deliver")
PROFILE_FIELDS = frozenset(
    PROFILE_POSITIVE + PROFILE_NON_NEGATIVE + PROFILE_FRACTIONS
    + ("durations", "robot_model", "tools", "motion_planning", "trajectory_conflicts")
)
NOT_OVERRIDABLE = frozenset({"ir_version", "kind", "id", "variants", "variant", "doc", "meta"})


def validate_profile(ir: Json) -> list[Issue]:
    """PR-*: numeric ranges, logistics durations, handoff feasibility, and variant overrides."""
    profile = _dict(ir)
    issues = _check_profile_values(profile, profile, "")
    issues += _check_handoff_reach(profile, "", None)
    for name, overrides in _dict(profile.get("variants")).items():
        issues += _check_variant(profile, str(name), overrides)
    issues += variants.check("profile", profile)  # S-RULE-VARIANTS
    return issues


def _check_profile_values(values: Mapping, scope: Mapping, prefix: str) -> list[Issue]:
    """PR-RANGES: check the profile fields present in ``scope`` (with values from ``values``)."""
    out: list[Issue] = []
    for key in PROFILE_POSITIVE:
        if key in scope and not (_is_num(values[key]) and values[key] > 0):
            out.append(_err("AG401", f"profile `{key}` must be a number > 0, got {values[key]!r}",
                            prefix + _ptr(key), "distances, speeds and times are positive"))
    for key in PROFILE_NON_NEGATIVE:
        if key in scope and not (_is_num(values[key]) and values[key] >= 0):
            out.append(_err("AG402", f"profile `{key}` must be a number >= 0, got {values[key]!r}",
                            prefix + _ptr(key), f"use 0 to switch the `{key}` effect off"))
    for key in PROFILE_FRACTIONS:
        if key in scope and not (_is_num(values[key]) and 0 <= values[key] <= 1):
            out.append(_err("AG403", f"profile `{key}` must lie in [0, 1], got {values[key]!r}",
                            prefix + _ptr(key), "the retreat is a fraction of the approach time (v1: 0.25)"))
    durations = _dict(values.get("durations"))
    for key in PROFILE_DURATIONS:
        if key in _dict(scope.get("durations")) and not (_is_int(durations[key]) and durations[key] >= 1):
            out.append(_err("AG405", f"profile `{key}` duration must be a positive integer number of "
                            f"ticks, got {durations[key]!r}", prefix + _ptr("durations", key),
                            "v1 uses pick 2, handoff 1, deliver 2"))
    return out


def _check_handoff_reach(values: Mapping, prefix: str, overrides: Mapping | None) -> list[Issue]:
    """PR-HANDOFF-REACH: the midpoint of two diagonal Moore neighbours must be within reach.

    G-HANDOFF-POINT puts a handoff at the midpoint of the two bases, s*sqrt(2)/2 from each base for
    diagonal neighbours (G-BASE); G-REACH needs that distance <= reach + 1e-9.
    """
    spacing, reach = values.get("spacing"), values.get("reach")
    if not (_is_num(spacing) and _is_num(reach) and spacing > 0 and reach > 0):
        return []
    needed = math.hypot(0.5 * spacing, 0.5 * spacing)
    if needed <= reach + REACH_TOLERANCE:
        return []
    key = "spacing" if overrides is not None and "spacing" in overrides else "reach"
    if overrides is not None and key not in overrides:
        return []  # the base profile already has the problem; reported there
    return [_err(
        "AG404", f"reach {reach} is shorter than the distance {needed:.4f} from a base to the handoff "
        f"point of two diagonal neighbours (spacing {spacing} x sqrt(2)/2); diagonal handoffs are impossible",
        prefix + _ptr(key), f"use a reach of at least {needed:.4f} or a spacing of at most {reach * math.sqrt(2):.4f}")]


def _merge(base: Mapping, overrides: Mapping) -> dict:
    out = dict(base)
    for key, value in overrides.items():
        if isinstance(value, Mapping) and isinstance(out.get(key), Mapping):
            out[key] = _merge(out[key], value)
        else:
            out[key] = value
    return out


def _check_variant(profile: Mapping, name: str, overrides: object) -> list[Issue]:
    """PR-VARIANT: a variant overrides known profile fields only, and the result is valid."""
    prefix = _ptr("variants", name)
    if not isinstance(overrides, Mapping):
        return []
    out: list[Issue] = []
    allowed = (PROFILE_FIELDS | set(profile)) - NOT_OVERRIDABLE
    for key, value in overrides.items():
        if key not in allowed:
            out.append(_err("AG406", f"variant `{name}` overrides `{key}`, which is not a profile "
                            f"parameter{_did_you_mean(key, allowed)}", prefix + _ptr(key),
                            "variants override profile parameters such as `rho_conf` or `spacing`"))
        elif key == "durations" and isinstance(value, Mapping):
            for sub in value:
                if sub not in PROFILE_DURATIONS and sub not in _dict(profile.get("durations")):
                    out.append(_err("AG406", f"variant `{name}` overrides duration `{sub}`, which is not "
                                    "a logistics duration", prefix + _ptr("durations", sub),
                                    f"known durations: {_q(PROFILE_DURATIONS)}"))
    merged = _merge(profile, {k: v for k, v in overrides.items() if k in allowed})
    out += _check_profile_values(merged, overrides, prefix)
    if not _check_handoff_reach(profile, "", None):  # else the base profile's AG404 covers it
        out += _check_handoff_reach(merged, prefix, overrides)
    return out
