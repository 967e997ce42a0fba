"""The 3-D pose estimators (registry names ``pose3d``, ``pose3d-depth``, ``pose-world``):
the pretrained pose model finds a person's keypoints, `pose.ArmChooser` picks the arm
that moves (or the one asked for), and the arm becomes an `ArmPose` in the camera frame
by one of three routes (``source``):

- ``"lift"``: the bone-length lift of the 2-D keypoints (`spatial.lift.ArmLifter`: the
  person's lengths refined over the clip, each bone's toward/away extent from a Bayes
  filter on its 2-D length and the model's depth (`spatial.share_filter.ShareFilter`),
  One Euro smoothing);
- ``"depth"``: the keypoints back-projected through the frame's metric depth image (an
  RGB-D camera), each arm bone kept to the person's length as the depth measures it
  (the median over the clip so far of the frames that measured all three bones within
  0.7-1.4 of an average adult's; the average adult's until there are 5), a bone off by
  more than a quarter solved on its ray as the lift does;
- ``"world"``: the model's own 3-D world landmarks, placed with the shoulder where the
  lift puts it (the baseline).

The lift's and the depth route's elbow flexion is at most an adult elbow's, 150 degrees
(`ArmPose.within_elbow_range`); the world landmarks' is MediaPipe's own.

A frame where the arm is not seen (nobody, or its shoulder, elbow or wrist below
``min_confidence``) returns the last pose held (trust 0); before any reading, the neutral
pose (`spatial.lift.neutral_pose`: a person 2.5 m away on the optical axis, facing the
camera, the arm hanging straight down at their side; trust 0). Never NaN.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Mapping
from typing import Any

import numpy as np

from imimic_gym.estimators.pose.model import KEYPOINTS, BodyKeypoints, PoseModel
from imimic_gym.estimators.pose.planar import ArmChooser
from imimic_gym.spatial.arm_pose import ArmPose
from imimic_gym.spatial.camera import Intrinsics
from imimic_gym.spatial.lift import (
    ArmLifter,
    BoneLengths,
    from_depth,
    from_world_landmarks,
    neutral_pose,
    shoulder_depth,
)

__all__ = ["DEPTH_LENGTH_FRAMES", "SOURCES", "Pose3DEstimator", "arm_keypoints"]

SOURCES = ("lift", "depth", "world")
# The depth route measures the person's arm over this many frames before trusting it.
DEPTH_LENGTH_FRAMES = 5


def arm_keypoints(body: BodyKeypoints, side: str) -> list[int]:
    """Rows of `KEYPOINTS` for ``side``'s arm in `ARM_POINTS` order (shoulder, elbow,
    wrist, hand, other shoulder, hip, other hip)."""
    other = "left" if side == "right" else "right"
    names = (f"{side}_shoulder", f"{side}_elbow", f"{side}_wrist", f"{side}_hand",
             f"{other}_shoulder", f"{side}_hip", f"{other}_hip")
    return [KEYPOINTS.index(name) for name in names]


class Pose3DEstimator:
    """A person's arm in 3-D from the pose model (module docstring).

    Args:
        fps: the video's frame rate, frames/s (the step between frames).
        intrinsics: the camera's, for any frame size (scaled to the frames'); None: a
            typical webcam's (`Intrinsics.guess`) for the frames' size.
        arm: "auto" (the arm that moves), "left" or "right".
        min_confidence: a reading whose shoulder, elbow or wrist is less confident than
            this is not used (the last pose held, trust 0).
        source: "lift", "depth" or "world" (module docstring).
        model: a `PoseModel` to use (None: a new one, in video mode).
        lift: keyword arguments for the lift's `spatial.lift.ArmLifter` (its smoothing,
            share filter, length quantile) over its defaults.
    """

    def __init__(self, fps: float = 30.0, intrinsics: Intrinsics | None = None,
                 arm: str = "auto", min_confidence: float = 0.5, source: str = "lift",
                 model: PoseModel | None = None, lift: Mapping[str, Any] | None = None
                 ) -> None:
        if not (math.isfinite(fps) and fps > 0):
            raise ValueError(f"fps must be a positive number, got {fps!r}")
        if not 0.0 <= min_confidence <= 1.0:
            raise ValueError(f"min_confidence must be in [0, 1], got {min_confidence!r}")
        if source not in SOURCES:
            raise ValueError(f"source must be one of {SOURCES}, got {source!r}")
        self.fps, self.intrinsics, self.arm = float(fps), intrinsics, arm
        self.min_confidence, self.source = min_confidence, source
        self.lift = dict(lift or {})
        self.chooser = ArmChooser(fps, arm, min_confidence=min_confidence)
        self.model = model if model is not None else PoseModel(video=True)
        self.lifter: ArmLifter | None = None
        self.reset()

    def reset(self) -> None:
        self.model.reset()
        self.chooser.reset()
        if self.lifter is not None:
            self.lifter.reset()
        self.last: ArmPose | None = None
        self.reads = 0
        self.depth_lengths: deque[np.ndarray] = deque(maxlen=3000)  # metres, per frame

    def _camera(self, width: int, height: int) -> Intrinsics:
        """The intrinsics for frames of this size (the lifter follows a new size)."""
        camera = (Intrinsics.guess(width, height) if self.intrinsics is None
                  else self.intrinsics if (self.intrinsics.width, self.intrinsics.height)
                  == (width, height) else self.intrinsics.scaled(width, height))
        if self.lifter is None or self.lifter.intrinsics != camera:
            self.lifter = ArmLifter(camera, self.fps, **self.lift)
        return camera

    def prefetch(self, frame: np.ndarray) -> None:
        """Start the pose model on ``frame``, the frame after those given to `update` (or
        here) so far, on the model's thread (`PoseModel.submit`), while the caller works;
        `update` of that same array then takes its reading."""
        self.model.submit(frame, (self.reads + self.model.pending) / self.fps)

    def warm_up(self) -> None:
        """The pose model's first reading done now, on a blank frame (`PoseModel.warm_up`):
        the first frame then reads at full speed; the readings are unchanged."""
        self.model.warm_up()

    def close(self) -> None:
        """Stop the pose model (`PoseModel.close`); a later frame starts it again."""
        self.model.close()

    def update(self, frame: np.ndarray, depth: np.ndarray | None = None) -> ArmPose:
        """The arm in the next (H, W, 3) uint8 RGB ``frame``; ``depth``: its (H, W) float32
        depth image, metres along the camera's axis (0 where unmeasured), which the
        ``"depth"`` source needs and the others ignore."""
        if self.source == "depth" and depth is None:
            raise ValueError("Pose3DEstimator(source='depth') needs each frame's depth "
                             "image; got None")
        height, width = frame.shape[:2]
        camera = self._camera(width, height)
        time_s = self.reads / self.fps
        self.reads += 1
        body = self.model(frame, time_s)
        pose = None if body is None else self._read(body, camera, depth, time_s)
        if pose is None:
            if self.last is not None:
                return self.last.held()
            side = self.arm if self.arm != "auto" else (self.chooser.side or "right")
            return neutral_pose(side, camera)
        self.last = pose
        return pose

    def _read(self, body: BodyKeypoints, camera: Intrinsics, depth: np.ndarray | None,
              time_s: float) -> ArmPose | None:
        side = self.chooser(body, time_s)
        rows = arm_keypoints(body, side)
        pixels, confidence = body.points[rows], body.confidence[rows]
        if confidence[:3].min() < self.min_confidence:
            return None
        model_depth = None if body.depth is None else body.depth[rows] * camera.width
        assert self.lifter is not None  # made by _camera
        if self.source == "depth":
            assert depth is not None  # checked in update
            return self._from_depth(side, pixels, confidence, np.asarray(depth, float),
                                    camera).within_elbow_range()
        if self.source == "world":
            if body.world is None:
                return None
            z0 = shoulder_depth(pixels, confidence, camera, self.lifter.prior)
            return from_world_landmarks(side, body.world[rows], pixels, confidence, camera,
                                        depth_of_shoulder=z0)
        return self.lifter(side, pixels, confidence, model_depth, time_s).within_elbow_range()

    def _from_depth(self, side: str, pixels: np.ndarray, confidence: np.ndarray,
                    depth: np.ndarray, camera: Intrinsics) -> ArmPose:
        measured = from_depth(side, pixels, confidence, depth, camera)
        prior = BoneLengths().arm
        plausible = ((measured.bone_lengths > 0.7 * prior)
                     & (measured.bone_lengths < 1.4 * prior)).all()
        if (measured.confidence[:4] > 0).all() and plausible:
            self.depth_lengths.append(measured.bone_lengths)
        lengths = (np.median(np.array(self.depth_lengths), axis=0)
                   if len(self.depth_lengths) >= DEPTH_LENGTH_FRAMES else prior)
        return from_depth(side, pixels, confidence, depth, camera, lengths=lengths)
