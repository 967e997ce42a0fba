"""Direction retargeting (closed form): a person's upper-arm and forearm directions and
elbow flexion -> SO-101 joint targets.

Frames: the person's directions are read in their **arm frame** (rows forward, outward,
up) and taken into the **robot base frame** (x forward, y left, z up) by a
`PersonToRobot` mapping. The SO-101's shoulder_lift, elbow_flex and wrist_flex axes are
parallel, so its upper arm, forearm and hand always lie in one vertical plane, the plane
turned by shoulder_pan: the robot matches the upper arm's direction and the elbow's
flexion exactly where its ranges allow, and the forearm's direction only where the
person's forearm lies in that plane (otherwise the nearer of the two in-plane forearms).

Angles in rad; joint targets (6,) in `SO101Spec.joint_names` order.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from imimic_gym.retarget.mapping import MIRROR, PersonToRobot
from imimic_gym.robots.so101 import SO101Spec
from imimic_gym.spatial.arm_pose import ArmPose, angle_between, unit

__all__ = ["DirectionRetargeter", "robot_arm_directions"]

_PAN, _LIFT, _ELBOW, _WRIST, _ROLL, _GRIP = range(6)
# Pans tried between the previous pan and each exact one (the continuity trade-off).
_BLEND_STEPS = 65
# rad: an upper arm this close to a robot direction counts as reached.
_REACHED = 1e-9
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
class DirectionRetargeter:
    """Person's arm -> SO-101 joint targets, frame by frame.

    Per frame: shoulder_pan and shoulder_lift point the robot's upper arm along the
    person's (or, where the robot cannot, along the nearest direction it can reach);
    elbow_flex sets the person's flexion, bending to the side nearer the person's forearm;
    wrist_flex sets the hand's signed angle to the forearm (positive continuing the
    elbow's bend); wrist_roll and gripper hold ``wrist_roll`` and ``gripper`` (rad). With
    a ``previous`` target, each choice also pays ``continuity`` rad of direction error
    per rad of joint motion, so the targets move continuously: the pan is held where the
    upper arm points along the pan axis (any pan fits there), and a solution is never
    swapped for a distant one that fits only slightly better; and no joint moves more
    than ``max_step`` rad from ``previous``, so where the robot must swing its pan half
    a turn to follow, it swings over several frames instead of flipping.
    ``forearm_weight`` is how much the forearm's direction counts beside the upper arm
    and the flexion (a tie-break: the bend side, and which of two equal shoulders).
    """

    spec: SO101Spec = field(default_factory=SO101Spec)
    mapping: PersonToRobot = MIRROR
    wrist_roll: float = 0.0
    gripper: float = 0.0
    continuity: float = 0.1
    max_step: float = math.radians(12.0)
    forearm_weight: float = 0.002

    def __post_init__(self) -> None:
        for name, index in (("wrist_roll", _ROLL), ("gripper", _GRIP)):
            lo, hi = self.spec.joint_ranges[index]
            if not lo <= getattr(self, name) <= hi:
                raise ValueError(f"DirectionRetargeter.{name} must be inside its joint range "
                                 f"[{lo}, {hi}] rad, got {getattr(self, name)}")
        if self.continuity < 0 or self.forearm_weight < 0 or self.max_step <= 0:
            raise ValueError(f"continuity and forearm_weight must be >= 0 and max_step > 0, "
                             f"got {self.continuity}, {self.forearm_weight}, {self.max_step}")

    @cached_property
    def _zero_angles(self) -> tuple[float, float]:
        """(upper arm's elevation in its plane at zero lift, the forearm's bend from the
        upper arm at zero elbow), rad, from the model's forward kinematics at q = 0."""
        sites = self.spec.forward_kinematics(np.zeros(len(self.spec.joint_names)))
        upper = sites[self.spec.elbow_site] - sites[self.spec.shoulder_site]
        fore = sites[self.spec.wrist_site] - sites[self.spec.elbow_site]
        upper_elevation = math.atan2(upper[2], upper[0])
        return upper_elevation, upper_elevation - math.atan2(fore[2], fore[0])

    def __call__(self, pose: ArmPose, previous: np.ndarray | None = None) -> np.ndarray:
        """(6,) float64 rad joint targets for ``pose``, inside the joint ranges;
        ``previous``: (6,) rad, the last targets (None at the first frame)."""
        upper = unit(self.mapping.to_robot(pose.in_arm_frame(pose.upper_arm)))
        fore = unit(self.mapping.to_robot(pose.in_arm_frame(pose.forearm)))
        hand = unit(self.mapping.to_robot(pose.in_arm_frame(pose.hand)))
        flexion = pose.elbow_flexion
        last = None if previous is None else self.spec.clip(previous)

        best: tuple[float, np.ndarray] | None = None
        pans = self._candidate_pans(upper, last)
        lifts, planes, upper_errors = self._shoulders(upper, pans)
        for pan, lift, plane, upper_error in zip(pans, lifts, planes, upper_errors,
                                                 strict=True):
            shoulder_cost = upper_error ** 2 + self._motion_cost(last, {_PAN: pan, _LIFT: lift})
            for bend in self._bends(flexion):
                q, cost = self._arm(pan, lift, plane, bend, flexion, upper, fore, hand, last)
                total = shoulder_cost + cost
                if best is None or total < best[0]:
                    best = (total, q)
        assert best is not None  # the candidate pans are never empty
        if last is None:
            return best[1]
        return np.clip(best[1], last - self.max_step, last + self.max_step)

    def _candidate_pans(self, upper: np.ndarray, last: np.ndarray | None) -> np.ndarray:
        """(n,) pans to try: of those in range that turn the arm's plane onto the upper arm
        (one or two, half a turn apart) and the range's ends (where the nearest reachable
        direction may lie), the ones that bring the upper arm nearest; with ``last``, also
        the best blend from the last pan toward each."""
        lo, hi = self.spec.joint_ranges[_PAN]
        azimuth = math.atan2(upper[1], upper[0])
        facing = [float(_wrap(np.float64(-azimuth + turn))) for turn in (0.0, math.pi)]
        tried = np.array([pan for pan in facing if lo <= pan <= hi] + [lo, hi])
        errors = self._shoulders(upper, tried)[2]
        best = [float(pan) for pan in tried[errors <= errors.min() + _REACHED]]
        pans = list(best)
        if last is not None:
            for target in best:
                blend = np.linspace(last[_PAN], target, _BLEND_STEPS)
                lifts, _, errors = self._shoulders(upper, blend)
                cost = errors ** 2 + self.continuity ** 2 * ((blend - last[_PAN]) ** 2
                                                             + (lifts - last[_LIFT]) ** 2)
                pans.append(float(blend[int(np.argmin(cost))]))
        return np.array(pans)

    def _shoulders(self, upper: np.ndarray, pans: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """For pans (n,): the lifts (n,) nearest ``upper`` (clipped into range), the arm
        planes' horizontal unit directions (n, 3), and the upper arm's remaining errors
        (n,) rad."""
        planes = np.stack([np.cos(pans), -np.sin(pans), np.zeros_like(pans)], axis=1)
        elevations = np.arctan2(upper[2], planes @ upper)
        upper_zero = self._zero_angles[0]
        lifts = np.clip(_wrap(upper_zero - elevations), *self.spec.joint_ranges[_LIFT])
        reached = _in_plane(planes, upper_zero - lifts)
        return lifts, planes, np.asarray(angle_between(reached, upper))

    def _arm(self, pan: float, lift: float, plane: np.ndarray, bend: float, flexion: float,
             upper: np.ndarray, fore: np.ndarray, hand: np.ndarray, last: np.ndarray | None
             ) -> tuple[np.ndarray, float]:
        """Targets for one shoulder and one bend side (``bend`` = +flexion bends the
        forearm forward-down in the plane, -flexion back-up), and their cost."""
        upper_zero, fore_zero = self._zero_angles
        elbow = float(np.clip(bend - fore_zero, *self.spec.joint_ranges[_ELBOW]))
        robot_bend = fore_zero + elbow
        fore_elevation = upper_zero - lift - robot_bend
        robot_fore = _in_plane(plane, fore_elevation)
        fore_error = float(angle_between(fore, robot_fore))
        cost = ((abs(robot_bend) - flexion) ** 2 + self.forearm_weight * fore_error ** 2
                + self._motion_cost(last, {_ELBOW: elbow}))

        side = 1.0 if robot_bend >= 0 else -1.0
        # The robot's positive wrist turns the hand toward lower elevation in the plane.
        robot_down = _in_plane(plane, fore_elevation - math.pi / 2)
        own_bend = -(upper - float(upper @ fore) * fore)  # |own_bend| = sin(flexion)
        tie = side * (robot_down - float(robot_down @ fore) * fore)
        continue_bend = unit(own_bend + _STRAIGHT_ELBOW_TIE * tie)
        wrist = side * math.atan2(float(hand @ continue_bend), float(hand @ fore))

        q = np.array([pan, lift, elbow, wrist, self.wrist_roll, self.gripper])
        return self.spec.clip(q), cost

    def _bends(self, flexion: float) -> list[float]:
        """Bend sides to try: forward-down (+flexion) always; back-up (-flexion) only where
        the elbow reaches it, so the flexion itself is never traded for the forearm."""
        lo = self.spec.joint_ranges[_ELBOW][0]
        return [flexion, -flexion] if -flexion - self._zero_angles[1] >= lo else [flexion]

    def _motion_cost(self, last: np.ndarray | None, joints: dict[int, float]) -> float:
        if last is None:
            return 0.0
        return self.continuity ** 2 * sum((value - last[i]) ** 2 for i, value in joints.items())


def _in_plane(plane: np.ndarray, elevation: np.ndarray | float) -> np.ndarray:
    """(..., 3) unit directions at ``elevation`` (...,) rad above ``plane``'s (..., 3)
    horizontal direction, in the vertical plane through it (past pi/2 back over the top)."""
    elevation = np.asarray(elevation, dtype=np.float64)[..., None]
    return np.cos(elevation) * plane + np.sin(elevation) * np.array([0.0, 0.0, 1.0])


def _wrap(angle: np.ndarray) -> np.ndarray:
    """Angles rad wrapped into (-pi, pi]."""
    return np.pi - np.mod(np.pi - angle, 2 * np.pi)
