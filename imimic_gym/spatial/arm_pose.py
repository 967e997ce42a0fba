"""`ArmPose`: one frame's human arm in 3-D, the one type the 3-D path speaks (the clip's
truth, the pose model's lifts, depth back-projection; retargeting and the 3-D metrics read
it).

Frames:
- **Camera frame**: metres, x right, y down, z away from the camera (`spatial.camera`).
- **Arm frame** of the followed arm: rows (forward, outward, up), unit vectors in the
  camera frame (`ArmPose.arm_frame`). ``up`` runs from the hips' middle to the shoulders'
  middle, ``outward`` from the other shoulder to this arm's shoulder (made perpendicular
  to up), ``forward`` the way the chest faces. A left arm's coordinates in its arm frame
  equal those of a right arm mirrored through the body's middle plane, so everything
  downstream (retargeting, metrics) treats both arms alike.

Angles: ``elbow_flexion`` is the angle between the upper arm and the forearm, 0 with the
arm straight, rad.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from imimic_gym.kinematics import keypoints_to_angles

__all__ = ["ARM_POINTS", "MAX_ELBOW_FLEXION", "SIDES", "ArmPose", "angle_between", "unit"]

# The points an ArmPose holds, in this order. "hand" is the hand's far end (the index
# finger's knuckle on the pose model); "other_*" are the other side's.
ARM_POINTS = ("shoulder", "elbow", "wrist", "hand", "other_shoulder", "hip", "other_hip")
SIDES = ("left", "right")
_S, _E, _W, _H, _OS, _HIP, _OHIP = range(len(ARM_POINTS))
# An adult elbow's active flexion: 0 to 150 degrees (the AAOS's range, as the rendered
# demonstrator's; rad). `ArmPose.within_elbow_range` reads an estimate down to it.
MAX_ELBOW_FLEXION = math.radians(150.0)
# Below this confidence a hip does not set the torso's up (the camera's up is used).
HIP_CONFIDENCE = 0.5
_CAMERA_UP = np.array([0.0, -1.0, 0.0])


def unit(v: np.ndarray) -> np.ndarray:
    """``v`` (..., 3) scaled to length 1 (a zero vector stays zero, never NaN)."""
    v = np.asarray(v, dtype=np.float64)
    norm = np.linalg.norm(v, axis=-1, keepdims=True)
    return np.divide(v, norm, out=np.zeros_like(v), where=norm > 1e-12)


def angle_between(a: np.ndarray, b: np.ndarray) -> np.ndarray | float:
    """Angle (rad, in [0, pi]) between direction vectors ``a`` and ``b`` (..., 3), by
    atan2 of the cross and dot products (accurate near 0 and pi, unlike arccos)."""
    a, b = unit(a), unit(b)
    cross = np.linalg.norm(np.cross(a, b), axis=-1)
    angle = np.arctan2(cross, np.sum(a * b, axis=-1))
    return float(angle) if np.ndim(angle) == 0 else angle


@dataclass(frozen=True)
class ArmPose:
    """One frame's arm, in the camera frame.

    Attributes:
        side: "left" or "right", the person's own.
        points: (7, 3) float64 metres in the camera frame, `ARM_POINTS` order.
        confidence: (7,) float64 in [0, 1], one per point (1 for truth).
        pixels: (7, 2) float64 image pixels (x, y) the points project to or came from.
        trust: in [0, 1]; 0 where the arm was not seen and ``points`` are the last seen
            pose, held (a robot copying it holds too).
        flexion: rad in [0, pi], the elbow's flexion where an estimate's is not the angle
            between its upper arm and forearm (a lift unsure which way the forearm
            tilts gives the flexion's expectation over the tilts, while its points lie
            between them); None: that angle.
    """

    side: str
    points: np.ndarray
    confidence: np.ndarray
    pixels: np.ndarray
    trust: float = 1.0
    flexion: float | None = None

    def __post_init__(self) -> None:
        k = len(ARM_POINTS)
        if self.side not in SIDES:
            raise ValueError(f"ArmPose.side must be 'left' or 'right', got {self.side!r}")
        for name, shape in (("points", (k, 3)), ("confidence", (k,)), ("pixels", (k, 2))):
            value = np.asarray(getattr(self, name), dtype=np.float64)
            if value.shape != shape or not np.isfinite(value).all():
                raise ValueError(f"ArmPose.{name} must be finite with shape {shape}, got "
                                 f"{value.shape}")
            object.__setattr__(self, name, value)
        if not 0.0 <= self.trust <= 1.0:
            raise ValueError(f"ArmPose.trust must be in [0, 1], got {self.trust!r}")
        if self.flexion is not None and not 0.0 <= self.flexion <= math.pi:
            raise ValueError(f"ArmPose.flexion must be None or in [0, pi] rad, got "
                             f"{self.flexion!r}")

    def point(self, name: str) -> np.ndarray:
        """(3,) camera-frame metres of ``name`` (one of `ARM_POINTS`)."""
        return self.points[ARM_POINTS.index(name)]

    @property
    def upper_arm(self) -> np.ndarray:
        """(3,) unit direction shoulder -> elbow, camera frame."""
        return unit(self.points[_E] - self.points[_S])

    @property
    def forearm(self) -> np.ndarray:
        """(3,) unit direction elbow -> wrist, camera frame."""
        return unit(self.points[_W] - self.points[_E])

    @property
    def hand(self) -> np.ndarray:
        """(3,) unit direction wrist -> hand, camera frame."""
        return unit(self.points[_H] - self.points[_W])

    @property
    def elbow_flexion(self) -> float:
        """Rad in [0, pi]: 0 with the arm straight (``flexion`` where given, else the
        angle between `upper_arm` and `forearm`)."""
        if self.flexion is not None:
            return self.flexion
        return float(angle_between(self.upper_arm, self.forearm))

    def within_elbow_range(self) -> ArmPose:
        """This pose with its `elbow_flexion` at most `MAX_ELBOW_FLEXION`: an estimate
        that reads an elbow bent further than an elbow bends (the pose model's keypoints
        of a full curl put the wrist on the shoulder) reads it as bent as it can be. The
        points are kept; only ``flexion`` is set."""
        if self.elbow_flexion <= MAX_ELBOW_FLEXION:
            return self
        return replace(self, flexion=MAX_ELBOW_FLEXION)

    @property
    def wrist_flexion(self) -> float:
        """Rad in [0, pi] between the forearm and the hand: 0 with the wrist straight."""
        return float(angle_between(self.forearm, self.hand))

    @property
    def bone_lengths(self) -> np.ndarray:
        """(3,) metres: upper arm, forearm, wrist to hand."""
        return np.linalg.norm(np.diff(self.points[[_S, _E, _W, _H]], axis=0), axis=1)

    def arm_frame(self) -> np.ndarray:
        """(3, 3) rows forward, outward, up: the arm frame (module docstring) as unit
        vectors in the camera frame. Without confident hips, up is the camera's up made
        perpendicular to the shoulders' line."""
        outward = self.points[_S] - self.points[_OS]
        hips_seen = min(self.confidence[_HIP], self.confidence[_OHIP]) >= HIP_CONFIDENCE
        up = (0.5 * (self.points[_S] + self.points[_OS])
              - 0.5 * (self.points[_HIP] + self.points[_OHIP])) if hips_seen else _CAMERA_UP
        outward_unit = unit(outward)
        if not outward_unit.any():  # shoulders on top of each other: no body width seen
            outward_unit = np.array([-1.0 if self.side == "right" else 1.0, 0.0, 0.0])
        up = unit(up - np.dot(up, outward_unit) * outward_unit)
        if not up.any():
            up = unit(_CAMERA_UP - np.dot(_CAMERA_UP, outward_unit) * outward_unit)
        forward = np.cross(up, outward_unit) if self.side == "right" else np.cross(outward_unit,
                                                                                   up)
        return np.stack([forward, outward_unit, up])

    def in_arm_frame(self, direction: np.ndarray) -> np.ndarray:
        """(..., 3) camera-frame directions as (forward, outward, up) coordinates."""
        return np.asarray(direction, dtype=np.float64) @ self.arm_frame().T

    def to_planar(self, n_links: int, reference_direction: float = -math.pi / 2
                  ) -> np.ndarray:
        """The planar joint angles (`kinematics.keypoints_to_angles`) of this arm's
        pixels: (n_links,) rad, so the 2-D estimators and robots read it unchanged."""
        return keypoints_to_angles(self.pixels[[_S, _E, _W]], n_links, reference_direction)

    def held(self) -> ArmPose:
        """This pose with trust 0: a frame that did not see the arm holds the last one."""
        return ArmPose(self.side, self.points, self.confidence, self.pixels, trust=0.0,
                       flexion=self.flexion)
