"""Run a controller through one episode with a plain Gymnasium loop, and score it."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np

from imimic_gym.metrics import angle_rmse_deg, lag_frames, max_error_deg

__all__ = ["Trajectory", "run_episode"]


@dataclass
class Trajectory:
    """One episode. T frames, n joints; angles in rad, time in s.

    ``frames`` holds ``env.render()`` images (T, H, 2W, 3) uint8 when recorded.
    """

    time: np.ndarray
    target: np.ndarray
    robot: np.ndarray
    reward: np.ndarray
    occlusion: np.ndarray
    frames: list[np.ndarray] = field(default_factory=list)

    def metrics(self) -> dict[str, Any]:
        return {
            "rmse_deg": angle_rmse_deg(self.robot, self.target),
            "max_error_deg": max_error_deg(self.robot, self.target),
            "lag_frames": lag_frames(self.target, self.robot),
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
    index, target, robot, reward, occlusion, frames = [], [], [], [], [], []

    def log(obs: dict[str, Any], info: dict[str, Any], r: float) -> None:
        index.append(info["frame_index"])
        target.append(info["target_angles"])
        robot.append(obs["qpos"])
        occlusion.append(info["occlusion"])
        reward.append(r)
        if record:
            frames.append(env.render())

    log(obs, info, 0.0)
    done = False
    while not done:
        obs, r, terminated, truncated, info = env.step(controller(obs))
        log(obs, info, float(r))
        done = terminated or truncated
    return Trajectory(
        time=np.asarray(index) / float(env.unwrapped.clip.fps),
        target=np.asarray(target),
        robot=np.asarray(robot),
        reward=np.asarray(reward),
        occlusion=np.asarray(occlusion),
        frames=frames,
    )
