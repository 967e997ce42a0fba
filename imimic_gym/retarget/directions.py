"""Direction retargeting (closed form per arm plane): a person's upper-arm and forearm
directions -> SO-101 joint targets.

Frames: the person's directions are read in their **arm frame** (rows forward, outward,
up) and taken into the **robot base frame** (x forward, y left, z up) by a
`PersonToRobot` mapping. The SO-101's shoulder_lift, elbow_flex and wrist_flex axes are
parallel, so its upper arm, forearm and hand always lie in one vertical plane, the plane
turned by shoulder_pan. The retargeter picks the plane and the two elevations in it that
point both segments nearest the person's: the squared angle of the upper arm's error plus
``forearm_weight`` times the forearm's (`DirectionRetargeter`; an upper arm hanging below
the robot's reach with its horizontal part shrunk), within the joint ranges.
Where the person's arm
is a pose the robot can take, both come back exactly.

Angles in rad; joint targets (6,) in `SO101Spec.joint_names` order.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from imimic_gym.retarget.mapping import MIRROR, PersonToRobot
from imimic_gym.robots.so101 import SO101Spec
from imimic_gym.spatial.arm_pose import ArmPose, unit

__all__ = ["DirectionRetargeter", "robot_arm_directions"]

_PAN, _LIFT, _ELBOW, _WRIST, _ROLL, _GRIP = range(6)
# Pans tried over the whole range first (5 degrees apart), then around the best one at
# each finer spacing in turn (rad), 6 spacings to each side.
_COARSE_PANS = 45
_REFINE_SPACINGS = tuple(math.radians(d) for d in (0.5, 0.05))
_REFINE_HALF_WIDTH = 6
# A small share of the robot's own bend direction that decides the wrist's sign when the
# person's elbow is straight (no bend plane of their own).
_STRAIGHT_ELBOW_TIE = math.sin(math.radians(2.0))


def robot_arm_directions(spec: SO101Spec, q: np.ndarray, mapping: PersonToRobot = MIRROR
                         ) -> tuple[np.ndarray, np.ndarray]:
    """The robot's upper-arm (shoulder site -> elbow site) and forearm (elbow site ->
    wrist site) unit directions at joint values ``q`` (6,) rad, each (3,) in the person's
    arm-frame coordinates under ``mapping``."""
    sites = spec.forward_kinematics(q)
    upper = unit(sites[spec.elbow_site] - sites[spec.shoulder_site])
    fore = unit(sites[spec.wrist_site] - sites[spec.elbow_site])
    return mapping.to_arm(upper), mapping.to_arm(fore)


@dataclass(frozen=True)
class _Arms:
    """Candidate arms, one per pan (n,) rad: the upper arm's and the forearm's elevations
    in the pan's vertical plane (n,) rad (the upper arm's from -24 to 176 degrees, past 90
    back over the top), and their costs (n,)."""

    pans: np.ndarray
    upper_elevations: np.ndarray
    fore_elevations: np.ndarray
    costs: np.ndarray


@dataclass(frozen=True)
class DirectionRetargeter:
    """Person's arm -> SO-101 joint targets, frame by frame.

    Per frame: shoulder_pan turns the robot's arm plane, shoulder_lift and elbow_flex set
    its upper arm's and forearm's elevations in it, so as to minimise
    ``e_upper^2 + forearm_weight * e_forearm^2 + flexion_weight * e_flexion^2`` (the
    angles, rad, between the robot's segments and the person's, and between the robot's
    elbow flexion and theirs) within the joint ranges; wrist_flex sets the hand's
    signed angle to the forearm (positive continuing the elbow's bend); wrist_roll and
    gripper hold ``wrist_roll`` and ``gripper`` (rad). With a ``previous`` target, each
    choice also pays ``continuity`` rad of direction error per rad of joint motion, so the
    targets move continuously: the pan is held where the arm leaves it free, and a
    solution is never swapped for a distant one that fits only slightly better; and
    ``jump_cost`` rad more per rad that a joint would move beyond ``max_step``, so a
    solution more than a frame's step away (the shoulder over the top, the elbow to its
    other bend) is taken only where it fits far better (the robot is blind meanwhile:
    it points wrong for every frame of the swing); and no joint moves more than
    ``max_step`` rad from ``previous``, so where the robot does swing, it swings over
    several frames instead of flipping. The squared costs add: continuity^2 * sum(d^2)
    + jump_cost^2 * sum(max(|d| - max_step, 0)^2) over pan, lift and elbow moves d.
    An upper arm hanging lower than the robot can point counts with its horizontal part
    shrunk (``hanging_power``, `_below_reach`): near the pole that part is mostly the
    estimate's error, so the forearm turns the pan there instead of an upper arm's
    slight tilt back swinging the robot half a turn.
    """

    spec: SO101Spec = field(default_factory=SO101Spec)
    mapping: PersonToRobot = MIRROR
    wrist_roll: float = 0.0
    gripper: float = 0.0
    continuity: float = 0.1
    jump_cost: float = 1.0
    max_step: float = math.radians(12.0)
    forearm_weight: float = 1.0
    flexion_weight: float = 0.0
    hanging_power: float = 2.0

    def __post_init__(self) -> None:
        for name, index in (("wrist_roll", _ROLL), ("gripper", _GRIP)):
            lo, hi = self.spec.joint_ranges[index]
            if not lo <= getattr(self, name) <= hi:
                raise ValueError(f"DirectionRetargeter.{name} must be inside its joint range "
                                 f"[{lo}, {hi}] rad, got {getattr(self, name)}")
        weights = (self.continuity, self.jump_cost, self.forearm_weight, self.flexion_weight,
                   self.hanging_power)
        if min(weights) < 0 or self.max_step <= 0:
            raise ValueError(f"continuity, jump_cost, forearm_weight, flexion_weight and "
                             f"hanging_power must be >= 0 and max_step > 0, got {weights} and "
                             f"{self.max_step}")

    @cached_property
    def _zero_angles(self) -> tuple[float, float]:
        """(upper arm's elevation in its plane at zero lift, the forearm's bend from the
        upper arm at zero elbow), rad, from the model's forward kinematics at q = 0."""
        sites = self.spec.forward_kinematics(np.zeros(len(self.spec.joint_names)))
        upper = sites[self.spec.elbow_site] - sites[self.spec.shoulder_site]
        fore = sites[self.spec.wrist_site] - sites[self.spec.elbow_site]
        upper_elevation = math.atan2(upper[2], upper[0])
        return upper_elevation, upper_elevation - math.atan2(fore[2], fore[0])

    @cached_property
    def _elevation_ranges(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """((lowest, highest) upper-arm elevation, (most back-up, most forward-down) bend
        of the forearm from the upper arm), rad, from the lift's and elbow's ranges."""
        upper_zero, fore_zero = self._zero_angles
        lift_lo, lift_hi = self.spec.joint_ranges[_LIFT]
        elbow_lo, elbow_hi = self.spec.joint_ranges[_ELBOW]
        return (upper_zero - lift_hi, upper_zero - lift_lo), (fore_zero + elbow_lo,
                                                              fore_zero + elbow_hi)

    def __call__(self, pose: ArmPose, previous: np.ndarray | None = None) -> np.ndarray:
        """(6,) float64 rad joint targets for ``pose``, inside the joint ranges;
        ``previous``: (6,) rad, the last targets (None at the first frame)."""
        upper, fore, hand = unit(self.mapping.to_robot(pose.in_arm_frame(
            np.stack([pose.upper_arm, pose.forearm, pose.hand]))))
        flexion = pose.elbow_flexion
        last = None if previous is None else self.spec.clip(previous)
        aim = self._below_reach(upper)

        lo, hi = self.spec.joint_ranges[_PAN]
        best = self._arms(aim, fore, flexion, self._candidate_pans(aim, fore, last), last)
        for spacing in _REFINE_SPACINGS:
            pan = best.pans[np.argmin(best.costs)]
            offsets = spacing * np.arange(-_REFINE_HALF_WIDTH, _REFINE_HALF_WIDTH + 1)
            around = self._arms(aim, fore, flexion, np.minimum(np.maximum(pan + offsets, lo), hi),
                                last)
            if around.costs.min() < best.costs.min():
                best = around
        i = int(np.argmin(best.costs))
        q = self._targets(float(best.pans[i]), float(best.upper_elevations[i]),
                          float(best.fore_elevations[i]), upper, fore, hand)
        if last is None:
            return q
        return np.clip(q, last - self.max_step, last + self.max_step)

    def _below_reach(self, upper: np.ndarray) -> np.ndarray:
        """The upper arm ((3,) unit, robot base frame) that the pan and elevations aim at:
        ``upper`` itself where the robot can point that low; below its lowest elevation
        (a hanging arm) its horizontal part shrunk by (its length / the lowest elevation's
        cosine) ** ``hanging_power``. Such an arm's horizontal direction is ill-defined
        near the pole and out of the robot's reach anyway, so the forearm decides the pan
        there."""
        lowest = self._elevation_ranges[0][0]
        if self.hanging_power <= 0.0 or upper[2] >= math.sin(lowest):
            return upper
        across = math.hypot(float(upper[0]), float(upper[1]))
        shrink = (across / math.cos(lowest)) ** self.hanging_power
        return unit(np.array([upper[0] * shrink, upper[1] * shrink, upper[2]]))

    def _candidate_pans(self, upper: np.ndarray, fore: np.ndarray, last: np.ndarray | None
                        ) -> np.ndarray:
        """(n,) pans to try: a grid over the range, those in range that turn the arm's
        plane onto the upper arm or onto the forearm (each two, half a turn apart), and
        the last pan."""
        lo, hi = self.spec.joint_ranges[_PAN]
        facing = [float(_wrap(np.float64(-math.atan2(d[1], d[0]) + turn)))
                  for d in (upper, fore) for turn in (0.0, math.pi)]
        pans = [pan for pan in facing if lo <= pan <= hi]
        if last is not None:
            pans.append(float(last[_PAN]))
        return np.concatenate([np.linspace(lo, hi, _COARSE_PANS), pans])

    def _arms(self, upper: np.ndarray, fore: np.ndarray, flexion: float, pans: np.ndarray,
              last: np.ndarray | None) -> _Arms:
        """For each pan, the best upper-arm elevation and bend in its plane.

        With both direction errors split into an out-of-plane part (fixed by the pan) and
        an in-plane part, the cost is near a quadratic in the upper arm's elevation ``a``
        and the bend ``b``: ``a - a_upper`` and ``a - b - a_fore`` each weighed by its
        curvature, and ``b -+ flexion`` for the bend to either side. Its optimum over the
        box of the lift's and elbow's ranges is the free one or lies on an edge; for
        each side the five are tried and priced by the exact cost."""
        (a_lo, a_hi), (b_lo, b_hi) = self._elevation_ranges
        cos_pan, sin_pan = np.cos(pans), np.sin(pans)
        upper_across = cos_pan * upper[0] - sin_pan * upper[1]  # along the plane's horizontal
        fore_across = cos_pan * fore[0] - sin_pan * fore[1]
        # The upper arm's in-plane elevation, wrapped nearest the reachable interval; the
        # bend to the forearm's, wrapped nearest the elbow's interval.
        a_upper = _wrap_near(np.arctan2(upper[2], upper_across), 0.5 * (a_lo + a_hi))
        a_fore = a_upper - _wrap_near(a_upper - np.arctan2(fore[2], fore_across),
                                      0.5 * (b_lo + b_hi))
        k_upper = _curvature(upper_across, upper[2])
        k_fore = self.forearm_weight * _curvature(fore_across, fore[2])
        k_flex = self.flexion_weight
        columns = []
        for bend in (flexion, -flexion):
            # Free optimum (the gradient's two equations solved), then each edge's.
            free_shift = k_fore * (a_upper - a_fore - bend) / (
                k_upper * (k_flex + k_fore) + k_fore * k_flex + 1e-12)
            columns.append((a_upper - k_flex * free_shift, bend + k_upper * free_shift))
            for a in (a_lo, a_hi):
                columns.append((np.full_like(pans, a), (k_fore * (a - a_fore) + k_flex * bend)
                                / (k_fore + k_flex + 1e-12)))
            for b in (b_lo, b_hi):
                columns.append(((k_upper * a_upper + k_fore * (b + a_fore))
                                / (k_upper + k_fore + 1e-12), np.full_like(pans, b)))
        elevations = np.minimum(np.maximum(np.stack([a for a, _ in columns], axis=1), a_lo),
                                a_hi)
        bends = np.minimum(np.maximum(np.stack([b for _, b in columns], axis=1), b_lo), b_hi)
        fore_elevations = elevations - bends
        costs = (_plane_angle(upper_across, upper[2], elevations) ** 2
                 + self.forearm_weight * _plane_angle(fore_across, fore[2], fore_elevations) ** 2
                 + k_flex * (np.abs(bends) - flexion) ** 2)
        if last is not None:
            upper_zero, fore_zero = self._zero_angles
            moves = np.abs(np.stack(np.broadcast_arrays(
                (pans - last[_PAN])[:, None], upper_zero - elevations - last[_LIFT],
                bends - fore_zero - last[_ELBOW])))  # (3, n, k) rad
            costs += (self.continuity ** 2 * (moves ** 2).sum(axis=0)
                      + self.jump_cost ** 2
                      * (np.maximum(moves - self.max_step, 0.0) ** 2).sum(axis=0))
        rows = np.arange(len(pans))
        pick = np.argmin(costs, axis=1)
        return _Arms(pans, elevations[rows, pick], fore_elevations[rows, pick],
                     costs[rows, pick])

    def _targets(self, pan: float, upper_elevation: float,
                 fore_elevation: float, upper: np.ndarray, fore: np.ndarray, hand: np.ndarray
                 ) -> np.ndarray:
        """(6,) joint targets for one arm in its plane; the wrist turns the hand by its
        angle to the person's forearm, continuing the robot's bend where the person's
        hand continues theirs."""
        upper_zero, fore_zero = self._zero_angles
        plane = np.array([math.cos(pan), -math.sin(pan), 0.0])
        robot_bend = upper_elevation - fore_elevation
        side = 1.0 if robot_bend >= 0 else -1.0
        # The robot's positive wrist turns the hand toward lower elevation in the plane.
        robot_down = _in_plane(plane, fore_elevation - math.pi / 2)
        own_bend = -(upper - float(upper @ fore) * fore)  # |own_bend| = sin(flexion)
        tie = side * (robot_down - float(robot_down @ fore) * fore)
        continue_bend = unit(own_bend + _STRAIGHT_ELBOW_TIE * tie)
        wrist = side * math.atan2(float(hand @ continue_bend), float(hand @ fore))
        q = np.array([pan, upper_zero - upper_elevation, robot_bend - fore_zero, wrist,
                      self.wrist_roll, self.gripper])
        return self.spec.clip(q)


def _plane_angle(across: np.ndarray, up: float, elevations: np.ndarray) -> np.ndarray:
    """(n, k) rad: the angles between a unit direction and the directions at
    ``elevations`` (n, k) rad in n vertical planes; ``across`` (n,) is the direction's
    component along each plane's horizontal, ``up`` its vertical one."""
    cosine = np.cos(elevations) * across[:, None] + np.sin(elevations) * up
    return np.arccos(np.minimum(np.maximum(cosine, -1.0), 1.0))


def _curvature(across: np.ndarray, up: float) -> np.ndarray:
    """(n,) half the second derivative of the squared angle between a unit direction and
    a direction turning in n vertical planes, at its nearest: o / tan(o) for the
    out-of-plane angle o (1 in the plane, 0 across it); ``across`` and ``up`` as in
    `_plane_angle`."""
    in_plane = np.minimum(np.sqrt(across ** 2 + up ** 2), 1.0)
    out_of_plane = np.arccos(in_plane)
    return np.where(out_of_plane > 1e-6,
                    out_of_plane * in_plane / np.maximum(np.sin(out_of_plane), 1e-12), 1.0)


def _in_plane(plane: np.ndarray, elevation: float) -> np.ndarray:
    """(3,) unit direction at ``elevation`` rad above ``plane``'s (3,) horizontal
    direction, in the vertical plane through it (past pi/2 back over the top)."""
    return math.cos(elevation) * plane + math.sin(elevation) * np.array([0.0, 0.0, 1.0])


def _wrap(angle: np.ndarray) -> np.ndarray:
    """Angles rad wrapped into (-pi, pi]."""
    return np.pi - np.mod(np.pi - angle, 2 * np.pi)


def _wrap_near(angle: np.ndarray, centre: float) -> np.ndarray:
    """Angles rad wrapped into (centre - pi, centre + pi]."""
    return centre + _wrap(angle - centre)
