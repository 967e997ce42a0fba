"""The episode loop (a plain Gymnasium loop with observers), its trajectory, its scores."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol, cast

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

__all__ = ["Observer", "Step", "Trajectory", "TrajectoryLog", "episode", "run_episode"]


@dataclass
class Trajectory:
    """One episode. T frames, n joints; angles in rad, time in s.

    ``frames`` holds ``env.render()`` images (T, H, 2W, 3) uint8 when recorded;
    ``trust`` (T,) the estimator's eta when the observation carries ``estimate``.
    ``target`` is NaN on the frames without truth (``info["has_truth"]`` False: a video
    frame without a label, or a clip without truth), which the metrics leave out.
    """

    time: np.ndarray
    target: np.ndarray
    robot: np.ndarray
    reward: np.ndarray
    occlusion: np.ndarray
    frames: list[np.ndarray] = field(default_factory=list)
    trust: np.ndarray | None = None

    @property
    def has_truth(self) -> np.ndarray:
        """(T,) bool: the frames whose target is known."""
        target = np.asarray(self.target, dtype=np.float64)
        return np.asarray(np.isfinite(target.reshape(len(target), -1)).all(axis=1), dtype=bool)

    def metrics(self) -> dict[str, Any]:
        """rmse_deg, max_error_deg (over the frames with truth; None without any),
        lag_frames, jerk_deg_s3 (robot), recovery_s (None without an occlusion that
        ends), mean_trust (None without an estimate), mean_reward, frames, and
        truth_frames (the frames the errors are over)."""
        fps = 1.0 / float(self.time[1] - self.time[0]) if len(self.time) > 1 else 1.0
        known = self.has_truth
        scored = known.any()
        return {
            "rmse_deg": angle_rmse_deg(self.robot[known], self.target[known]) if scored
            else None,
            "max_error_deg": max_error_deg(self.robot[known], self.target[known]) if scored
            else None,
            "lag_frames": lag_frames(self.target, self.robot),
            "jerk_deg_s3": jerk_rms(self.robot, fps),
            "recovery_s": recovery_time_s(self.robot, self.target, self.occlusion, fps),
            "mean_trust": float(np.mean(self.trust)) if self.trust is not None else None,
            "mean_reward": float(np.mean(self.reward)) if len(self.reward) else 0.0,
            "frames": len(self.time),
            "truth_frames": int(known.sum()),
        }


@dataclass
class Step:
    """One frame of an episode, after the controller has answered it. ``reward`` is the
    reward of the step that produced ``obs`` (0 for the reset's observation); ``action``
    is the controller's answer to ``obs``; ``asked`` is `time.perf_counter()` when the
    loop asked the env for this frame (reset or step)."""

    obs: dict[str, Any]
    info: dict[str, Any]
    reward: float
    action: np.ndarray
    asked: float


class Observer(Protocol):
    """Something that watches an episode (`episode`): logs, files, a servo, a display."""

    def on_step(self, env: gym.Env, step: Step) -> None: ...


def episode(env: gym.Env, controller: Callable[[dict[str, Any]], np.ndarray],
            seed: int | None = None, options: dict[str, Any] | None = None,
            observers: Sequence[Observer] = (), realtime: bool = False) -> Iterator[Step]:
    """The episode loop: ``obs, info = env.reset(seed=seed, options=options)``, then, for
    each frame, ``action = controller(obs)``, every observer's ``on_step``, the `Step`
    yielded, and ``env.step(action)``, to the clip's end (or the end of a streamed clip).

    ``realtime`` waits until frame i's time (i / fps after the first) before asking for
    it, so a file plays at its own speed. The controller answers the last frame too (its
    action is not stepped). Every loop of the package runs this one.
    """
    from imimic_gym.clips.video import StreamEndedError

    asked = time.perf_counter()
    obs, info = env.reset(seed=seed, options=options)
    if hasattr(controller, "reset"):
        controller.reset()
    fps, first = float(env.metadata["render_fps"]), time.perf_counter()
    reward, done = 0.0, False
    while True:
        step = Step(obs, info, reward, controller(obs), asked)
        for observer in observers:
            observer.on_step(env, step)
        yield step
        if done:
            return
        if realtime:
            time.sleep(max(0.0, first + (info["frame_index"] + 1) / fps - time.perf_counter()))
        asked = time.perf_counter()
        try:
            obs, r, terminated, truncated, info = env.step(step.action)
        except StreamEndedError:
            return
        reward, done = float(r), terminated or truncated


class TrajectoryLog:
    """Observer: the episode as a `Trajectory` (``record``: with ``env.render()`` of
    every frame)."""

    def __init__(self, record: bool = False, fps: float = 1.0) -> None:
        self.record, self.fps = record, fps
        self.index: list[int] = []
        self.target: list[np.ndarray] = []
        self.robot: list[np.ndarray] = []
        self.reward: list[float] = []
        self.occlusion: list[float] = []
        self.trust: list[float] = []
        self.frames: list[np.ndarray] = []
        self._trust_at: int | None = None

    def on_step(self, env: gym.Env, step: Step) -> None:
        self.fps = float(env.metadata["render_fps"])
        self.add(step)
        if self.record:
            self.frames.append(cast(np.ndarray, env.render()))  # render_mode="rgb_array"

    def add(self, step: Step) -> None:
        """Log one frame (a vector env's loop logs each sub-env's frames this way)."""
        obs, info = step.obs, step.info
        self.index.append(info["frame_index"])
        # A frame without truth has no target: NaN, which the metrics leave out.
        self.target.append(info["target_angles"] if info.get("has_truth", True)
                           else np.full(len(obs["qpos"]), np.nan))
        self.robot.append(obs["qpos"])
        self.occlusion.append(info["occlusion"])
        self.reward.append(step.reward)
        if "estimate" in obs:
            if self._trust_at is None:  # the estimate's layout is fixed for the episode
                self._trust_at = estimate_fields(len(obs["qpos"]))["trust"].start
            self.trust.append(float(obs["estimate"][self._trust_at]))

    def trajectory(self) -> Trajectory:
        return Trajectory(
            time=np.asarray(self.index) / self.fps,
            target=np.asarray(self.target),
            robot=np.asarray(self.robot),
            reward=np.asarray(self.reward),
            occlusion=np.asarray(self.occlusion),
            frames=self.frames,
            trust=np.asarray(self.trust) if self.trust else None,
        )


def run_episode(
    env: gym.Env,
    controller: Callable[[dict[str, Any]], np.ndarray],
    seed: int | None = None,
    record: bool = False,
    options: dict[str, Any] | None = None,
    observers: Sequence[Observer] = (),
) -> Trajectory:
    """The `episode` loop to the clip's end, as a `Trajectory`; ``record`` keeps
    ``env.render()`` of every frame; ``observers`` watch it too.

    The first frame, before any action, is part of the trajectory (reward 0).
    """
    log = TrajectoryLog(record)
    for _ in episode(env, controller, seed=seed, options=options, observers=[log, *observers]):
        pass
    return log.trajectory()
