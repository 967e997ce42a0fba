"""Scripted controllers: a PD tracker of any target-angle source, the oracle, and the
three estimate-driven trackers of the evaluation suite (position, velocity, torque).

A controller has ``reset()`` and ``__call__(obs) -> action``. It reads the robot state
from ``obs["qpos"]``/``obs["qvel"]`` and its targets from a `TargetSource` or from
``obs["estimate"]``; it never looks at pixels (estimator wrappers turn pixels into
targets upstream).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol

import gymnasium as gym
import mujoco
import numpy as np

from imimic_gym.envs.imitate_video import imitate_env
from imimic_gym.estimators.types import estimate_fields
from imimic_gym.kinematics import wrap_angle

__all__ = [
    "SCRIPTED_CONTROLLERS", "EstimateTarget", "OracleController", "PDController",
    "PositionController", "TargetSource", "TorqueController", "TruthTarget",
    "VelocityController",
]


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
        self.env, self.lookahead = imitate_env(env), lookahead

    def reset(self) -> None:
        """Stateless: the env's ``frame_index`` says where the clip is."""

    def __call__(self, obs: dict[str, Any]) -> np.ndarray:
        if self.env.frame_index is None:
            raise RuntimeError("call the env's reset() before asking for a target")
        return self.env.target_angles(self.env.frame_index + self.lookahead)


class EstimateTarget:
    """Targets from an estimator wrapper's ``obs["estimate"]``, led by ``lead_frames``.

    The estimate describes the frame the env shows; the reward compares the robot with
    the next one. Leading the angle by omega / fps (one frame) removes that frame of lag.

    Until the estimator has read the arm at all (its trust is still 0: a frame-
    differencing estimator sees nothing before the arm moves, and meanwhile reports a
    placeholder, the middle of the joint range) the target is the robot's first observed
    pose, at rest: the robot starts where the arm is, and chasing the placeholder would
    drive it away and back. Everything this uses is in the observation.
    """

    def __init__(self, env: gym.Env, lead_frames: float = 1.0) -> None:
        inner = imitate_env(env)
        self.fields = estimate_fields(inner.arm.n_joints)
        self.lead_s = lead_frames / float(inner.clip.fps)
        self.reset()

    def reset(self) -> None:
        """Forget the episode's start pose: wait for the estimator's first reading."""
        self._start: np.ndarray | None = None
        self._read = False

    def reference(self, obs: dict[str, Any]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The led target: angles (rad), omega (rad/s) and alpha (rad/s^2), each (n,).

        The angle is led by omega * lead and omega by alpha * lead, so the three stay
        consistent with one another for the feed-forward controllers.
        """
        estimate = obs["estimate"]
        angles, omega, alpha = (estimate[self.fields[k]].astype(np.float64)
                                for k in ("angles", "omega", "alpha"))
        if not self._read:
            if self._start is None:
                self._start = np.asarray(obs["qpos"], dtype=np.float64).copy()
            if estimate[self.fields["trust"]][0] <= 0.0:
                return self._start.copy(), np.zeros_like(omega), np.zeros_like(alpha)
            self._read = True
        return angles + self.lead_s * omega, omega + self.lead_s * alpha, alpha

    def __call__(self, obs: dict[str, Any]) -> np.ndarray:
        return self.reference(obs)[0]


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
        self.env, self.target = imitate_env(env), target
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


def _require_control(env: gym.Env, control: str, name: str) -> None:
    if imitate_env(env).control != control:
        raise ValueError(f"{name} drives control={control!r} actuation; this env has "
                         f"control={imitate_env(env).control!r}")


def PositionController(env: gym.Env, lead_frames: float = 1.0) -> PDController:
    """The paper's setting: the servo's target is the estimated angle (led by one frame of
    the estimated omega), and the servo closes the loop itself. Needs
    ``control="position"`` and an estimator wrapper's ``obs["estimate"]``; holds the
    start pose until the estimator's first reading (`EstimateTarget`)."""
    _require_control(env, "position", "PositionController")
    return PDController(env, EstimateTarget(env, lead_frames))


class VelocityController(PDController):
    """Velocity feed-forward plus a position correction (needs ``control="velocity"``):
    command = omega_est + kp * wrap(q_est - q), with kp = 2 pi ``bandwidth_hz`` (1/s).

    The estimated omega moves the robot with the arm at once; the position term only
    removes what the feed-forward got wrong, so the loop needs less gain (less noise
    amplified) than `PDController`'s pure position feedback for the same lag. The angle
    is not led by default (``lead_frames=0``): the feed-forward already carries the robot
    into the next frame, and leading the angle as well counts that frame twice (the robot
    then runs a frame ahead of the arm).
    """

    def __init__(self, env: gym.Env, bandwidth_hz: float = 4.0,
                 lead_frames: float = 0.0) -> None:
        _require_control(env, "velocity", "VelocityController")
        self.reference = EstimateTarget(env, lead_frames)
        super().__init__(env, self.reference, bandwidth_hz=bandwidth_hz)

    def __call__(self, obs: dict[str, Any]) -> np.ndarray:
        angles, omega, _ = self.reference.reference(obs)
        command = omega + self.kp * wrap_angle(angles - obs["qpos"])
        return self.env.command_to_action(command)


class TorqueController(PDController):
    """Computed torque (needs ``control="torque"``): the estimated acceleration through
    the robot model's inverse dynamics, plus PD on the estimated angle and omega.

    qacc = alpha_est + kp * wrap(q_est - q) + kd * (omega_est - qvel), and
    tau = mj_inverse(q, qvel, qacc) = M(q) qacc + bias(q, qvel); kp = omega^2 and
    kd = 2 omega (critically damped, omega = 2 pi ``bandwidth_hz``). DON's alpha is a
    second difference of its angles and noisy, so it enters scaled by
    ``alpha_feedforward`` (1 = the textbook computed-torque law). Not led by default, for
    the reason `VelocityController` gives.
    """

    def __init__(self, env: gym.Env, bandwidth_hz: float = 4.0, lead_frames: float = 0.0,
                 alpha_feedforward: float = 1.0) -> None:
        _require_control(env, "torque", "TorqueController")
        self.reference = EstimateTarget(env, lead_frames)
        self.alpha_feedforward = alpha_feedforward
        super().__init__(env, self.reference, bandwidth_hz=bandwidth_hz)

    def __call__(self, obs: dict[str, Any]) -> np.ndarray:
        angles, omega, alpha = self.reference.reference(obs)
        qacc = (self.alpha_feedforward * alpha + self.kp * wrap_angle(angles - obs["qpos"])
                + self.kd * (omega - obs["qvel"]))
        self._data.qpos[:], self._data.qvel[:] = obs["qpos"], obs["qvel"]
        self._data.qacc[:] = qacc
        mujoco.mj_inverse(self._model, self._data)
        return self.env.command_to_action(self._data.qfrc_inverse.copy())


SCRIPTED_CONTROLLERS: dict[str, Callable[..., PDController]] = {
    "position": PositionController,
    "velocity": VelocityController,
    "torque": TorqueController,
}
"""Each estimate-driven scripted controller by name, with the control mode it needs."""
