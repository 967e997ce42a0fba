"""Shared by every estimator: the path estimator (paper §3, layer 4a) and joint torques.

An estimator measures a joint angle per frame; this turns the series into angular
velocity and acceleration, and those into the torque the robot needs.
"""

from __future__ import annotations

import math
import operator
from collections import deque
from collections.abc import Sequence

import mujoco
import numpy as np

from imimic_gym.kinematics import wrap_angle
from imimic_gym.robots.planar import joint_inertia

__all__ = ["PathEstimator", "TorqueModel"]


class PathEstimator:
    """DON layer 4a, path estimator, paper Eq. (velAcc): v_p = s_p - s_{p-1}, a_p = v_p - v_{p-1}.

    The location s_p of the link is its angle about the pivot (rad). The paper divides the
    tip's displacement by the skeleton length r to get omega = v / r; the tangential
    displacement at radius r is r * d(angle), so the wrapped angle difference is the same
    quantity without the small-angle error. Per frame, times fps (fps^2) gives rad/s
    (rad/s^2).

    Keeps the last ``window`` samples of V and A (the sets the prediction layer merges),
    each a tuple of n floats. Python floats, not numpy arrays: this runs every frame on one
    to three angles, where numpy's cost per call is ten times the arithmetic; the
    arithmetic is the same (`wrap_angle` of a float is the array's to the bit).
    """

    def __init__(self, n_joints: int, fps: float, window: int = 10) -> None:
        if isinstance(fps, bool) or not isinstance(fps, (int, float, np.number)) \
                or not math.isfinite(fps) or fps <= 0:
            raise ValueError(f"fps must be a positive, finite number of frames per second, "
                             f"got {fps!r}")
        self.n, self.fps, self.window = n_joints, float(fps), window
        self.reset()

    def reset(self) -> None:
        self.location: tuple[float, ...] | None = None
        self.V: deque[tuple[float, ...]] = deque(maxlen=self.window)
        self.A: deque[tuple[float, ...]] = deque(maxlen=self.window)

    def update(self, location: Sequence[float] | np.ndarray
               ) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """Add this frame's location (n angles, rad); return (v, a) per frame,
        rad/frame(^2), n each."""
        location = tuple(map(float, location))
        if len(location) != self.n:
            raise ValueError(f"PathEstimator tracks {self.n} angles, got {len(location)}")
        if self.location is None:
            v = (0.0,) * self.n
        else:
            v = tuple(map(_wrapped_difference, location, self.location))
        a = tuple(map(operator.sub, v, self.V[-1])) if self.V else (0.0,) * self.n
        self.location = location
        self.V.append(v)
        self.A.append(a)
        return v, a

    def correct(self, location: Sequence[float] | np.ndarray
                ) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """Replace the newest location with a better reading of the same frame (n angles,
        rad); its v and a follow. Returns them, as `update` does."""
        if self.location is None:
            return self.update(location)
        newest = self.V.pop()
        self.A.pop()
        # The location before the newest, if the newest was not the first after a reset.
        self.location = tuple(map(operator.sub, self.location, newest)) if self.V else None
        return self.update(location)

    def omega(self) -> np.ndarray:
        """Angular velocity (n,), rad/s: the mean of the last two v, centred on the frame."""
        return _mean_of_last(self.V, 2, self.n, self.fps)

    def alpha(self) -> np.ndarray:
        """Angular acceleration (n,), rad/s^2: the mean of the last three a."""
        return _mean_of_last(self.A, 3, self.n, self.fps**2)


def _mean_of_last(values: deque[tuple[float, ...]], k: int, n: int, scale: float
                  ) -> np.ndarray:
    """Mean of the last ``k`` n-tuples of ``values`` (newest first in the sum), times
    ``scale``: (n,); zeros if there are none."""
    k = min(k, len(values))
    if k == 0:
        return np.zeros(n)
    total = values[-1]
    for i in range(2, k + 1):
        total = tuple(map(operator.add, total, values[-i]))
    return np.array([t / k * scale for t in total])


def _wrapped_difference(angle: float, last: float) -> float:
    return wrap_angle(angle - last)


class TorqueModel:
    """Torque (N m) the robot needs for a motion: the paper's tau = I alpha for one link,
    with I the joint's inertia from the robot's MuJoCo model; the model's inverse dynamics
    (``mj_inverse``, so coupling, gravity and damping count) for two or more links."""

    def __init__(self, model: mujoco.MjModel) -> None:
        self.model = model
        self.data = mujoco.MjData(model)
        self.inertia = joint_inertia(model)

    def __call__(self, angles: np.ndarray, omega: np.ndarray, alpha: np.ndarray) -> np.ndarray:
        if self.model.nv == 1:
            return self.inertia * alpha
        self.data.qpos[:], self.data.qvel[:], self.data.qacc[:] = angles, omega, alpha
        mujoco.mj_inverse(self.model, self.data)
        return self.data.qfrc_inverse.copy()
