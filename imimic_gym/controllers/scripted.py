"""Scripted controllers: a PD tracker of any target-angle source, and the oracle.

A controller has ``reset()`` and ``__call__(obs) -> action``. It reads the robot state
from ``obs["qpos"]``/``obs["qvel"]`` and its targets from a `TargetSource`; it never looks
at pixels (estimator wrappers turn pixels into targets upstream).
"""

from __future__ import annotations

from typing import Any, Protocol

import gymnasium as gym
import mujoco
import numpy as np

from imimic_gym.metrics import wrap_angle

__all__ = ["EstimateTarget", "OracleController", "PDController", "TargetSource", "TruthTarget"]


class TargetSource(Protocol):
    """Where a controller's target joint angles (rad, shape (n,)) come from."""

    def reset(self) -> None: ...

    def __call__(self, obs: dict[str, Any]) -> np.ndarray: ...


class TruthTarget:
    """The clip's true angles ``lookahead`` frames after the one the env shows.

    The reward compares the robot with the frame shown after the step, so reading one
    frame ahead is exactly what a perfect estimator with no latency would give: this is
    the upper bound that every estimator is measured against.
    """

    def __init__(self, env: gym.Env, lookahead: int = 1) -> None:
        self.env, self.lookahead = env.unwrapped, lookahead

    def reset(self) -> None:
        """Stateless: the env's ``frame_index`` says where the clip is."""

    def __call__(self, obs: dict[str, Any]) -> np.ndarray:
        return self.env.target_angles(self.env.frame_index + self.lookahead)


class EstimateTarget:
    """Targets from an estimator wrapper's ``obs["estimate"]``, led by ``lead_frames``.

    The estimate describes the frame the env shows; the reward compares the robot with
    the next one. Leading the angle by omega / fps (one frame) removes that frame of lag.
    """

    def __init__(self, env: gym.Env, lead_frames: float = 1.0) -> None:
        from imimic_gym.wrappers.estimator import estimate_fields

        inner = env.unwrapped
        self.fields = estimate_fields(inner.arm.n_links)
        self.lead_s = lead_frames / float(inner.clip.fps)

    def reset(self) -> None:
        """Stateless: everything it needs is in the observation."""

    def __call__(self, obs: dict[str, Any]) -> np.ndarray:
        estimate = obs["estimate"]
        angles = estimate[self.fields["angles"]].astype(np.float64)
        return angles + self.lead_s * estimate[self.fields["omega"]]


class PDController:
    """Tracks a target-angle source through any of the env's actuation modes.

    - position: the command is the target angle; the servo closes the loop itself.
    - velocity: command = kp * error, kp = omega (1/s): a first-order loop around the
      velocity servo.
    - torque: command = M(q) (kp * error - kd * qvel) + bias(q, qvel), with
      kp = omega^2, kd = 2 omega (critically damped), M the robot model's mass matrix and
      bias its gravity and Coriolis torques at the observed state. The PD acts on joint
      accelerations and M turns them into torques, so the links' coupling does not
      detune it, and a vertical arm does not sag under gravity.

    omega = 2 pi ``bandwidth_hz``. The loop is closed once per video frame, so the
    bandwidth must stay well below the frame rate (4 Hz at 30 fps: omega dt = 0.84).

    Args:
        env: the (wrapped) ImitateVideo env, for the actuator ranges and the arm.
        target: a `TargetSource`.
        bandwidth_hz: closed-loop bandwidth for velocity and torque control.
        kp, kd: explicit gains (1/s for velocity; 1/s^2 and 1/s for torque), overriding
            the ones derived from ``bandwidth_hz``.
    """

    def __init__(self, env: gym.Env, target: TargetSource, bandwidth_hz: float = 4.0,
                 kp: float | np.ndarray | None = None,
                 kd: float | np.ndarray | None = None) -> None:
        self.env, self.target = env.unwrapped, target
        self.control = self.env.control
        omega = 2 * np.pi * bandwidth_hz
        derived_kp = {"position": 1.0, "velocity": omega, "torque": omega**2}
        derived_kd = {"position": 0.0, "velocity": 0.0, "torque": 2 * omega}
        self.kp = derived_kp[self.control] if kp is None else kp
        self.kd = derived_kd[self.control] if kd is None else kd
        self._model = self.env.model
        self._data = mujoco.MjData(self._model)  # a scratch copy: the env's stays untouched

    def _dynamics(self, qpos: np.ndarray, qvel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Mass matrix (n, n) and bias torques (n,) of the robot model at this state."""
        self._data.qpos[:], self._data.qvel[:] = qpos, qvel
        mujoco.mj_forward(self._model, self._data)
        mass = np.zeros((self._model.nv, self._model.nv))
        mujoco.mj_fullM(self._model, self._data, mass)
        return mass, self._data.qfrc_bias.copy()

    def reset(self) -> None:
        self.target.reset()

    def __call__(self, obs: dict[str, Any]) -> np.ndarray:
        target = np.asarray(self.target(obs), dtype=np.float64)
        if self.control == "position":
            return self.env.command_to_action(target)
        error = wrap_angle(target - obs["qpos"])
        if self.control == "velocity":
            return self.env.command_to_action(self.kp * error)
        mass, bias = self._dynamics(obs["qpos"], obs["qvel"])
        acceleration = self.kp * error - self.kd * obs["qvel"]
        return self.env.command_to_action(mass @ acceleration + bias)


def OracleController(env: gym.Env) -> PDController:
    """A PD controller fed the true angles one frame ahead: the upper bound."""
    return PDController(env, TruthTarget(env))
