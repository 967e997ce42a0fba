"""The arm in 3-D: `ArmPose` (one frame's human arm, camera frame), the camera
(`Intrinsics`), and the lifts that make an `ArmPose` from 2-D keypoints."""

from imimic_gym.spatial.arm_pose import ARM_POINTS, ArmPose, angle_between, unit
from imimic_gym.spatial.camera import Intrinsics

__all__ = ["ARM_POINTS", "ArmPose", "Intrinsics", "angle_between", "unit"]
