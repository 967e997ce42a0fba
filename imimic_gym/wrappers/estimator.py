"""Estimator observation wrappers: add ``obs["estimate"]`` computed from ``obs["frame"]``.

The estimator is an object (any `Estimator`: DON, later the CNN and the baselines); the
wrapper only feeds it frames, so the env knows nothing about estimators and estimators
know nothing about the env.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from imimic_gym.estimators.don import DON
from imimic_gym.estimators.types import Estimate, Estimator

__all__ = ["DONObservation", "EstimatorObservation", "TruthObservation", "estimate_fields"]

# Bounds of the estimate vector, so the space is finite (checkers warn on infinite ones)
# and a wild estimate cannot leave it: angles rad, omega rad/s, alpha rad/s^2, torque N m.
BOUNDS = {"angles": np.pi, "omega": 100.0, "alpha": 10_000.0, "torque": 1_000.0}


def estimate_fields(n: int) -> dict[str, slice]:
    """Where each field of the Estimate sits in ``obs["estimate"]`` for ``n`` joints."""
    fields = {name: slice(i * n, (i + 1) * n) for i, name in enumerate(BOUNDS)}
    fields["trust"], fields["predicted"] = slice(4 * n, 4 * n + 1), slice(4 * n + 1, 4 * n + 2)
    return fields


class EstimatorObservation(gym.ObservationWrapper, gym.utils.RecordConstructorArgs):
    """Adds ``obs["estimate"]``: `Box` (4n + 2,) float32 = angles (rad), omega (rad/s),
    alpha (rad/s^2), torque (N m), trust eta, predicted (0/1); see `estimate_fields`.
    Values beyond the space's bounds are clipped to them.

    Args:
        env: an env whose observation is a Dict with ``frame`` (H, W, 3) uint8.
        estimator: the `Estimator` to feed; it is reset on every ``env.reset``. An env
            rebuilt from this wrapper's spec shares the same estimator object; build a
            new wrapper (or use `DONObservation`) for a second env.
        keep_frame: False drops ``frame`` from the observation (controllers that do not
            look at pixels train faster without it).
    """

    def __init__(self, env: gym.Env, estimator: Estimator, keep_frame: bool = True) -> None:
        space = env.observation_space
        if not isinstance(space, spaces.Dict) or "frame" not in space.spaces:
            raise TypeError(
                f"EstimatorObservation needs a Dict observation space with a 'frame' key, "
                f"got {space}"
            )
        frame = space["frame"]
        if not (isinstance(frame, spaces.Box) and frame.dtype == np.uint8
                and len(frame.shape) == 3 and frame.shape[2] == 3):
            raise TypeError(f"obs['frame'] must be a Box (H, W, 3) uint8, got {frame}")
        # Recorded so gym.make(env.spec) can rebuild the stack; a subclass that records
        # its own arguments first keeps those (the first record wins).
        gym.utils.RecordConstructorArgs.__init__(self, estimator=estimator, keep_frame=keep_frame)
        gym.ObservationWrapper.__init__(self, env)
        self.estimator, self.keep_frame = estimator, keep_frame
        self.n = int(env.action_space.shape[0])
        low = np.concatenate([np.full(self.n, -b) for b in BOUNDS.values()] + [[0.0, 0.0]])
        self._low, self._high = low.astype(np.float32), (-low).astype(np.float32)
        self._high[-2:] = 1.0
        subspaces = dict(space.spaces)
        if not keep_frame:
            subspaces.pop("frame")
        subspaces["estimate"] = spaces.Box(self._low, self._high, dtype=np.float32)
        self.observation_space = spaces.Dict(subspaces)
        self.last_estimate: Estimate | None = None

    def reset(self, **kwargs: Any) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        self.estimator.reset()
        return super().reset(**kwargs)

    def observation(self, observation: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        self.last_estimate = self.estimator.update(observation["frame"])
        vector = np.clip(self.last_estimate.as_vector(), self._low, self._high)
        out = {k: v for k, v in observation.items() if self.keep_frame or k != "frame"}
        out["estimate"] = vector
        return out


class DONObservation(EstimatorObservation):
    """`EstimatorObservation` with DON, set up from the env: its frame rate, the clip's
    reference direction, the joint's range, and the robot's model for torques.
    ``don_params`` go to `DON` and override these."""

    def __init__(self, env: gym.Env, keep_frame: bool = True, **don_params: Any) -> None:
        gym.utils.RecordConstructorArgs.__init__(self, keep_frame=keep_frame, **don_params)
        inner = env.unwrapped
        if inner.arm.n_links != 1:
            raise ValueError(
                f"DON handles one moving link so far; this env's arm has {inner.arm.n_links}"
            )
        params = {
            "fps": float(inner.clip.fps),
            "reference_direction": float(inner.clip.meta.get("reference_direction", 0.0)),
            "robot": inner.model,
            "joint_range": tuple(inner.arm.joint_ranges[0]),
            **don_params,
        }
        super().__init__(env, DON(**params), keep_frame=keep_frame)


class _TruthReader:
    """The oracle "estimator": the clip's true angles, omega and alpha at the frame the
    env shows, trust 1, torque 0. It reads the env, not the frame: evaluation only."""

    def __init__(self, env: gym.Env) -> None:
        self.env = env.unwrapped

    def reset(self) -> None:
        """Stateless: the env's ``frame_index`` says where the clip is."""

    def update(self, frame: np.ndarray) -> Estimate:
        truth, i = self.env.clip.truth, self.env.frame_index
        return Estimate(angles=truth.angles[i], omega=truth.angular_velocity[i],
                        alpha=truth.angular_acceleration[i],
                        torque=np.zeros(truth.angles.shape[1]), trust=1.0)


class TruthObservation(EstimatorObservation):
    """`EstimatorObservation` with a perfect, zero-latency estimator: the clip's truth.

    The evaluation suite's ``oracle`` estimator, so any controller can be scored on what
    it would do with perfect vision. Truth in an observation: never train a policy on it.
    """

    def __init__(self, env: gym.Env, keep_frame: bool = True) -> None:
        gym.utils.RecordConstructorArgs.__init__(self, keep_frame=keep_frame)
        super().__init__(env, _TruthReader(env), keep_frame=keep_frame)
