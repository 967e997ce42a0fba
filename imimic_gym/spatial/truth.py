"""`ArmPose` from a rendered clip's 3-D truth (`clips.types.ClipTruth.points3d`)."""

from __future__ import annotations

import numpy as np

from imimic_gym.clips.types import Clip
from imimic_gym.spatial.arm_pose import ARM_POINTS, ArmPose
from imimic_gym.spatial.camera import Intrinsics

__all__ = ["arm_poses", "clip_intrinsics"]


def clip_intrinsics(clip: Clip) -> Intrinsics:
    """The camera of a clip with 3-D truth (``meta["intrinsics"]``)."""
    if "intrinsics" not in clip.meta:
        raise ValueError(f"clip {clip.meta.get('scenario', '?')!r} states no camera "
                         "intrinsics (only spatial clips do)")
    return Intrinsics(**clip.meta["intrinsics"])


def arm_poses(clip: Clip) -> list[ArmPose]:
    """One `ArmPose` per frame from the clip's truth: its points and pixels, confidence 1
    and trust 1 throughout, the side ``meta["arm_side"]``."""
    truth = clip.truth
    if truth is None or truth.points3d is None or truth.points2d is None:
        raise ValueError(f"clip {clip.meta.get('scenario', '?')!r} has no 3-D truth; "
                         "only a spatial arm's clips (a gesture) do")
    side = str(clip.meta["arm_side"])
    confidence = np.ones(len(ARM_POINTS))
    return [ArmPose(side, points, confidence, pixels, trust=1.0)
            for points, pixels in zip(truth.points3d, truth.points2d, strict=True)]
