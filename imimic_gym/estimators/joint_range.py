"""Joint limits as the estimators use them: where a link can point in the image
(`pointing_range`), and a joint angle moved to within its limits (`within_range`).

Angles in rad, counter-clockwise with the image's y axis up (`imimic_gym.kinematics`).
Why a reading past a limit is reported at the limit: `docs/decisions/don-joint-limits.md`.
"""

from __future__ import annotations

import math

from imimic_gym.kinematics import wrap_angle

__all__ = ["pointing_range", "within_range"]


def pointing_range(base: float, joint_range: tuple[float, float],
                   margin_deg: float = 20.0) -> tuple[float, float]:
    """Where a link can point, as (middle direction, half-width), rad: its joint's range
    (low, high, rad) about its parent's direction ``base`` (rad), widened by
    ``margin_deg`` either side for a pivot a few pixels off."""
    lo, hi = joint_range
    return base + (lo + hi) / 2, (hi - lo) / 2 + math.radians(margin_deg)


def within_range(q: float, joint_range: tuple[float, float] | None) -> float:
    """The joint angle ``q`` (rad, wrapped to [-pi, pi)) moved to the nearer (round the
    circle) of the joint's limits ``joint_range`` (low, high, rad) where it lies outside
    them; ``q`` itself inside them or without a range. The arm never passes its limits,
    so a reading past one is that much nearer the truth at the limit."""
    if joint_range is None:
        return q
    lo, hi = joint_range
    if hi - lo >= 2 * math.pi or (q - lo) % (2 * math.pi) <= hi - lo:
        return q
    nearer = lo if abs(wrap_angle(q - lo)) < abs(wrap_angle(q - hi)) else hi
    return float(wrap_angle(nearer))
