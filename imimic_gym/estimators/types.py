"""What every vision estimator produces (`Estimate`, laid out as a vector by
`estimate_fields`), what it is (`Estimator`; `SpatialEstimator` for those that read the
arm in 3-D), and what it may know about the clip and the robot (`EstimatorContext`,
published by the env)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

if TYPE_CHECKING:
    from imimic_gym.spatial.arm_pose import ArmPose
    from imimic_gym.spatial.camera import Intrinsics

__all__ = ["ESTIMATE_BOUNDS", "Estimate", "Estimator", "EstimatorContext", "SpatialEstimator",
           "estimate_fields"]

# Bounds of the estimate vector, so an observation space is finite (checkers warn on
# infinite ones) and a wild estimate cannot leave it: angles rad, omega rad/s, alpha
# rad/s^2, torque N m.
ESTIMATE_BOUNDS = {"angles": math.pi, "omega": 100.0, "alpha": 10_000.0, "torque": 1_000.0}


def estimate_fields(n: int) -> dict[str, slice]:
    """Where each field of `Estimate.as_vector` sits for ``n`` joints: ``angles``,
    ``omega``, ``alpha``, ``torque`` (n each), ``trust`` and ``predicted`` (1 each)."""
    fields = {name: slice(i * n, (i + 1) * n) for i, name in enumerate(ESTIMATE_BOUNDS)}
    fields["trust"], fields["predicted"] = slice(4 * n, 4 * n + 1), slice(4 * n + 1, 4 * n + 2)
    return fields


@dataclass(frozen=True)
class Estimate:
    """One frame's estimate of the demonstrator's arm. n joints.

    Attributes:
        angles: (n,) joint angles, rad: link 1 from the reference direction, link i from
            its parent link, counter-clockwise in the image positive (`imimic_gym.robots.planar`).
        omega: (n,) angular velocities, rad/s.
        alpha: (n,) angular accelerations, rad/s^2.
        torque: (n,) joint torques the robot needs for this motion, N m.
        trust: the trust factor eta in [0, 1] (1 = nothing to distrust). 0 also before
            the estimator has read anything: the angles are then a placeholder.
        predicted: True when the prediction layer, not the current frame, gave the angles.
        keypoints: (n + 1, 2) pixel coordinates (x, y) of the pivot and link ends, or None.
    """

    angles: np.ndarray
    omega: np.ndarray
    alpha: np.ndarray
    torque: np.ndarray
    trust: float
    predicted: bool = False
    keypoints: np.ndarray | None = None

    def __post_init__(self) -> None:
        n = np.shape(self.angles)
        for name in ("angles", "omega", "alpha", "torque"):
            value = getattr(self, name)
            if type(value) is not np.ndarray or value.dtype != np.float64:
                value = np.asarray(value, dtype=np.float64)
                object.__setattr__(self, name, value)
            # math.isfinite over a few joints: numpy's per-call cost is most of a frame's
            # bookkeeping here.
            if value.shape != n or not all(map(math.isfinite, value.ravel().tolist())):
                raise ValueError(f"Estimate.{name} must be finite with shape {n}, got {value}")
        if not 0.0 <= self.trust <= 1.0:
            raise ValueError(f"Estimate.trust must be in [0, 1], got {self.trust}")

    def as_vector(self) -> np.ndarray:
        """(4n + 2,) float32: angles, omega, alpha, torque, trust, predicted, laid out as
        `estimate_fields` says."""
        return np.concatenate([
            self.angles, self.omega, self.alpha, self.torque,
            [self.trust, float(self.predicted)],
        ]).astype(np.float32)


class Estimator(Protocol):
    """Turns a stream of frames into estimates. Knows nothing about environments."""

    def reset(self) -> None:
        """Forget all frames: the next ``update`` starts a new clip."""

    def update(self, frame: np.ndarray) -> Estimate:
        """Take the next (H, W, 3) uint8 RGB frame and return the estimate for it."""


class SpatialEstimator(Protocol):
    """Turns a stream of frames (and, from an RGB-D camera, depth images) into the arm in
    3-D. Knows nothing about environments."""

    def reset(self) -> None:
        """Forget all frames: the next ``update`` starts a new clip."""

    def update(self, frame: np.ndarray, depth: np.ndarray | None = None) -> ArmPose:
        """Take the next (H, W, 3) uint8 RGB frame (and its (H, W) float32 depth in
        metres, or None) and return the arm's `ArmPose` for it (camera frame)."""


@dataclass(frozen=True)
class EstimatorContext:
    """What an estimator may know about a clip and the robot copying it: the seam between
    the env (`ImitateVideoEnv.estimator_context`) and the estimators, which never see the
    env itself.

    Attributes:
        fps: the clip's frame rate, frames/s.
        link_parents: (n,) each moving link's parent link, -1 for the root pivot.
        joint_ranges: n (low, high) joint limits, rad (the `Estimate.angles` convention).
        reference_direction: image direction of the fixed reference link, rad
            counter-clockwise from image right.
        modality: ``"rgb"`` or ``"depth"`` (the depth video as grey frames, near = bright).
        demonstrator: ``"human"``, ``"servo"`` or ``"hand"``; ``"human"`` for real footage.
        robot: the robot's ``mujoco.MjModel``, for torques; None gives zero torque.
        truth: a no-argument callable giving the true `Estimate` of the frame the env
            shows now (the oracle's only input; evaluation only), or None without truth.
        spatial: the clip's arm moves in space and its reader wants an `ArmPose` per
            frame (`SpatialEstimator`); False: planar joint angles (`Estimator`).
        intrinsics: the camera's `spatial.camera.Intrinsics` at the frames' size, or None
            where unknown (3-D estimators then guess a typical camera's).
    """

    fps: float
    link_parents: tuple[int, ...]
    joint_ranges: tuple[tuple[float, float], ...]
    reference_direction: float
    modality: str = "rgb"
    demonstrator: str = "human"
    robot: Any = None
    truth: Callable[[], Estimate] | None = None
    spatial: bool = False
    intrinsics: Intrinsics | None = None

    def __post_init__(self) -> None:
        if not (math.isfinite(self.fps) and self.fps > 0):
            raise ValueError(f"EstimatorContext.fps must be a positive number, got {self.fps!r}")
        if len(self.joint_ranges) != len(self.link_parents):
            raise ValueError(f"EstimatorContext has {len(self.link_parents)} links but "
                             f"{len(self.joint_ranges)} joint ranges")

    @property
    def n_links(self) -> int:
        return len(self.link_parents)
