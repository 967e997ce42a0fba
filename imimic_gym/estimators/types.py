"""`Estimate` and the `Estimator` protocol: what every vision estimator produces."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np

__all__ = ["Estimate", "Estimator"]


@dataclass(frozen=True)
class Estimate:
    """One frame's estimate of the demonstrator's arm. n joints.

    Attributes:
        angles: (n,) joint angles, rad (DESIGN.md convention).
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
        """(4n + 2,) float32: angles, omega, alpha, torque, trust, predicted."""
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
