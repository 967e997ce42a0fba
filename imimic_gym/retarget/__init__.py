"""Retargeting: a person's arm (`spatial.ArmPose`) -> robot joint targets. Each retargeter is
called as ``retargeter(pose, previous) -> (n_joints,) rad`` and owns nothing else.
`DirectionRetargeter` aligns directions in closed form; `MinkRetargeter`
(`imimic_gym.retarget.ik`, needs the ``ik`` extra) solves task-space IK through mink."""

from imimic_gym.retarget.directions import DirectionRetargeter, robot_arm_directions
from imimic_gym.retarget.mapping import MAPPINGS, MIRROR, TILTED, PersonToRobot

__all__ = ["MAPPINGS", "MIRROR", "TILTED", "DirectionRetargeter", "PersonToRobot",
           "robot_arm_directions"]
