"""Robot descriptions: what a robot is (joints, ranges, zero, its MJCF, its named sites),
read by the env, the controllers, the renderer and retargeting. The planar 1-3 link arm is
`imimic_gym.robots.planar.ArmSpec`; the spatial SO-101 is `SO101Spec`."""

from imimic_gym.robots.so101 import GRIPPER_RANGE, JOINT_NAMES, JOINT_RANGES, SO101Spec
from imimic_gym.robots.spec import RobotSpec

__all__ = ["GRIPPER_RANGE", "JOINT_NAMES", "JOINT_RANGES", "RobotSpec", "SO101Spec"]
