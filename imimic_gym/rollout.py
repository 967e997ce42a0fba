"""Run a controller through one episode with a plain Gymnasium loop, and score it."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, cast

import gymnasium as gym
import numpy as np

from imimic_gym.estimators.types import estimate_fields
from imimic_gym.metrics import (
    angle_rmse_deg,
    jerk_rms,
    lag_frames,
    max_error_deg,
    recovery_time_s,
)

__all__ = ["Trajectory", "run_episode"]


@dataclass
class Trajectory:
    """One episode. T frames, n joints; angles in rad, time in s.

    ``frames`` holds ``env.render()`` images (T, H, 2W, 3) uint8 when recorded;
    ``trust`` (T,) the estimator's eta when the observation carries ``estimate``.
    """

    time: np.ndarray
    target: np.ndarray
    robot: np.ndarray
    reward: np.ndarray
    occlusion: np.ndarray
    frames: list[np.ndarray] = field(default_factory=list)
    trust: np.ndarray | None = None

    def metrics(self) -> dict[str, Any]:
        """rmse_deg, max_error_deg, lag_frames, jerk_deg_s3 (robot), recovery_s (None
        without an occlusion that ends), mean_trust (None without an estimate),
        mean_reward, frames."""
        fps = 1.0 / float(self.time[1] - self.time[0]) if len(self.time) > 1 else 1.0
        return {
            "rmse_deg": angle_rmse_deg(self.robot, self.target),
            "max_error_deg": max_error_deg(self.robot, self.target),
            "lag_frames": lag_frames(self.target, self.robot),
            "jerk_deg_s3": jerk_rms(self.robot, fps),
            "recovery_s": recovery_time_s(self.robot, self.target, self.occlusion, fps),
            "mean_trust": float(np.mean(self.trust)) if self.trust is not None else None,
            "mean_reward": float(np.mean(self.reward)) if len(self.reward) else 0.0,
            "frames": len(self.time),
        }


def run_episode(
    env: gym.Env,
    controller: Callable[[dict[str, Any]], np.ndarray],
    seed: int | None = None,
    record: bool = False,
    options: dict[str, Any] | None = None,
) -> Trajectory:
    """``obs, info = env.reset(seed=seed, options=options)``, then step ``controller(obs)``
    to the clip's end. ``record`` keeps ``env.render()`` of every frame.

    The first frame, before any action, is part of the trajectory (reward 0).
    """
    obs, info = env.reset(seed=seed, options=options)
    if hasattr(controller, "reset"):
        controller.reset()
    index, target, robot, reward, occlusion, frames, trust = [], [], [], [], [], [], []
    trust_at = None
    if "estimate" in obs:
        trust_at = estimate_fields(len(obs["qpos"]))["trust"].start

    def log(obs: dict[str, Any], info: dict[str, Any], r: float) -> None:
        index.append(info["frame_index"])
        target.append(info["target_angles"])
        robot.append(obs["qpos"])
        occlusion.append(info["occlusion"])
        reward.append(r)
        if trust_at is not None:
            trust.append(float(obs["estimate"][trust_at]))
        if record:
            frames.append(cast(np.ndarray, env.render()))  # render_mode="rgb_array"

    log(obs, info, 0.0)
    done = False
    while not done:
        obs, r, terminated, truncated, info = env.step(controller(obs))
        log(obs, info, float(r))
        done = terminated or truncated
    return Trajectory(
        time=np.asarray(index) / float(env.metadata["render_fps"]),
        target=np.asarray(target),
        robot=np.asarray(robot),
        reward=np.asarray(reward),
        occlusion=np.asarray(occlusion),
        frames=frames,
        trust=np.asarray(trust) if trust_at is not None else None,
    )
