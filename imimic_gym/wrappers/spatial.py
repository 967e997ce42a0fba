"""The 3-D path's estimator stage: a spatial estimator (an `ArmPose` a frame) read through
the env's retargeter, so that ``obs["estimate"]`` holds the robot's joint targets and every
controller (`controllers`) drives a spatial robot as it drives a planar one.

Data flow: frame -> spatial estimator -> `ArmPose` -> retargeter -> joint targets (rad)
-> `Estimate` (omega, alpha by the shared path estimator) -> controller.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from imimic_gym.estimators.motion import PathEstimator
from imimic_gym.estimators.types import Estimate, SpatialEstimator
from imimic_gym.spatial.arm_pose import ArmPose
from imimic_gym.spatial.draw import draw_side_view

__all__ = ["RetargetedEstimator"]

Retarget = Callable[[ArmPose, "np.ndarray | None"], np.ndarray]


class RetargetedEstimator:
    """An `Estimator` of the robot's joint targets from a `SpatialEstimator`.

    Each frame: the arm's `ArmPose` (``last_pose``), retargeted onto the robot
    continuing the last targets; rates from the shared path estimator (paper layer 4a).
    A frame where the arm is not seen (trust 0) holds the last targets at rest; before the
    first reading the targets are ``start`` (the robot's rest pose) with trust 0.

    Args:
        spatial: the spatial estimator (`estimators.registry.build_spatial_estimator`).
        retarget: ``retarget(pose, previous) -> (n,) rad`` (`retarget.DirectionRetargeter`).
        fps: frames/s, for the rates.
        start: (n,) rad, the targets before the first reading.
    """

    def __init__(self, spatial: SpatialEstimator, retarget: Retarget, fps: float,
                 start: np.ndarray) -> None:
        self.spatial, self.retarget = spatial, retarget
        self.start = np.asarray(start, dtype=np.float64).copy()
        self.path = PathEstimator(len(self.start), fps)
        self.reset()

    def reset(self) -> None:
        self.spatial.reset()
        self.path.reset()
        self.targets: np.ndarray | None = None
        self.last_pose: ArmPose | None = None

    def caption(self) -> str:
        """The last frame's reading in words, for the picture: the elbow's flexion and
        the trust."""
        pose = self.last_pose
        if pose is None:
            return "no reading yet"
        seen = f"elbow {math.degrees(pose.elbow_flexion):.0f} deg" if pose.trust > 0 else \
            "arm not seen: holding"
        return f"{pose.side} arm, {seen}  eta {pose.trust:.2f}"

    def draw(self, picture: np.ndarray) -> np.ndarray:
        """``picture`` (the caller's own, drawn on in place and returned) with this frame's
        reading seen from the person's side (`spatial.draw.draw_side_view`): where the arm
        goes toward or away from the camera; unchanged where the arm is not seen."""
        if self.last_pose is None or self.last_pose.trust == 0.0:
            return picture
        return draw_side_view(picture, self.last_pose, in_place=True)

    def prefetch(self, frame: np.ndarray) -> None:
        """The spatial estimator's ``prefetch`` of ``frame`` (the next frame `update` will
        get, the same array), if it has one; else nothing."""
        prefetch = getattr(self.spatial, "prefetch", None)
        if callable(prefetch):
            prefetch(frame)

    def warm_up(self) -> None:
        """The spatial estimator's ``warm_up``, if it has one; else nothing."""
        warm_up = getattr(self.spatial, "warm_up", None)
        if callable(warm_up):
            warm_up()

    def close(self) -> None:
        """The spatial estimator's ``close``, if it has one (its threads stop)."""
        close = getattr(self.spatial, "close", None)
        if callable(close):
            close()

    def update(self, frame: np.ndarray, depth: np.ndarray | None = None) -> Estimate:
        """The joint targets for the next (H, W, 3) uint8 RGB ``frame`` (``depth``: its
        (H, W) float32 metres, for an estimator that reads depth)."""
        pose = self.spatial.update(frame, depth)
        self.last_pose = pose
        zeros = np.zeros(len(self.start))
        if pose.trust == 0.0:  # nothing drawn: the held pose is not in this frame
            self.path.reset()  # a person who comes back is no velocity spike
            held = self.start if self.targets is None else self.targets
            return Estimate(angles=held, omega=zeros, alpha=zeros, torque=zeros, trust=0.0)
        keypoints = pose.pixels[:4]  # shoulder, elbow, wrist, hand: drawn as a chain
        self.targets = self.retarget(pose, self.targets)
        self.path.update(self.targets)
        return Estimate(angles=self.targets, omega=self.path.omega(), alpha=self.path.alpha(),
                        torque=zeros, trust=pose.trust, keypoints=keypoints)
